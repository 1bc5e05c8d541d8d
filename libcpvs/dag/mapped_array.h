#pragma once
// A growable array of trivially copyable values in an anonymous mapping of its own. Growing remaps its pages
// (mremap) instead of copying them into a new allocation, so the node tables of a large view — gigabytes on a
// forest — are neither copied at every doubling nor zeroed twice by the kernel, as a std::vector's would be
// (docs/construction.md, "Memory"). Huge pages are asked for once it is large, as the tools' allocator does.
#include <sys/mman.h>

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <new>
#include <span>
#include <type_traits>
#include <utility>

namespace cpvs {

template <class T>
class MappedArray {
  static_assert(std::is_trivially_copyable_v<T>);

public:
  MappedArray() = default;
  MappedArray(const MappedArray&) = delete;
  MappedArray& operator=(const MappedArray&) = delete;
  MappedArray(MappedArray&& other) noexcept { swap(other); }
  MappedArray& operator=(MappedArray&& other) noexcept {
    MappedArray(std::move(other)).swap(*this);
    return *this;
  }
  ~MappedArray() {
    if (data_) ::munmap(data_, capacityBytes_);
  }

  size_t size() const { return size_; }
  const T& operator[](size_t i) const { return data_[i]; }
  T& operator[](size_t i) { return data_[i]; }
  std::span<const T> span() const { return {data_, size_}; }
  // Bytes mapped (resident as far as they were touched).
  size_t capacityBytes() const { return capacityBytes_; }

  void append(const T* values, size_t count) {
    if (count == 0) return;  // values may be null then, which memcpy does not allow
    reserve(size_ + count);
    std::memcpy(data_ + size_, values, count * sizeof(T));
    size_ += count;
    written_ = std::max(written_, size_);
  }

  // New values are zero: fresh pages of an anonymous mapping are, and values once written are cleared.
  void resize(size_t count) {
    reserve(count);
    if (count > size_ && written_ > size_) std::memset(data_ + size_, 0, (std::min(count, written_) - size_) * sizeof(T));
    size_ = count;
    written_ = std::max(written_, size_);
  }

  // Gives the whole pages below value `end` back to the kernel: a consumer that walks the array once frees it
  // as it goes. Those values read as zero afterwards.
  void discardBefore(size_t end) {
    constexpr size_t kPage = 4096;
    const size_t bytes = std::min(end, size_) * sizeof(T) / kPage * kPage;
    if (bytes > discarded_) ::madvise(reinterpret_cast<char*>(data_) + discarded_, bytes - discarded_, MADV_DONTNEED);
    discarded_ = std::max(discarded_, bytes);
  }

  void reserve(size_t count) {
    if (count * sizeof(T) <= capacityBytes_) return;
    // Pages while small (a view has a table per level, most of them small), huge pages once it is large.
    constexpr size_t kPage = 4096, kHugePage = size_t(2) << 20;
    const size_t wanted = std::max(count * sizeof(T), 2 * capacityBytes_);
    const size_t granule = wanted >= kHugePage ? kHugePage : kPage;
    const size_t bytes = (wanted + granule - 1) / granule * granule;
    void* at = data_ ? ::mremap(data_, capacityBytes_, bytes, MREMAP_MAYMOVE)
                     : ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (at == MAP_FAILED) throw std::bad_alloc();
    if (granule == kHugePage) ::madvise(at, bytes, MADV_HUGEPAGE);  // a hint: ignored where huge pages are off
    data_ = static_cast<T*>(at);
    capacityBytes_ = bytes;
  }

private:
  void swap(MappedArray& other) noexcept {
    std::swap(data_, other.data_);
    std::swap(size_, other.size_);
    std::swap(capacityBytes_, other.capacityBytes_);
    std::swap(written_, other.written_);
    std::swap(discarded_, other.discarded_);
  }

  T* data_ = nullptr;
  size_t size_ = 0;
  size_t capacityBytes_ = 0;
  size_t written_ = 0;    // values [0, written_) may be non-zero
  size_t discarded_ = 0;  // bytes at the front given back by discardBefore
};

}  // namespace cpvs

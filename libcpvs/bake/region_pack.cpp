#include "libcpvs/bake/region_pack.h"

#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

constexpr char kMagic[8] = {'C', 'P', 'V', 'S', 'R', 'G', 'N', '2'};
constexpr size_t kHeaderBytes = 24, kFooterBytes = 32, kEntryBytes = 32;

void putWord(std::string& out, uint64_t value) {
  for (unsigned b = 0; b < 8; ++b) out.push_back(char(uint8_t(value >> (8 * b))));
}

uint64_t wordAt(const char* bytes) {
  uint64_t value = 0;
  for (unsigned b = 0; b < 8; ++b) value |= uint64_t(uint8_t(bytes[b])) << (8 * b);
  return value;
}

// Reads exactly `n` bytes at `offset`; false when the file ends first.
bool readAt(int fd, char* out, size_t n, uint64_t offset) {
  while (n > 0) {
    const ssize_t got = ::pread(fd, out, n, off_t(offset));
    if (got <= 0) return false;
    out += got;
    n -= size_t(got);
    offset += uint64_t(got);
  }
  return true;
}

}  // namespace

RegionPackReader::RegionPackReader(const std::string& path, uint64_t frameKey) : path_(path) {
  const auto fail = [&](const std::string& why) { throw Error(ErrorCategory::InvalidInput, path_ + ": " + why); };
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) fail("cannot be opened");
  try {
    struct stat info {};
    if (::fstat(fd_, &info) != 0 || uint64_t(info.st_size) < kHeaderBytes + kFooterBytes) fail("too short for a region pack");
    const uint64_t size = uint64_t(info.st_size);
    char head[kHeaderBytes], foot[kFooterBytes];
    if (!readAt(fd_, head, kHeaderBytes, 0) || !readAt(fd_, foot, kFooterBytes, size - kFooterBytes))
      fail("cannot be read");
    if (std::memcmp(head, kMagic, 8) != 0 || std::memcmp(foot + 24, kMagic, 8) != 0)
      fail("not a region pack of this version");
    const uint64_t count = wordAt(foot), indexAt = wordAt(foot + 8);
    if (indexAt < kHeaderBytes || indexAt > size - kFooterBytes || (size - kFooterBytes - indexAt) / kEntryBytes != count ||
        (size - kFooterBytes - indexAt) % kEntryBytes != 0)
      fail("its index does not fit the file (cut short?)");
    std::string index(size_t(count * kEntryBytes), '\0');
    if (!readAt(fd_, index.data(), index.size(), indexAt)) fail("cannot be read");
    std::string hashed(head, kHeaderBytes);
    hashed += index;
    if (XXH3_64bits(hashed.data(), hashed.size()) != wordAt(foot + 16)) fail("checksum mismatch (damaged)");
    if (wordAt(head + 8) != frameKey) fail("a region pack of another view");
    lightKey_ = wordAt(head + 16);
    index_.resize(count);
    for (size_t r = 0; r < count; ++r) {
      const char* e = index.data() + r * kEntryBytes;
      index_[r] = {wordAt(e), wordAt(e + 8), wordAt(e + 16), wordAt(e + 24)};
      if (index_[r].offset < kHeaderBytes || index_[r].length > indexAt - index_[r].offset)
        fail("region " + std::to_string(r) + " lies outside the records");
    }
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

RegionPackReader::~RegionPackReader() {
  if (fd_ >= 0) ::close(fd_);
}

RegionPackReader::RegionPackReader(RegionPackReader&& other) noexcept
    : path_(std::move(other.path_)), fd_(other.fd_), lightKey_(other.lightKey_), index_(std::move(other.index_)) {
  other.fd_ = -1;
}

std::string RegionPackReader::record(size_t region) const {
  const Entry& e = index_[region];
  std::string bytes(size_t(e.length), '\0');
  if (!readAt(fd_, bytes.data(), bytes.size(), e.offset) || XXH3_64bits(bytes.data(), bytes.size()) != e.hash)
    throw Error(ErrorCategory::InvalidInput, path_ + ": region " + std::to_string(region) + " is damaged");
  return bytes;
}

RegionPackWriter::RegionPackWriter(int fd, std::string name, uint64_t frameKey, uint64_t lightKey)
    : fd_(fd), name_(std::move(name)) {
  head_.assign(kMagic, sizeof kMagic);
  putWord(head_, frameKey);
  putWord(head_, lightKey);
  write(head_);
}

void RegionPackWriter::write(std::string_view bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n <= 0) throw Error(ErrorCategory::OutputFailed, name_ + ": cannot write the region pack");
    done += size_t(n);
  }
  offset_ += bytes.size();
}

void RegionPackWriter::add(uint64_t key, std::string_view record) {
  index_.insert(index_.end(), {key, offset_, record.size(), XXH3_64bits(record.data(), record.size())});
  write(record);
}

void RegionPackWriter::finish() {
  std::string tail;
  for (const uint64_t word : index_) putWord(tail, word);
  const uint64_t indexAt = offset_;
  std::string hashed = head_ + tail;
  putWord(tail, index_.size() / 4);
  putWord(tail, indexAt);
  putWord(tail, XXH3_64bits(hashed.data(), hashed.size()));
  tail.append(kMagic, sizeof kMagic);
  write(tail);
}

}  // namespace cpvs

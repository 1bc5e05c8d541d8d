// portability.h's ReadOnlyFile: POSIX mmap, the Windows file mapping, or the file read whole where neither exists.
#include "libcpvs/runtime/portability.h"

#include <cerrno>
#include <cstring>
#include <utility>

#if defined(_WIN32)
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
#elif defined(__unix__) || defined(__APPLE__)
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#else
#include <fstream>
#endif

namespace cpvs::portable {

ReadOnlyFile::~ReadOnlyFile() { release(); }

ReadOnlyFile::ReadOnlyFile(ReadOnlyFile&& other) noexcept { *this = std::move(other); }

ReadOnlyFile& ReadOnlyFile::operator=(ReadOnlyFile&& other) noexcept {
  if (this != &other) {
    release();
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    mapping_ = std::exchange(other.mapping_, nullptr);
    mappingHandle_ = std::exchange(other.mappingHandle_, nullptr);
    owned_ = std::move(other.owned_);
  }
  return *this;
}

#if defined(_WIN32)

void ReadOnlyFile::release() {
  if (mapping_) UnmapViewOfFile(mapping_);
  if (mappingHandle_) CloseHandle(mappingHandle_);
  mapping_ = mappingHandle_ = nullptr;
  data_ = nullptr;
  size_ = 0;
  owned_.clear();
}

bool ReadOnlyFile::open(const std::string& path, std::string& error) {
  release();
  const auto reason = [] { return "Windows error " + std::to_string(GetLastError()); };
  HANDLE file = CreateFileA(path.c_str(), GENERIC_READ, FILE_SHARE_READ, nullptr, OPEN_EXISTING,
                            FILE_ATTRIBUTE_NORMAL, nullptr);
  if (file == INVALID_HANDLE_VALUE) return error = "cannot open: " + reason(), false;
  if (GetFileType(file) != FILE_TYPE_DISK) {
    CloseHandle(file);
    return error = "not a regular file", false;
  }
  LARGE_INTEGER size;
  if (!GetFileSizeEx(file, &size)) {
    error = "cannot stat: " + reason();
    CloseHandle(file);
    return false;
  }
  size_ = uint64_t(size.QuadPart);
  if (size_ > 0) {
    mappingHandle_ = CreateFileMappingA(file, nullptr, PAGE_READONLY, 0, 0, nullptr);
    mapping_ = mappingHandle_ ? MapViewOfFile(mappingHandle_, FILE_MAP_READ, 0, 0, 0) : nullptr;
    if (!mapping_) {
      error = "cannot map: " + reason();
      CloseHandle(file);
      release();
      return false;
    }
    data_ = static_cast<const uint8_t*>(mapping_);
  }
  CloseHandle(file);
  return true;
}

#elif defined(__unix__) || defined(__APPLE__)

void ReadOnlyFile::release() {
  if (mapping_) ::munmap(mapping_, size_t(size_));
  mapping_ = nullptr;
  data_ = nullptr;
  size_ = 0;
  owned_.clear();
}

bool ReadOnlyFile::open(const std::string& path, std::string& error) {
  release();
  // O_NONBLOCK: opening a FIFO must not wait for a writer (fstat below refuses anything but a regular file).
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) return error = std::string("cannot open: ") + std::strerror(errno), false;
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    error = std::string("cannot stat: ") + std::strerror(errno);
    ::close(fd);
    return false;
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(fd);
    return error = "not a regular file", false;
  }
  size_ = uint64_t(st.st_size);
  if (size_ > 0) {
    void* m = ::mmap(nullptr, size_t(size_), PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      error = std::string("cannot map: ") + std::strerror(errno);
      ::close(fd);
      size_ = 0;
      return false;
    }
    mapping_ = m;
    data_ = static_cast<const uint8_t*>(m);
  }
  ::close(fd);
  return true;
}

#else  // neither: the file read whole

void ReadOnlyFile::release() {
  data_ = nullptr;
  size_ = 0;
  owned_.clear();
}

bool ReadOnlyFile::open(const std::string& path, std::string& error) {
  release();
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return error = "cannot open: no such file or not readable", false;
  const std::streamoff size = in.tellg();
  if (size < 0) return error = "cannot stat: its size is unknown", false;
  owned_.resize((size_t(size) + 7) / 8);
  in.seekg(0);
  if (size > 0 && !in.read(reinterpret_cast<char*>(owned_.data()), size)) return error = "cannot map: a read failed", false;
  data_ = reinterpret_cast<const uint8_t*>(owned_.data());
  size_ = uint64_t(size);
  return true;
}

#endif

}  // namespace cpvs::portable

#include "libcpvs/bake/region_pack.h"

#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <xxhash.h>
#include <zstd.h>

#include "libcpvs/base/error.h"

namespace cpvs {
namespace {

constexpr char kMagic[8] = {'C', 'P', 'V', 'S', 'R', 'G', 'N', '3'};
constexpr size_t kHeaderBytes = 24, kFooterBytes = 40, kEntryWords = 5, kBlockWords = 3;
constexpr size_t kBlockTarget = size_t(1) << 20;  // records a block collects before it is compressed
constexpr int kLevel = 1;                         // zstd's fastest level: a pack is written by every cached bake

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
    if (std::memcmp(head, kMagic, 8) != 0 || std::memcmp(foot + 32, kMagic, 8) != 0)
      fail("not a region pack of this version");
    const uint64_t count = wordAt(foot), blockCount = wordAt(foot + 8), indexAt = wordAt(foot + 16);
    const uint64_t tableBytes = size - kFooterBytes - std::min(indexAt, size - kFooterBytes);
    if (indexAt < kHeaderBytes || count > tableBytes / (8 * kEntryWords) || blockCount > tableBytes / (8 * kBlockWords) ||
        8 * (kEntryWords * count + kBlockWords * blockCount) != tableBytes)
      fail("its index does not fit the file (cut short?)");
    std::string tables(size_t(tableBytes), '\0');
    if (!readAt(fd_, tables.data(), tables.size(), indexAt)) fail("cannot be read");
    std::string hashed(head, kHeaderBytes);
    hashed += tables;
    if (XXH3_64bits(hashed.data(), hashed.size()) != wordAt(foot + 24)) fail("checksum mismatch (damaged)");
    if (wordAt(head + 8) != frameKey) fail("a region pack of another view");
    lightKey_ = wordAt(head + 16);
    const char* blockTable = tables.data() + 8 * kEntryWords * count;
    for (size_t b = 0; b < blockCount; ++b) {
      const char* e = blockTable + 8 * kBlockWords * b;
      const Block block{wordAt(e), wordAt(e + 8), wordAt(e + 16)};
      if (block.offset < kHeaderBytes || block.offset > indexAt || block.size > indexAt - block.offset ||
          block.bytes > (uint64_t(1) << 34))
        fail("block " + std::to_string(b) + " lies outside the blocks");
      blocks_.push_back(block);
    }
    index_.resize(count);
    for (size_t r = 0; r < count; ++r) {
      const char* e = tables.data() + 8 * kEntryWords * r;
      Entry& entry = index_[r];
      entry = {wordAt(e), wordAt(e + 8), wordAt(e + 16), wordAt(e + 24), wordAt(e + 32)};
      if (entry.length > 0 && (entry.block >= blockCount || entry.offset > blocks_[entry.block].bytes ||
                               entry.length > blocks_[entry.block].bytes - entry.offset))
        fail("region " + std::to_string(r) + " lies outside its block");
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
    : path_(std::move(other.path_)), fd_(other.fd_), lightKey_(other.lightKey_), index_(std::move(other.index_)),
      blocks_(std::move(other.blocks_)), loaded_(other.loaded_), bytes_(std::move(other.bytes_)) {
  other.fd_ = -1;
}

void RegionPackReader::loadBlock(uint64_t block) {
  if (loaded_ == block) return;
  loaded_ = UINT64_MAX;
  const Block& b = blocks_[block];
  std::string compressed(size_t(b.size), '\0');
  bytes_.resize(size_t(b.bytes));
  if (!readAt(fd_, compressed.data(), compressed.size(), b.offset) ||
      ZSTD_decompress(bytes_.data(), bytes_.size(), compressed.data(), compressed.size()) != b.bytes)
    throw Error(ErrorCategory::InvalidInput, path_ + ": block " + std::to_string(block) + " is damaged");
  loaded_ = block;
}

std::string RegionPackReader::record(size_t region) {
  const Entry& e = index_[region];
  if (e.length == 0) return {};
  loadBlock(e.block);
  std::string bytes = bytes_.substr(size_t(e.offset), size_t(e.length));
  if (XXH3_64bits(bytes.data(), bytes.size()) != e.hash)
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

void RegionPackWriter::flushBlock() {
  if (block_.empty()) return;
  std::string compressed(ZSTD_compressBound(block_.size()), '\0');
  const size_t size = ZSTD_compress(compressed.data(), compressed.size(), block_.data(), block_.size(), kLevel);
  if (ZSTD_isError(size)) throw Error(ErrorCategory::RuntimeFailure, name_ + ": zstd: " + ZSTD_getErrorName(size));
  blocks_.insert(blocks_.end(), {offset_, size, block_.size()});
  write({compressed.data(), size});
  std::string().swap(block_);  // a block may hold one large record: do not keep its capacity
}

void RegionPackWriter::add(uint64_t key, std::string_view record) {
  if (!block_.empty() && block_.size() + record.size() > kBlockTarget) flushBlock();
  index_.insert(index_.end(), {key, blocks_.size() / kBlockWords, block_.size(), record.size(),
                               XXH3_64bits(record.data(), record.size())});
  block_ += record;
}

void RegionPackWriter::finish() {
  flushBlock();
  std::string tables;
  for (const uint64_t word : index_) putWord(tables, word);
  for (const uint64_t word : blocks_) putWord(tables, word);
  const uint64_t indexAt = offset_;
  const std::string hashed = head_ + tables;
  putWord(tables, index_.size() / kEntryWords);
  putWord(tables, blocks_.size() / kBlockWords);
  putWord(tables, indexAt);
  putWord(tables, XXH3_64bits(hashed.data(), hashed.size()));
  tables.append(kMagic, sizeof kMagic);
  write(tables);
}

}  // namespace cpvs

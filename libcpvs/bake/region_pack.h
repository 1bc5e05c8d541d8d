#pragma once
// The region records of one view, as the bake cache keeps them (docs/incremental-bakes.md): per region of the
// view, in splitIntoRegions' order, its key and its DAG events (libcpvs/dag/region_record.h). One file per view
// frame, so that a re-bake after an edit finds the records of the regions the edit did not reach.
//
// The file is written region by region as the bake goes and read region by region as the next bake goes, so
// neither bake holds a pack in memory (an incremental bake must not need more memory than a clean one). Records
// are zstd-compressed in blocks of consecutive regions (about 1 MiB of records each, or one larger record): a
// region records again the nodes it shares with its neighbours, which compresses well, and a reader that takes
// the regions in order decompresses each block once.
// Coding (little-endian u64 words unless said):
//   header  "CPVSRGN3", the frame key, the key of the light entry stored with it (BakeCache::pathOf)
//   blocks  one zstd frame each, one after another
//   index   per region: its key, its block, the record's offset in the block's bytes and its length, an XXH3-64 of
//           the record
//   blocks  per block: its offset in the file, its compressed and its decompressed size
//   footer  the region count, the block count, the index's offset, an XXH3-64 of the header, the index and the
//           block table, "CPVSRGN3"
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cpvs {

class RegionPackReader {
public:
  // Opens the pack at `path` for `frameKey`: checks its header, footer, index and block table (each block and
  // record is checked when read). Throws Error(InvalidInput) naming the file when it is damaged, cut short or
  // another frame's.
  RegionPackReader(const std::string& path, uint64_t frameKey);
  ~RegionPackReader();
  RegionPackReader(RegionPackReader&& other) noexcept;
  RegionPackReader(const RegionPackReader&) = delete;
  RegionPackReader& operator=(const RegionPackReader&) = delete;
  RegionPackReader& operator=(RegionPackReader&&) = delete;

  uint64_t lightKey() const { return lightKey_; }
  size_t size() const { return index_.size(); }
  uint64_t key(size_t region) const { return index_[region].key; }
  // The record of `region`. Throws Error(InvalidInput) when its block does not decompress or it does not match
  // its hash. Not for two threads at once (it keeps the last block decompressed).
  std::string record(size_t region);

private:
  struct Entry {
    uint64_t key, block, offset, length, hash;
  };
  struct Block {
    uint64_t offset, size, bytes;
  };
  void loadBlock(uint64_t block);

  std::string path_;
  int fd_ = -1;
  uint64_t lightKey_ = 0;
  std::vector<Entry> index_;
  std::vector<Block> blocks_;
  uint64_t loaded_ = UINT64_MAX;  // the block in `bytes_`
  std::string bytes_;
};

class RegionPackWriter {
public:
  // Writes a pack to `fd` (open for writing, empty); `name` is for messages.
  RegionPackWriter(int fd, std::string name, uint64_t frameKey, uint64_t lightKey);
  // Appends the next region's key and record (an empty record: a region with nothing to replay).
  void add(uint64_t key, std::string_view record);
  // Writes the last block, the index, the block table and the footer. Throws Error(OutputFailed), as add does
  // when a write fails.
  void finish();

private:
  void write(std::string_view bytes);
  void flushBlock();

  int fd_;
  std::string name_;
  uint64_t offset_ = 0;
  std::string head_;   // the header's bytes, for the footer's hash
  std::string block_;  // the records of the block being filled
  std::vector<uint64_t> index_, blocks_;
};

}  // namespace cpvs

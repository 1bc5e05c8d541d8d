#pragma once
// The region records of one view, as the bake cache keeps them (docs/incremental-bakes.md): per region of the
// view, in splitIntoRegions' order, its key and its DAG events (libcpvs/dag/region_record.h). One file per view
// frame, so that a re-bake after an edit finds the records of the regions the edit did not reach.
//
// The file is written region by region as the bake goes and read region by region as the next bake goes, so
// neither bake holds a pack in memory (an incremental bake must not need more memory than a clean one).
// Coding (little-endian u64 words unless said):
//   header  "CPVSRGN2", the frame key, the key of the light entry stored with it (BakeCache::pathOf)
//   records one after another (bytes)
//   index   per region: its key, the record's offset and length, an XXH3-64 of the record
//   footer  the region count, the index's offset, an XXH3-64 of the header and the index, "CPVSRGN2"
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cpvs {

class RegionPackReader {
public:
  // Opens the pack at `path` for `frameKey`: checks its header, footer and index (each record is checked when
  // read). Throws Error(InvalidInput) naming the file when it is damaged, cut short or another frame's.
  RegionPackReader(const std::string& path, uint64_t frameKey);
  ~RegionPackReader();
  RegionPackReader(RegionPackReader&& other) noexcept;
  RegionPackReader(const RegionPackReader&) = delete;
  RegionPackReader& operator=(const RegionPackReader&) = delete;
  RegionPackReader& operator=(RegionPackReader&&) = delete;

  uint64_t lightKey() const { return lightKey_; }
  size_t size() const { return index_.size(); }
  uint64_t key(size_t region) const { return index_[region].key; }
  // The record of `region`. Throws Error(InvalidInput) when it does not match its hash.
  std::string record(size_t region) const;

private:
  struct Entry {
    uint64_t key, offset, length, hash;
  };
  std::string path_;
  int fd_ = -1;
  uint64_t lightKey_ = 0;
  std::vector<Entry> index_;
};

class RegionPackWriter {
public:
  // Writes a pack to `fd` (open for writing, empty); `name` is for messages.
  RegionPackWriter(int fd, std::string name, uint64_t frameKey, uint64_t lightKey);
  // Appends the next region's key and record (an empty record: a region with nothing to replay).
  void add(uint64_t key, std::string_view record);
  // Writes the index and the footer. Throws Error(OutputFailed), as add does when a write fails.
  void finish();

private:
  void write(std::string_view bytes);

  int fd_;
  std::string name_;
  uint64_t offset_ = 0;
  std::string head_;  // the header's bytes, for the footer's hash
  std::vector<uint64_t> index_;
};

}  // namespace cpvs

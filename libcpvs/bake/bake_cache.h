#pragma once
// A folder of finished light bakes keyed by what each one depends on, so that a re-bake after a light or a mesh
// moved re-bakes only the lights whose inputs changed (docs/many-lights.md, "The bake cache").
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "libcpvs/bake/cpvs_writer.h"
#include "libcpvs/bake/bake_keys.h"
#include "libcpvs/bake/region_pack.h"

namespace cpvs {

class BakeCache {
public:
  // Creates the folder if needed. Throws Error(OutputFailed) when it cannot be created or written.
  explicit BakeCache(std::string folder);

  // The light baked under `key`, with `light`'s own record (name, colour, intensity) in place. Nothing when
  // the entry is missing, or is damaged or from another key (then `problem` says so; the caller bakes again).
  std::optional<BakedLight> find(uint64_t key, const Light& light, std::string* problem = nullptr) const;
  class NewEntry;
  // Writes a finished light for `key`: a one-light .cpvs in a temporary of the folder, which the returned
  // entry's commit() renames into place, so a reader (or another bake sharing the folder) never sees half an
  // entry, and a bake that fails or is cancelled before committing leaves none. Throws Error(OutputFailed).
  std::unique_ptr<NewEntry> write(uint64_t key, const BakedLight& baked) const;

  std::string pathOf(uint64_t key) const;

  // The region records of the view whose frame key is `frameKey` (region_pack.h), from the last bake of that
  // view frame that stored them. Nothing when there are none, or when the file is damaged or another frame's
  // (then `problem` says so).
  std::optional<RegionPackReader> findRegions(uint64_t frameKey, std::string* problem = nullptr) const;

  // A cache file being written: a temporary in the folder, renamed to its name by commit() (so a reader, or a
  // bake sharing the folder, never sees half of it), removed if never committed. Throws Error(OutputFailed).
  class NewEntry {
  public:
    NewEntry(const std::string& folder, std::string path, uint64_t key);
    ~NewEntry();
    NewEntry(const NewEntry&) = delete;
    NewEntry& operator=(const NewEntry&) = delete;
    int fd() const { return fd_; }
    const std::string& path() const { return path_; }
    // Flushes and closes the temporary (a bake keeps its entries closed until it commits them all).
    void close();
    void commit();

  private:
    std::string path_, temp_;
    int fd_ = -1;
  };
  // The region pack of `frameKey`, to be written (it replaces the frame's previous one when committed).
  std::unique_ptr<NewEntry> newRegions(uint64_t frameKey) const;
  std::string regionsPathOf(uint64_t frameKey) const;
  // Removes the light entry `key` (one a later bake of the same view frames superseded). A bake sharing the
  // folder that has it open keeps reading it; one about to open it bakes the light (its regions still hit).
  void remove(uint64_t key) const;

  // Keeps the folder's entries within `maxBytes`: the least recently used go first (an entry is used when it is
  // stored or found: the find and store calls set its modification time). Only entries are counted and removed
  // (light entries and region packs, named as pathOf and regionsPathOf name them), never anything else in the
  // folder. A bake sharing the folder that has an entry
  // open keeps reading it (removal unlinks; the mapping stays), and one about to open it finds it missing and
  // bakes the light. Returns the entries removed and the bytes left.
  struct Trimmed {
    uint64_t removed = 0, bytesLeft = 0;
  };
  Trimmed trim(uint64_t maxBytes) const;

private:
  std::string folder_;
};

}  // namespace cpvs

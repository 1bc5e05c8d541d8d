#pragma once
// Hash-consing of variable-length records appended once each to one array: the node words of a level
// (node_table.h), the leaf parents' bytes (leaf_parent_table.h). intern() returns the offset of an equal stored
// record, appending the record when it is new; every hash hit is confirmed by comparing the whole record (a hash
// alone would corrupt shadows on a collision). A record's offset is where it was appended, so the index decides
// nothing about the bytes: it is kept small (hash_index.h, 4 bytes a slot) and is released once no more records
// come.
#include <cstdint>
#include <cstring>
#include <utility>

#include <xxhash.h>

#include "libcpvs/dag/hash_index.h"
#include "libcpvs/dag/mapped_array.h"

namespace cpvs {

// RecordLength: a callable giving the length (in T) of the stored record that starts at a pointer, for
// rehashing the records when the index grows. Records must be prefix-free: no record is the start of a longer one.
template <class T, class RecordLength>
class InternedRecords {
public:
  // Returns the offset of a record equal to record[0, length), appending it when new.
  uint32_t intern(const T* record, uint32_t length) { return intern(record, length, hashOf(record, length)); }
  // The same with the record's hashOf() already taken (a caller that hashes records ahead of interning them, to
  // prefetch() their index slots).
  uint32_t intern(const T* record, uint32_t length, uint64_t hash) {
    if (index_.full(size_, records_.size())) {
      index_.rebuild(size_, records_.size(), [&](auto&& insert) {
        for (size_t i = 0; i < records_.size();) {
          const uint32_t n = RecordLength{}(&records_[i]);
          insert(uint32_t(i), hashOf(&records_[i], n));
          i += n;
        }
      });
    }
    // A stored record may be shorter than this one: the comparison may read past it, but not past the mapping.
    records_.reserve(records_.size() + length);
    const uint32_t newOffset = uint32_t(records_.size());
    const uint32_t offset = index_.findOrInsert(hash, newOffset, [&](uint32_t at) {
      return records_[at] == record[0] && std::memcmp(&records_[at], record, length * sizeof(T)) == 0;
    });
    if (offset == newOffset) {
      records_.append(record, length);
      ++size_;
    }
    return offset;
  }

  // What intern() hashes a record by.
  static uint64_t hashOf(const T* record, uint32_t length) { return XXH3_64bits(record, length * sizeof(T)); }
  // Brings the index slot an intern() of a record with this hash starts at into the cache: a hint, taken a few
  // records ahead, so that the probes (cache misses in a large table) overlap.
  void prefetch(uint64_t hash) const { index_.prefetch(hash); }
  // The next step, once that slot has arrived: brings the stored record it names into the cache, where the
  // intern() will compare it (found records are compared whole).
  void prefetchCandidate(uint64_t hash) const {
    const uint32_t at = index_.firstCandidate(hash);
    if (at < records_.size()) __builtin_prefetch(&records_[at]);
  }

  const MappedArray<T>& records() const { return records_; }
  uint64_t size() const { return size_; }
  // Hands the records over (to the encoder, which consumes them): no intern() after this.
  MappedArray<T> take() {
    releaseIndex();
    return std::move(records_);
  }
  // Frees the index: no intern() after this.
  void releaseIndex() { index_.release(); }
  uint64_t indexBytes() const { return index_.bytes(); }

private:
  MappedArray<T> records_;  // every record once, in the order they were added
  HashIndex index_;         // by offset
  uint64_t size_ = 0;
};

}  // namespace cpvs

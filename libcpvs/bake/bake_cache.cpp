#include "libcpvs/bake/bake_cache.h"

#include <cstdio>
#include <algorithm>
#include <filesystem>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "libcpvs/bake/bake.h"
#include "libcpvs/bake/baked_from_file.h"
#include "libcpvs/base/error.h"
#include "libcpvs/version.h"

namespace cpvs {
BakeCache::BakeCache(std::string folder) : folder_(std::move(folder)) {
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  if (ec || !std::filesystem::is_directory(folder_))
    throw Error(ErrorCategory::OutputFailed, folder_ + ": cannot create the bake cache folder" +
                                                 (ec ? ": " + ec.message() : std::string()));
}

std::string BakeCache::pathOf(uint64_t key) const {
  return (std::filesystem::path(folder_) / (hex64(key) + ".cpvs")).string();
}

std::optional<BakedLight> BakeCache::find(uint64_t key, const Light& light, std::string* problem) const {
  const std::string path = pathOf(key);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  auto opened = CpvsFile::open(path);
  const auto reject = [&](const std::string& why) -> std::optional<BakedLight> {
    if (problem) *problem = why;
    return std::nullopt;
  };
  if (!opened.ok()) return reject(opened.outcome().message());
  const CpvsFile& file = *opened.value();
  nlohmann::json settings = nlohmann::json::parse(file.settingsJson(), nullptr, false);
  if (!settings.is_object() || settings.value("cache_key", std::string()) != hex64(key) || file.lights().size() != 1)
    return reject(path + ": not a cache entry for key " + hex64(key));
  Result<BakedLight> read = bakedLightOf(file, file.lights()[0]);
  if (!read) return reject(read.outcome().message());
  BakedLight baked = std::move(read).value();
  baked.light = light;
  std::filesystem::last_write_time(path, std::filesystem::file_time_type::clock::now(), ec);  // used now (trim)
  return baked;
}

std::unique_ptr<BakeCache::NewEntry> BakeCache::write(uint64_t key, const BakedLight& baked) const {
  auto entry = std::make_unique<NewEntry>(folder_, pathOf(key), key);
  // Written as it is encoded: neither a copy of the light nor the file's bytes are held beside the bake's DAGs.
  const std::string settings =
      nlohmann::json{{"cache_key", hex64(key)}, {"tool", "cpvs-bake"}, {"tool_version", kVersion}}.dump();
  CpvsWriter writer(settings, {baked.light}, {baked.views.size()}, [&](uint64_t at, const char* data, size_t n) {
    while (n > 0) {
      const ssize_t done = ::pwrite(entry->fd(), data, n, off_t(at));
      if (done <= 0) throw Error(ErrorCategory::OutputFailed, entry->path() + ": cannot write the bake cache entry");
      data += done;
      n -= size_t(done);
      at += uint64_t(done);
    }
  });
  writer.add(baked);
  writer.finish();
  entry->close();
  return entry;
}

BakeCache::NewEntry::NewEntry(const std::string& folder, std::string path, uint64_t key) : path_(std::move(path)) {
  temp_ = (std::filesystem::path(folder) / (".entry-" + hex64(key) + "-XXXXXX")).string();
  fd_ = ::mkstemp(temp_.data());
  if (fd_ < 0) throw Error(ErrorCategory::OutputFailed, folder + ": cannot write a bake cache entry");
  ::fchmod(fd_, 0644);  // a cache folder is often shared by a team's build machines
}

BakeCache::NewEntry::~NewEntry() {
  if (fd_ >= 0) ::close(fd_);
  if (!temp_.empty()) ::unlink(temp_.c_str());
}

void BakeCache::NewEntry::close() {
  if (fd_ < 0) return;
  const bool ok = ::fsync(fd_) == 0;
  const bool closed = ::close(fd_) == 0;
  fd_ = -1;
  if (!ok || !closed) throw Error(ErrorCategory::OutputFailed, path_ + ": cannot write the bake cache entry");
}

void BakeCache::NewEntry::commit() {
  close();
  if (std::rename(temp_.c_str(), path_.c_str()) != 0)
    throw Error(ErrorCategory::OutputFailed, path_ + ": cannot write the bake cache entry");
  temp_.clear();
}

std::string BakeCache::regionsPathOf(uint64_t frameKey) const {
  return (std::filesystem::path(folder_) / (hex64(frameKey) + ".regions")).string();
}

std::optional<RegionPackReader> BakeCache::findRegions(uint64_t frameKey, std::string* problem) const {
  const std::string path = regionsPathOf(frameKey);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return std::nullopt;
  try {
    RegionPackReader pack(path, frameKey);
    std::filesystem::last_write_time(path, std::filesystem::file_time_type::clock::now(), ec);  // used now (trim)
    return pack;
  } catch (const Error& e) {
    if (problem) *problem = e.what();
    return std::nullopt;
  }
}

std::unique_ptr<BakeCache::NewEntry> BakeCache::newRegions(uint64_t frameKey) const {
  return std::make_unique<NewEntry>(folder_, regionsPathOf(frameKey), frameKey);
}

void BakeCache::remove(uint64_t key) const {
  std::error_code ec;
  std::filesystem::remove(pathOf(key), ec);  // gone already (another bake removed it): as good
}

BakeCache::Trimmed BakeCache::trim(uint64_t maxBytes) const {
  struct Entry {
    std::filesystem::file_time_type used;
    std::string name;
    uint64_t bytes;
  };
  std::vector<Entry> entries;
  uint64_t total = 0;
  std::error_code ec;
  for (const auto& item : std::filesystem::directory_iterator(folder_, ec)) {
    const std::string name = item.path().filename().string();
    // An entry: 16 hex digits and ".cpvs" or ".regions" (temporaries start with ".entry-"; other files are not
    // ours).
    const std::string suffix = name.size() > 16 ? name.substr(16) : std::string();
    if ((suffix != ".cpvs" && suffix != ".regions") || name.find_first_not_of("0123456789abcdef") != 16 ||
        !item.is_regular_file(ec))
      continue;
    const uint64_t bytes = item.file_size(ec);
    const auto used = item.last_write_time(ec);
    if (ec) continue;  // removed by another bake meanwhile
    entries.push_back({used, name, bytes});
    total += bytes;
  }
  // Oldest use first; ties by name, so that every bake removes the same ones.
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.used != b.used ? a.used < b.used : a.name < b.name;
  });
  Trimmed trimmed;
  for (const Entry& e : entries) {
    if (total <= maxBytes) break;
    if (std::filesystem::remove(std::filesystem::path(folder_) / e.name, ec) || !ec) {
      total -= e.bytes;  // removed here, or by another bake sharing the folder
      trimmed.removed += 1;
    }
  }
  trimmed.bytesLeft = total;
  return trimmed;
}

}  // namespace cpvs

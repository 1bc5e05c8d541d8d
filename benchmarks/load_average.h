#pragma once
// The 1-, 5- and 15-minute load averages as /proc/loadavg gives them ("0.98 1.12 1.33"), printed beside every
// timing a study takes; empty where the system does not say.
#include <cstdio>
#include <string>

namespace cpvs::study {

inline std::string loadAverage() {
  char text[128] = {};
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (!std::fgets(text, sizeof text, f)) text[0] = 0;
    std::fclose(f);
  }
  std::string s(text);
  size_t end = 0;
  for (int field = 0; field < 3 && end != std::string::npos; ++field) end = s.find(' ', end + (field ? 1 : 0));
  return s.substr(0, end);
}

}  // namespace cpvs::study

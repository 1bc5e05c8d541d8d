#include "tools/common/progress.h"

#include <algorithm>
#include <cstdio>

#include <unistd.h>

namespace cpvs::tools {

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)), enabled_(!quiet && ::isatty(STDERR_FILENO)), start_(std::chrono::steady_clock::now()) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(double fraction) {
  if (!enabled_) return;
  const int permille = int(std::clamp(fraction, 0.0, 1.0) * 1000);
  const auto now = std::chrono::steady_clock::now();
  if (permille == lastPermille_ || (permille < 1000 && now - lastDraw_ < std::chrono::milliseconds(100))) return;
  lastPermille_ = permille;
  lastDraw_ = now;
  constexpr int width = 30;
  const int filled = permille * width / 1000;
  const double seconds = std::chrono::duration<double>(now - start_).count();
  std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%%  %.1fs", label_.c_str(), filled, "##############################",
               width - filled, "", permille / 10.0, seconds);
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!enabled_ || lastPermille_ < 0) return;
  std::fprintf(stderr, "\n");
  lastPermille_ = -1;
  enabled_ = false;
}

}  // namespace cpvs::tools

#include "tools/common/progress.h"

#include <algorithm>
#include <cstdio>

#include <unistd.h>

namespace cpvs::tools {

bool stderrIsTerminal() { return ::isatty(STDERR_FILENO) != 0; }

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)), enabled_(!quiet && stderrIsTerminal()), start_(std::chrono::steady_clock::now()) {}

void ProgressBar::setDetail(std::string detail) {
  constexpr size_t kWidest = 32;
  if (detail.size() > kWidest) detail = detail.substr(0, kWidest - 3) + "...";
  detail_ = std::move(detail);
}

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
  char eta[32] = "";
  if (permille >= 10 && permille < 1000)
    std::snprintf(eta, sizeof eta, ", ETA %.0fs", seconds * (1000.0 - permille) / permille);
  // \033[K clears what a longer previous line left.
  std::fprintf(stderr, "\r%s [%.*s%*s] %5.1f%%  %.1fs%s  %s\033[K", label_.c_str(), filled,
               "##############################", width - filled, "", permille / 10.0, seconds, eta, detail_.c_str());
  std::fflush(stderr);
}

void ProgressBar::finish() {
  if (!enabled_ || lastPermille_ < 0) return;
  std::fprintf(stderr, "\n");
  lastPermille_ = -1;
  enabled_ = false;
}

}  // namespace cpvs::tools

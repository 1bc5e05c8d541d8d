#pragma once
// A progress bar on stderr when it is a terminal; silent otherwise (pipelines, CI logs) or with --quiet.
#include <chrono>
#include <string>

namespace cpvs::tools {

bool stderrIsTerminal();

class ProgressBar {
public:
  ProgressBar(std::string label, bool quiet);
  ~ProgressBar();
  void update(double fraction);  // [0, 1]; redraws at most ~10 times a second, with an ETA
  void setDetail(std::string detail);  // what is being worked on (e.g. a light's name), shown after the bar
  void finish();

private:
  std::string label_, detail_;
  bool enabled_;
  int lastPermille_ = -1;
  std::chrono::steady_clock::time_point start_, lastDraw_;
};

}  // namespace cpvs::tools

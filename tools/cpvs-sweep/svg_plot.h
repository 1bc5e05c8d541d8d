#pragma once
// A tiny hand-written SVG line-plot writer for cpvs-sweep: panels with a log2 x axis (resolutions) and a log10
// or linear y axis, several series each with a colour, a dash style and markers. No dependencies.
#include <string>
#include <vector>

namespace cpvs::sweep {

struct Series {
  std::string label;
  std::string colour;  // CSS colour
  std::string dash;    // SVG stroke-dasharray ("" solid)
  bool hollow = false; // hollow markers
  std::vector<double> x, y;  // y <= 0 on a log axis: drawn on the bottom edge as a downward triangle ("0")
};

struct Panel {
  std::string title;
  std::string yLabel;
  bool logY = true;
  std::vector<Series> series;
};

// Lays the panels out in a grid of `columns` and returns the whole SVG document. x values are resolutions
// (powers of two), labelled 1k, 2k, ...
std::string renderSvg(const std::string& title, const std::vector<Panel>& panels, int columns = 2);

}  // namespace cpvs::sweep

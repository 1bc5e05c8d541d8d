#include "tools/cpvs-sweep/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace cpvs::sweep {
namespace {

constexpr double kPanelW = 460, kPanelH = 330;
constexpr double kLeft = 70, kRight = 16, kTop = 34, kBottom = 120;  // bottom: axis labels + legend

std::string num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

std::string resolutionLabel(double n) {
  const long v = std::lround(n);
  if (v >= 1024 && v % 1024 == 0) return std::to_string(v / 1024) + "k";
  return std::to_string(v);
}

std::string tickLabel(double v) {
  char b[32];
  const double a = std::abs(v);
  if (a == 0) return "0";
  if (a >= 1e4 || a < 1e-2) {
    const int e = int(std::lround(std::log10(a)));
    if (std::abs(a / std::pow(10.0, e) - 1.0) < 1e-9) {
      std::snprintf(b, sizeof b, "1e%d", e);
      return b;
    }
    std::snprintf(b, sizeof b, "%.0e", v);
    return b;
  }
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

void panel(std::string& svg, const Panel& p, double ox, double oy) {
  const double w = kPanelW - kLeft - kRight, h = kPanelH - kTop - kBottom;
  // Ranges.
  double xMin = std::numeric_limits<double>::infinity(), xMax = -xMin, yMin = xMin, yMax = -xMin;
  for (const Series& s : p.series) {
    for (size_t i = 0; i < s.x.size(); ++i) {
      xMin = std::min(xMin, s.x[i]);
      xMax = std::max(xMax, s.x[i]);
      if (p.logY && !(s.y[i] > 0)) continue;
      if (!std::isfinite(s.y[i])) continue;
      yMin = std::min(yMin, s.y[i]);
      yMax = std::max(yMax, s.y[i]);
    }
  }
  if (!std::isfinite(xMin)) xMin = 1024, xMax = 16384;
  if (xMax <= xMin) xMax = xMin * 2;
  if (!std::isfinite(yMin)) yMin = p.logY ? 1e-4 : 0, yMax = 1;
  double ly0, ly1;
  if (p.logY) {
    ly0 = std::floor(std::log10(yMin));
    ly1 = std::ceil(std::log10(yMax));
    if (ly1 <= ly0) ly1 = ly0 + 1;
  } else {
    ly0 = std::min(0.0, yMin);
    ly1 = yMax > ly0 ? yMax * 1.1 : ly0 + 1;
  }
  const double lx0 = std::log2(xMin), lx1 = std::log2(xMax);
  auto X = [&](double x) { return ox + kLeft + (lx1 > lx0 ? (std::log2(x) - lx0) / (lx1 - lx0) : 0.5) * w; };
  auto Y = [&](double y) {
    const double t = p.logY ? (std::log10(y) - ly0) / (ly1 - ly0) : (y - ly0) / (ly1 - ly0);
    return oy + kTop + (1.0 - t) * h;
  };
  const double bottom = oy + kTop + h;

  svg += "<text x=\"" + num(ox + kLeft + w / 2) + "\" y=\"" + num(oy + 20) +
         "\" text-anchor=\"middle\" font-size=\"14\" font-weight=\"bold\">" + escape(p.title) + "</text>\n";
  svg += "<rect x=\"" + num(ox + kLeft) + "\" y=\"" + num(oy + kTop) + "\" width=\"" + num(w) + "\" height=\"" +
         num(h) + "\" fill=\"none\" stroke=\"#444\"/>\n";
  // y grid and ticks.
  if (p.logY) {
    for (int e = int(ly0); e <= int(ly1); ++e) {
      const double y = Y(std::pow(10.0, e));
      svg += "<line x1=\"" + num(ox + kLeft) + "\" y1=\"" + num(y) + "\" x2=\"" + num(ox + kLeft + w) + "\" y2=\"" +
             num(y) + "\" stroke=\"#ddd\"/>\n";
      svg += "<text x=\"" + num(ox + kLeft - 5) + "\" y=\"" + num(y + 4) + "\" text-anchor=\"end\" font-size=\"11\">" +
             tickLabel(std::pow(10.0, e)) + "</text>\n";
    }
  } else {
    for (int i = 0; i <= 5; ++i) {
      const double v = ly0 + (ly1 - ly0) * i / 5.0;
      const double y = Y(v);
      svg += "<line x1=\"" + num(ox + kLeft) + "\" y1=\"" + num(y) + "\" x2=\"" + num(ox + kLeft + w) + "\" y2=\"" +
             num(y) + "\" stroke=\"#ddd\"/>\n";
      svg += "<text x=\"" + num(ox + kLeft - 5) + "\" y=\"" + num(y + 4) + "\" text-anchor=\"end\" font-size=\"11\">" +
             tickLabel(v) + "</text>\n";
    }
  }
  // x ticks at every power of two in range.
  for (double x = std::exp2(std::ceil(lx0 - 1e-9)); x <= xMax * 1.0001; x *= 2) {
    const double px = X(x);
    svg += "<line x1=\"" + num(px) + "\" y1=\"" + num(oy + kTop) + "\" x2=\"" + num(px) + "\" y2=\"" + num(bottom) +
           "\" stroke=\"#eee\"/>\n";
    svg += "<text x=\"" + num(px) + "\" y=\"" + num(bottom + 15) + "\" text-anchor=\"middle\" font-size=\"11\">" +
           resolutionLabel(x) + "</text>\n";
  }
  svg += "<text x=\"" + num(ox + kLeft + w / 2) + "\" y=\"" + num(bottom + 31) +
         "\" text-anchor=\"middle\" font-size=\"11\">CPVS resolution N</text>\n";
  svg += "<text transform=\"translate(" + num(ox + 16) + "," + num(oy + kTop + h / 2) +
         ") rotate(-90)\" text-anchor=\"middle\" font-size=\"11\">" + escape(p.yLabel) + "</text>\n";
  // Series.
  for (const Series& s : p.series) {
    std::string path;
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.y[i])) continue;
      const bool zero = p.logY && !(s.y[i] > 0);
      const double px = X(s.x[i]), py = zero ? bottom : Y(s.y[i]);
      path += (path.empty() ? "M" : " L") + num(px) + "," + num(py);
    }
    const std::string dash = s.dash.empty() ? "" : " stroke-dasharray=\"" + s.dash + "\"";
    if (!path.empty())
      svg += "<path d=\"" + path + "\" fill=\"none\" stroke=\"" + s.colour + "\" stroke-width=\"2\"" + dash + "/>\n";
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.y[i])) continue;
      const double px = X(s.x[i]);
      if (p.logY && !(s.y[i] > 0)) {  // zero: a triangle on the axis
        svg += "<path d=\"M" + num(px - 5) + "," + num(bottom - 8) + " L" + num(px + 5) + "," + num(bottom - 8) + " L" +
               num(px) + "," + num(bottom) + " Z\" fill=\"" + s.colour + "\"><title>" + escape(s.label) +
               ": 0</title></path>\n";
        continue;
      }
      char title[64];
      std::snprintf(title, sizeof title, "%.6g", s.y[i]);
      svg += "<circle cx=\"" + num(px) + "\" cy=\"" + num(Y(s.y[i])) + "\" r=\"3.5\" fill=\"" +
             (s.hollow ? std::string("white") : s.colour) + "\" stroke=\"" + s.colour + "\" stroke-width=\"1.5\"><title>" +
             escape(s.label) + " @ " + resolutionLabel(s.x[i]) + ": " + title + "</title></circle>\n";
    }
  }
  // Legend below the axis labels, two columns.
  for (size_t i = 0; i < p.series.size(); ++i) {
    const Series& s = p.series[i];
    const double lx = ox + kLeft + (i % 2) * (w / 2), ly = bottom + 48 + double(i / 2) * 15;
    const std::string dash = s.dash.empty() ? "" : " stroke-dasharray=\"" + s.dash + "\"";
    svg += "<line x1=\"" + num(lx) + "\" y1=\"" + num(ly - 4) + "\" x2=\"" + num(lx + 22) + "\" y2=\"" + num(ly - 4) +
           "\" stroke=\"" + s.colour + "\" stroke-width=\"2\"" + dash + "/>\n";
    svg += "<text x=\"" + num(lx + 27) + "\" y=\"" + num(ly) + "\" font-size=\"10.5\">" + escape(s.label) + "</text>\n";
  }
}

}  // namespace

std::string renderSvg(const std::string& title, const std::vector<Panel>& panels, int columns) {
  columns = std::max(1, columns);
  const int rows = int((panels.size() + size_t(columns) - 1) / size_t(columns));
  const double width = kPanelW * columns, height = kPanelH * rows + 30;
  std::string svg = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" +
                    num(width) + "\" height=\"" + num(height) + "\" viewBox=\"0 0 " + num(width) + " " + num(height) +
                    "\" font-family=\"sans-serif\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg += "<text x=\"" + num(width / 2) + "\" y=\"20\" text-anchor=\"middle\" font-size=\"15\">" + escape(title) +
         "</text>\n";
  for (size_t i = 0; i < panels.size(); ++i)
    panel(svg, panels[i], kPanelW * double(i % size_t(columns)), 30 + kPanelH * double(i / size_t(columns)));
  svg += "</svg>\n";
  return svg;
}

}  // namespace cpvs::sweep

#include "libcpvs/eval/throughput.h"

#include <algorithm>
#include <stdexcept>

namespace cpvs {

namespace {
volatile float gSink;
}  // namespace

void consume(float value) { gSink = value; }

void Throughput::add(const std::string& name, Method method) { methods_.push_back({name, std::move(method), {}}); }

void Throughput::run(int rounds) {
  if (rounds <= 0) return;
  for (auto& m : methods_) m.method();
  for (int r = 0; r < rounds; ++r)
    for (auto& m : methods_) m.samples.push_back(m.method());
}

double Throughput::best(const std::string& name) const {
  const auto& s = find(name).samples;
  return s.empty() ? 0.0 : *std::max_element(s.begin(), s.end());
}

double Throughput::median(const std::string& name) const {
  std::vector<double> s = find(name).samples;
  if (s.empty()) return 0.0;
  std::nth_element(s.begin(), s.begin() + ptrdiff_t(s.size() / 2), s.end());
  return s[s.size() / 2];
}

const Throughput::Entry& Throughput::find(const std::string& name) const {
  for (const Entry& e : methods_)
    if (e.name == name) return e;
  throw std::logic_error("no throughput method " + name);
}

}  // namespace cpvs

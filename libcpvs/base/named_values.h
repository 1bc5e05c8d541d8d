#pragma once
// An enum's names (command-line values, report fields) from one table per enum: parse a name, or name a value.
// An unknown name is a usage error that lists the choices in the table's order.
#include <cstddef>
#include <string>

#include "libcpvs/base/error.h"

namespace cpvs {

template <class E>
struct Named {
  E value;
  const char* name;
};

// Throws Error(InvalidArgument): "unknown WHAT 'NAME' (expected a, b or c)".
template <class E, size_t N>
E parseNamed(const Named<E> (&table)[N], const std::string& name, const std::string& what) {
  for (const Named<E>& entry : table)
    if (name == entry.name) return entry.value;
  std::string choices;
  for (size_t i = 0; i < N; ++i) choices += std::string(i == 0 ? "" : i + 1 == N ? " or " : ", ") + table[i].name;
  throw Error(ErrorCategory::InvalidArgument, "unknown " + what + " '" + name + "' (expected " + choices + ")");
}

// The value's name; "?" for a value the table lacks.
template <class E, size_t N>
const char* nameOf(const Named<E> (&table)[N], E value) {
  for (const Named<E>& entry : table)
    if (entry.value == value) return entry.name;
  return "?";
}

}  // namespace cpvs

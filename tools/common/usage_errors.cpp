#include "tools/common/usage_errors.h"

#include <algorithm>
#include <cctype>
#include <iostream>
#include <vector>

namespace cpvs::tools {
namespace {

// Optimal string alignment distance: insertions, deletions, substitutions and swaps of neighbours, the slips
// a hand makes on a keyboard.
size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i)
    for (size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

std::string lowered(std::string text) {
  for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

// "--sun", "-o": every name the app's options answer to.
std::vector<std::string> optionNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* option : app.get_options()) {
    for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
    for (const std::string& name : option->get_snames()) names.push_back("-" + name);
  }
  return names;
}

// "-3", "-0.5,1": a negative number given as a value, not an option.
bool looksLikeOption(const std::string& word) {
  return word.size() > 1 && word[0] == '-' && !std::isdigit(static_cast<unsigned char>(word[1])) && word[1] != '.';
}

std::string ordinal(size_t n) {
  const size_t tens = n % 100, ones = n % 10;
  const char* suffix = (tens >= 11 && tens <= 13) ? "th" : ones == 1 ? "st" : ones == 2 ? "nd" : ones == 3 ? "rd" : "th";
  return std::to_string(n) + suffix;
}

// "KIND", without the validator text CLI11 appends ("TEXT:{city,landscape}").
std::string typeName(const CLI::Option& option) {
  const std::string name = option.get_type_name();
  return name.substr(0, name.find(':'));
}

std::vector<const CLI::Option*> positionals(const CLI::App& app) {
  std::vector<const CLI::Option*> result;
  for (const CLI::Option* option : app.get_options())
    if (option->get_positional()) result.push_back(option);
  return result;
}

// The first required option that was not given, or null.
const CLI::Option* missingRequired(const CLI::App& app) {
  for (const CLI::Option* option : app.get_options())
    if (option->get_required() && option->count() == 0) return option;
  return nullptr;
}

// The words CLI11 did not take, split into unknown options and positional arguments no slot took (a word right
// after an unknown option is that option's value, not a stray).
struct Leftovers {
  std::vector<std::string> unknownOptions, strayPositionals;
};

Leftovers leftovers(const CLI::App& app) {
  Leftovers result;
  bool afterUnknown = false;
  for (const std::string& word : app.remaining()) {
    if (looksLikeOption(word)) {
      result.unknownOptions.push_back(word);
      afterUnknown = word.find('=') == std::string::npos;
    } else {
      if (!afterUnknown) result.strayPositionals.push_back(word);
      afterUnknown = false;
    }
  }
  return result;
}

std::string unknownOptionsMessage(const CLI::App& app, const std::vector<std::string>& unknown) {
  std::string message;
  for (const std::string& word : unknown) {
    const std::string name = word.substr(0, word.find('='));
    const std::string nearest = nearestOption(app, name);
    message += (message.empty() ? "unknown option " : "; unknown option ") + name +
               (nearest.empty() ? std::string() : " (did you mean " + nearest + "?)");
  }
  return message;
}

std::string strayPositionalsMessage(const CLI::App& app, const std::vector<std::string>& strays) {
  size_t taken = 0, slots = 0;
  for (const CLI::Option* option : positionals(app)) {
    taken += option->count();
    slots += size_t(std::max(option->get_items_expected_max(), 1));
  }
  std::string message;
  for (size_t i = 0; i < strays.size(); ++i)
    message += (i ? "; " : "") + std::string("'") + strays[i] + "', the " + ordinal(taken + i + 1) +
               " positional argument, was taken for nothing";
  const std::string usage = positionalUsage(app);
  message += " (" + app.get_name() + " takes " + std::to_string(slots) + ":" + usage.substr(app.get_name().size()) + ")";
  return message;
}

}  // namespace

std::string nearestOption(const CLI::App& app, const std::string& typed) {
  const std::string wanted = lowered(typed.substr(0, typed.find('=')));
  const std::string bare = wanted.substr(wanted.find_first_not_of('-') == std::string::npos ? wanted.size()
                                                                                              : wanted.find_first_not_of('-'));
  std::vector<std::string> best, prefixed;
  size_t bestDistance = bare.size() <= 4 ? 1 : 2;  // a likely slip: one edit in a short name, two in a longer one
  for (const std::string& name : optionNames(app)) {
    const size_t distance = editDistance(wanted, lowered(name));
    if (distance < bestDistance) best.clear(), bestDistance = distance;
    if (distance == bestDistance) best.push_back(name);
    if (bare.size() >= 2 && name.size() > 2 && lowered(name).compare(2, bare.size(), bare) == 0) prefixed.push_back(name);
  }
  if (best.empty() && prefixed.size() == 1) best = prefixed;  // "--res" for "--resolution"
  std::string joined;
  for (const std::string& name : best) joined += (joined.empty() ? "" : " or ") + name;
  return joined;
}

std::string positionalUsage(const CLI::App& app) {
  std::string usage = app.get_name();
  for (const CLI::Option* option : positionals(app)) {
    std::string name = typeName(*option);
    if (name.empty() || name == "TEXT") name = option->get_name(true);
    usage += " " + name + (option->get_items_expected_max() > 1 ? "..." : "");
  }
  return usage;
}

std::string describeParseError(const CLI::App& app, const CLI::ParseError& error) {
  const Leftovers words = leftovers(app);
  // CLI11's own message first where it is about a value (a conversion, a check): the leftovers come after it.
  const bool aboutWords = dynamic_cast<const CLI::RequiredError*>(&error) || dynamic_cast<const CLI::ExtrasError*>(&error);
  std::string message = aboutWords ? std::string() : std::string(error.what());
  if (!words.unknownOptions.empty())
    message += (message.empty() ? "" : "; ") + unknownOptionsMessage(app, words.unknownOptions);
  if (!words.strayPositionals.empty())
    message += (message.empty() ? "" : "; ") + strayPositionalsMessage(app, words.strayPositionals);
  if (const CLI::Option* missing = missingRequired(app); missing && dynamic_cast<const CLI::RequiredError*>(&error)) {
    const std::string name = missing->get_positional() ? typeName(*missing) : missing->get_name();
    std::string required = name + " is required";
    // The stray word is most likely the value that belongs after the missing option.
    if (!missing->get_positional() && words.strayPositionals.size() == 1)
      required += ": '" + words.strayPositionals[0] + "' goes after it (" + name + " " + words.strayPositionals[0] + ")";
    message += (message.empty() ? "" : "; ") + required;
  }
  return message.empty() ? std::string(error.what()) : message;
}

int reportParseError(CLI::App& app, const CLI::ParseError& error) {
  if (error.get_exit_code() == 0) return app.exit(error);  // --help, --version
  const std::string tool = app.get_name();
  std::cerr << tool << ": error: " << describeParseError(app, error) << "\n"
            << tool << ": usage: " << positionalUsage(app) << " [OPTIONS]; '" << tool << " --help' lists them\n";
  return 1;
}

}  // namespace cpvs::tools

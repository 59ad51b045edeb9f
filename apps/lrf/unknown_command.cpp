#include "unknown_command.h"

#include <algorithm>
#include <vector>

namespace lrf::cli {
namespace {

// Optimal string alignment distance: Levenshtein's edits plus the swap of two adjacent letters, the
// commonest typo ("trian").
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
  for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

std::vector<std::string> command_names(CLI::App& root) {
  std::vector<std::string> names;
  for (const CLI::App* sub : root.get_subcommands([](CLI::App*) { return true; })) names.push_back(sub->get_name());
  return names;
}

}  // namespace

std::string unknown_command(CLI::App& root, int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--") return "";
    if (arg.size() > 1 && arg[0] == '-') {
      // An option of the root that takes a value ("--threads 2") uses the next word too.
      const CLI::Option* option = arg.find('=') == std::string::npos ? root.get_option_no_throw(arg) : nullptr;
      if (option && option->get_items_expected_max() > 0) ++i;
      continue;
    }
    const std::vector<std::string> names = command_names(root);
    return std::find(names.begin(), names.end(), arg) == names.end() ? arg : "";
  }
  return "";
}

std::string closest_command(CLI::App& root, const std::string& word) {
  std::string best;
  // At most two edits, and fewer than the word has letters: further than that is another word, not a typo.
  size_t best_distance = std::min<size_t>(3, word.size());
  for (const std::string& name : command_names(root)) {
    const size_t distance = edit_distance(word, name);
    if (distance < best_distance) best = name, best_distance = distance;
  }
  return best;
}

}  // namespace lrf::cli

#pragma once
// What `lrf compare` is about to do for one method, said before it starts: a compare of several methods
// runs for a long time, and each method's training then prints the time it expects (expected_time.h).
#include <string>

#include "lrf/compare/compare.h"

namespace lrf {

// One line: the field the method fits, on what, for how many steps, and that it is then scored on the test
// views; e.g. "an RGB field on the views reduced 8x, 7000 steps, then scored on the test views".
std::string compare_method_plan(const std::string& method, const CompareOptions& options);

}  // namespace lrf

#pragma once
// "Did you mean" suggestions for misspelt names (attributes, node types, nodes, flags).

#include <string>
#include <string_view>
#include <vector>

namespace rig {

// The candidate closest to `name` by edit distance, or "" when none is plausibly a typo of it.
std::string closestName(std::string_view name, const std::vector<std::string>& candidates);

// "; did you mean 'x'?" when there is a close candidate, otherwise "".
std::string didYouMean(std::string_view name, const std::vector<std::string>& candidates);

}  // namespace rig

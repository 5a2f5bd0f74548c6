#pragma once
// Numbers in text files, read the same way whatever the locale.

#include <optional>
#include <string_view>

namespace rig {

// A finite number written in C locale style ("1.5", "-.25", "1e-3", "+2"), the whole text; nullopt for
// anything else (a word, trailing characters, inf, nan, a value out of range).
std::optional<double> parseFiniteNumber(std::string_view text);

}  // namespace rig

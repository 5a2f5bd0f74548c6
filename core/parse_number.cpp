#include "core/parse_number.h"

#include <charconv>
#include <cmath>

namespace rig {

std::optional<double> parseFiniteNumber(std::string_view s)
{
    // from_chars takes no leading '+'; a lone "+" or "+-" stays an error.
    if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
    double x = 0.0;
    const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), x);
    if (s.empty() || ec != std::errc() || end != s.data() + s.size() || !std::isfinite(x)) return std::nullopt;
    return x;
}

}  // namespace rig

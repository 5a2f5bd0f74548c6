#include "app/common/frame_range.h"

#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::app {

std::vector<double> FrameRange::frames() const
{
    std::vector<double> out;
    const auto count = static_cast<long long>(std::floor((last - first) / step + 1e-9));
    // Rounded to 1e-9 frames so 1:2:0.1 gives 1.7, not 1.7000000000000002.
    for (long long i = 0; i <= count; ++i) {
        const double frame = first + static_cast<double>(i) * step;
        // (Far from 0 the rounding would overflow, and a double has no 1e-9 digits there anyway.)
        out.push_back(std::abs(frame) < 1e6 ? std::round(frame * 1e9) / 1e9 : frame);
    }
    return out;
}

FrameRange parseFrameRange(std::string_view text, std::string_view flag, bool steps)
{
    auto bad = [&](std::string_view why) {
        return Error(fmt::format("{} '{}': {}; expected {}", flag, text, why,
                                 steps ? "A:B[:STEP], e.g. 1:240 or 1:240:2" : "A:B, e.g. 1:240"));
    };
    std::vector<double> parts;
    std::string_view rest = text;
    while (true) {
        const auto colon = rest.find(':');
        const std::string_view piece = rest.substr(0, colon);
        double x = 0.0;
        const auto [end, ec] = std::from_chars(piece.data(), piece.data() + piece.size(), x);
        if (piece.empty() || ec != std::errc() || end != piece.data() + piece.size() || !std::isfinite(x))
            throw bad(fmt::format("'{}' is not a number", piece));
        parts.push_back(x);
        if (colon == std::string_view::npos) break;
        rest.remove_prefix(colon + 1);
    }
    if (parts.size() < 2 || parts.size() > 3) throw bad(steps ? "give two or three numbers" : "give two numbers");
    FrameRange range{parts[0], parts[1], parts.size() == 3 ? parts[2] : 1.0};
    if (range.step <= 0) throw bad("the step must be positive");
    if (range.last < range.first) throw bad("the last frame is before the first");
    if ((range.last - range.first) / range.step > 1e7) throw bad("more than ten million frames");
    return range;
}

}  // namespace rig::app

#pragma once
// Frame ranges as the command lines and the Python module take them (--frames A:B[:STEP]).

#include <string_view>
#include <vector>

namespace rig::app {

// Frames A:B[:STEP], inclusive, step > 0 (e.g. 1:240, 0:10:0.5).
struct FrameRange {
    double first = 0.0;
    double last = 0.0;
    double step = 1.0;
    std::vector<double> frames() const;
};
// Throws rig::Error naming the flag when the text is not a valid range. `steps`: whether the command takes a STEP
// (rig-invert does not: its frames are a warm-start chain), for the form and example the messages suggest.
FrameRange parseFrameRange(std::string_view text, std::string_view flag, bool steps = true);

}  // namespace rig::app

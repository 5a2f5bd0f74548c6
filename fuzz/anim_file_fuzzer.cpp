// libFuzzer target: Maya .anim text from arbitrary bytes. parseAnimFile must either return curves or throw
// rig::Error; every curve returned then builds (its keys increase and are finite), plays through AnimCurve on
// and off its keys, and writes back to text that reads again to the same number of curves and keys.
// Anything else (another exception, a crash, a sanitizer report, a timeout) is a bug. scripts/fuzz.sh runs
// it; docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>

#include "core/error.h"
#include "nodes/curves/anim_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    rig::AnimFile file;
    try {
        file = rig::parseAnimFile(text, "fuzz.anim");
    }
    catch (const rig::Error&) {
        return 0;
    }
    for (const auto& curve : file.curves) {
        if (curve.keys.empty()) __builtin_trap();
        const rig::AnimCurve c = rig::AnimCurve::build(curve.keys, curve.pre, curve.post);
        for (const double x : {curve.keys.front().x - 1.5, curve.keys.front().x, curve.keys.back().x + 2.25, -1e300,
                               1e300, std::numeric_limits<double>::quiet_NaN()})
            (void)c.evaluate(x);
    }
    const rig::AnimFile back = rig::parseAnimFile(rig::formatAnimFile(file), "back.anim");
    if (back.curves.size() != file.curves.size()) __builtin_trap();
    for (std::size_t i = 0; i < file.curves.size(); ++i)
        if (back.curves[i].keys.size() != file.curves[i].keys.size()) __builtin_trap();
    return 0;
}

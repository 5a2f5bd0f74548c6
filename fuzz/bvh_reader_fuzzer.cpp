// libFuzzer target: BVH text from arbitrary bytes. parseBvh must either return a clip or throw
// rig::Error; a clip is then played: the world matrices of its first and last motion lines, a sample
// between frames and out of range, and the rig channels. Anything else (another exception, a crash,
// a sanitizer report, a timeout, memory past the limit) is a bug. scripts/fuzz.sh runs it;
// docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string_view>

#include "core/error.h"
#include "nodes/clips/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    rig::BvhClip clip;
    try {
        clip = rig::parseBvh(text, "fuzz.bvh");
    }
    catch (const rig::Error&) {
        return 0;
    }
    // Every clip the reader returns has at least one motion line and one channel.
    if (clip.frameCount < 1 || clip.channelCount < 1) __builtin_trap();
    (void)rig::bvhWorldMatrices(clip, 0);
    (void)rig::bvhWorldMatrices(clip, clip.frameCount - 1);
    for (const double time :
         {1.5, static_cast<double>(clip.frameCount) + 0.25, -1e300, 1e300, std::numeric_limits<double>::quiet_NaN()}) {
        const auto values = rig::bvhSample(clip, time);
        (void)rig::bvhWorldMatrices(clip, values);
        (void)rig::bvhRigChannels(clip, values);
    }
    return 0;
}

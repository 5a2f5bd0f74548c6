// libFuzzer target: skeletal clips through assimp (nodes/clips/assimp_clip.h) from arbitrary bytes, the format
// found by assimp from the content (no extension). Each input must either give a clip or throw rig::Error. A clip
// that loads has at least one frame, a value for every channel of every frame, all finite, parents before their
// children, and finite world matrices at its first and last frames. Anything else (another exception, a crash,
// a sanitizer report, a timeout, memory past the limit) is a bug. assimp and the clip's making run in a child
// process (nodes/clips/clip_isolation.h), as in the tools, so that assimp's own aborts are the one-line error they
// are for a user; libFuzzer sees no coverage from the child, so this target checks that guarantee and the clip's
// invariants on mutated seeds rather than steering into the reader. scripts/fuzz.sh runs it.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/error.h"
#include "nodes/clips/assimp_clip.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    rig::SkeletalClip skeleton;
    try {
        skeleton = rig::parseAssimpClip(bytes, "", "fuzz", "");
    }
    catch (const rig::Error&) {
        return 0;
    }
    const rig::BvhClip& clip = skeleton.clip;
    if (clip.frameCount < 1 || !(clip.frameTime > 0.0)) __builtin_trap();
    if (clip.values.size() != static_cast<std::size_t>(clip.frameCount) * static_cast<std::size_t>(clip.channelCount))
        __builtin_trap();
    for (const double v : clip.values)
        if (!std::isfinite(v)) __builtin_trap();
    for (std::size_t j = 0; j < clip.joints.size(); ++j)
        if (clip.joints[j].parent >= static_cast<int>(j)) __builtin_trap();
    for (const int f : {0, clip.frameCount - 1})
        for (const auto& m : rig::bvhWorldMatrices(clip, f))
            if (!m.allFinite()) __builtin_trap();
    return 0;
}

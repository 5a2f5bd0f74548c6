// libFuzzer target: map files and JSON target clips (nodes/clips/target_clip.h) from arbitrary bytes.
// The same bytes are read as a map file and as a JSON clip (with no map, then with the map when it
// loads); each must either load or throw rig::Error. A clip that loads has one frame number and one world
// matrix per joint for every frame, and its frame numbers increase. Anything else (another exception, a
// crash, a sanitizer report, a timeout, memory past the limit) is a bug. scripts/fuzz.sh runs it;
// docs/robustness.md.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include "core/error.h"
#include "nodes/clips/target_clip.h"

namespace {

void readClip(std::string_view text, const rig::TargetMap& map)
{
    rig::TargetClip clip;
    try {
        clip = rig::parseJsonTargetClip(text, "fuzz.json", map);
    }
    catch (const rig::Error&) {
        return;
    }
    if (clip.frameNumbers.empty() || clip.worlds.size() != clip.frameNumbers.size()) __builtin_trap();
    for (std::size_t f = 0; f < clip.worlds.size(); ++f) {
        if (clip.worlds[f].size() != clip.joints.size()) __builtin_trap();
        if (f > 0 && !(clip.frameNumbers[f] > clip.frameNumbers[f - 1])) __builtin_trap();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    std::optional<rig::TargetMap> map;
    try {
        map = rig::parseTargetMap(text, "fuzz.yaml");
    }
    catch (const rig::Error&) {
    }
    readClip(text, rig::TargetMap{});
    if (map) readClip(text, *map);
    return 0;
}

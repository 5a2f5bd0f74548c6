#pragma once
// The maya_load row of rig-bench (docs/maya.md): every Maya ASCII scene of a folder (../shared/maya) read into a graph,
// the best of three loads timed, and the scene's outcome (its graph's size, or the one line that refused it).

#include <filesystem>

#include "bench/bench_common.h"

namespace rig::bench {

// Null when the folder is absent.
Json mayaLoadJson(const std::filesystem::path& folder);

}  // namespace rig::bench

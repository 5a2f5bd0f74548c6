#pragma once
// The Maya rows of rig-bench (docs/maya.md). maya_load: every Maya ASCII scene of a folder (../shared/maya) read into
// a graph, the best of three loads timed, and the scene's outcome (its graph's size, or the one line that refused it).
// maya_scenes: each animated scene of that folder whose rig the reader evaluates, learned as it comes
// (rig-learn --params auto) and its own animation inverted without --hybrid (rig-invert --clip SCENE.ma), the curves
// written back as OUT.ma and replayed against the scene's joints.

#include <filesystem>
#include <functional>
#include <string_view>

#include "bench/bench_common.h"

namespace rig::bench {

// Null when the folder is absent.
Json mayaLoadJson(const std::filesystem::path& folder);

// Null when the folder is absent; scratch files (OUT.ma) go to `workDir`; `log` says each step (may be empty).
Json mayaScenesJson(const std::filesystem::path& folder, const std::filesystem::path& workDir,
                    const std::function<void(std::string_view)>& log);

}  // namespace rig::bench

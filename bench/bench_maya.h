#pragma once
// The Maya rows of rig-bench (docs/maya.md). maya_load: every Maya ASCII scene of a folder (../shared/maya) read into
// a graph, the best of three loads timed, and the scene's outcome (its graph's size, or the one line that refused it).
// maya_scenes: each animated scene of that folder whose rig the reader evaluates, learned as it comes
// (rig-learn --params auto) and its own animation inverted without --hybrid (rig-invert --clip SCENE.ma), the curves
// written back as OUT.ma and replayed against the scene's joints.

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "bench/bench_common.h"

namespace rig::bench {

// Null when the folder is absent.
Json mayaLoadJson(const std::filesystem::path& folder);

// An animated scene: the rig scene, and the scene animating it (the same file where one scene holds both: its time
// curves are cut from the parameters they key), both relative to the folder.
struct AnimatedScene {
    std::string rig;
    std::string clip;
};
// The animated scenes of ../shared/maya whose rig the reader evaluates (its README).
const std::vector<AnimatedScene>& publicAnimatedScenes();

// Null when the folder is absent; a scene absent from it is left out; scratch files (OUT.ma) go to `workDir`; `log`
// says each step (may be empty).
Json mayaScenesJson(const std::filesystem::path& folder, const std::filesystem::path& workDir,
                    const std::function<void(std::string_view)>& log,
                    const std::vector<AnimatedScene>& scenes = publicAnimatedScenes());

// Issue #46's goal, per joint: `scenes` (mayaScenesJson's) given the FK biped's CPU time per frame over its target
// joints in the same run (fk_biped_cpu_ms_per_joint), and each scene's CPU time per frame and joint over it
// (times_fk_biped_per_joint).
void compareWithBiped(Json& scenes, double bipedCpuMsPerFrame, int bipedJoints);

}  // namespace rig::bench

#include "bench/bench_maya.h"

#include <algorithm>
#include <chrono>

#include <map>
#include <set>

#include <fmt/format.h>

#include "app/common/output_file.h"
#include "app/invert/invert_run.h"
#include "app/invert/maya_scene_output.h"
#include "app/learn/learn_run.h"
#include "core/error.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/maya_clip.h"

namespace rig::bench {

Json mayaLoadJson(const std::filesystem::path& folder)
{
    if (!std::filesystem::is_directory(folder)) return Json();
    std::vector<std::filesystem::path> scenes;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(folder))
        if (entry.path().extension() == ".ma") scenes.push_back(entry.path());
    std::sort(scenes.begin(), scenes.end());
    Json rows = Json::array();
    double largestSeconds = 0.0;
    std::uintmax_t largestBytes = 0;
    const auto registry = makeBuiltinRegistry();
    for (const auto& scene : scenes) {
        Json row{{"scene", scene.filename().string()}, {"bytes", std::filesystem::file_size(scene)}};
        double best = 1e300;
        for (int run = 0; run < 3; ++run) {
            const auto start = std::chrono::steady_clock::now();
            try {
                MayaSceneInfo info;
                const auto graph = loadRigFile(scene, registry, nullptr, &info);
                row["graph_nodes"] = graph->nodeCount();
                row["refused"] = Json();
            }
            catch (const Error& e) {
                row["refused"] = e.what();
            }
            best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        row["load_seconds"] = best;
        if (row.at("bytes").get<std::uintmax_t>() > largestBytes) {
            largestBytes = row.at("bytes").get<std::uintmax_t>();
            largestSeconds = best;
        }
        rows.push_back(std::move(row));
    }
    return Json{{"scenes", std::move(rows)}, {"largest_bytes", largestBytes}, {"largest_load_seconds", largestSeconds}};
}

// Each animated scene of ../shared/maya whose rig the reader evaluates (HumanStance.ma's is refused: docs/maya.md).
const std::vector<AnimatedScene>& publicAnimatedScenes()
{
    static const std::vector<AnimatedScene> scenes{
        {"I-LoveBees__Maya/mimic_RigTestAnim.ma", "I-LoveBees__Maya/mimic_RigTestAnim.ma"},
        {"sweet4lorie__MonsterRobotRunner/ART/C_Robot/C_Robot_Rig.ma",
         "sweet4lorie__MonsterRobotRunner/ART/C_Robot/C_Robot_Run.ma"},
        {"Autodesk__maya-usd/test/lib/usd/translators/UsdExportSkeletonTest/UsdExportSkeleton.ma",
         "Autodesk__maya-usd/test/lib/usd/translators/UsdExportSkeletonTest/UsdExportSkeleton.ma"},
        {"Autodesk__maya-usd/test/lib/usd/translators/UsdExportEulerFilterTest/UsdExportEulerFilterTest.ma",
         "Autodesk__maya-usd/test/lib/usd/translators/UsdExportEulerFilterTest/UsdExportEulerFilterTest.ma"},
        {"Squamashii__UVUFall2008/Rigging/SpiderBot/Spencer_SpiderBot_Anim_001.ma",
         "Squamashii__UVUFall2008/Rigging/SpiderBot/Spencer_SpiderBot_Anim_001.ma"},
        {"samuelmoores__Infinity/InfinityMaya/Scenes/Grunt_Rig.ma",
         "samuelmoores__Infinity/InfinityMaya/Scenes/Grunt_Run.ma"},
    };
    return scenes;
}

namespace {

// OUT.ma's target joints (the approximation's joints the clip gives) against the clip's, matched by name without
// namespaces (OUT.ma names the rig's joints under its reference's namespace): the worst position difference, cm,
// over every frame and over the frames `reached`. The clip's other joints (a rig's control joints, which a scene
// saves as joints too) were no target: a control the solve set otherwise than the scene (one of a redundant pair)
// moves them.
std::pair<double, double> replayErrors(const TargetClip& clip, const TargetClip& replay,
                                       const std::vector<bool>& reached, const Approximation& approximation)
{
    std::set<std::string> targets;
    for (const ApproximationOutput& o : approximation.outputs)
        if (!o.helper) targets.insert(withoutNamespaces(o.name));
    std::map<std::string, std::size_t> replayed;
    for (std::size_t j = 0; j < replay.joints.size(); ++j) replayed.emplace(withoutNamespaces(replay.joints[j]), j);
    double all = 0.0, onReached = 0.0;
    const std::size_t frames = std::min(clip.worlds.size(), replay.worlds.size());
    for (std::size_t f = 0; f < frames; ++f)
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            const auto r = replayed.find(withoutNamespaces(clip.joints[j]));
            if (r == replayed.end() || !targets.contains(withoutNamespaces(clip.joints[j]))) continue;
            const double d =
                (clip.worlds[f][j].block<3, 1>(0, 3) - replay.worlds[f][r->second].block<3, 1>(0, 3)).norm();
            all = std::max(all, d);
            if (f < reached.size() && reached[f]) onReached = std::max(onReached, d);
        }
    return {all, onReached};
}

// One scene: learned with auto parameters and outputs, its animation inverted with the default settings, OUT.ma
// written and read back.
Json sceneRow(const std::filesystem::path& rig, const std::filesystem::path& clip, const std::filesystem::path& out)
{
    app::LearnJob learnJob;
    learnJob.rig = rig.string();
    learnJob.params = {"auto"};
    app::LearnOutcome learned = app::learn(learnJob);
    const std::size_t unmodelled = learned.unmodelled.size();
    auto approximation = std::make_shared<const Approximation>(std::move(learned.approximation));
    app::InvertJob job;
    job.approximation = rig.filename().string() + " (learned in memory)";
    job.loadedApproximation = approximation;
    job.rig = rig.string();
    job.clip = clip.string();
    const app::InvertOutcome inverted = app::invert(job);
    const ClipInversionSummary& s = inverted.summary;
    app::writeFileAtomically(out,
                             app::curvesMayaScene(inverted, nullptr, app::keyTangent("auto"), job.rig, out.string()));
    std::vector<bool> reached;
    for (const FrameInversion& f : s.perFrame) reached.push_back(f.status == FrameStatus::reached);
    // The scene's joints as rig-invert read them (no map: as the scene gives them), against OUT.ma's.
    const auto [replayAll, replayReached] = replayErrors(inverted.clip, readMayaClip(out, {}), reached, *approximation);
    const auto joints = std::count_if(approximation->outputs.begin(), approximation->outputs.end(),
                                      [](const auto& o) { return !o.helper; });
    // The thread's CPU time, as the FK biped's figure it is compared with per joint (bench_suite.cpp).
    const double cpuMsPerFrame = s.frames > 0 ? 1e3 * s.solveCpuSeconds / static_cast<double>(s.frames) : 0.0;
    return Json{{"clip", clip.filename().string()},
                {"rig", rig.filename().string()},
                {"joints", joints},
                {"parameters_found", learned.rigParameters},
                {"parameters_modelled", approximation->parameters.size()},
                {"unmodelled_outputs", unmodelled},
                {"training_evaluations", approximation->training.evaluations},
                {"learn_seconds", approximation->training.seconds},
                {"within_epsilon", approximation->validation.withinEpsilon},
                {"worst_relative_error_cm", approximation->validation.maxRelativeError},
                {"frames", s.frames},
                {"reached", s.count(FrameStatus::reached)},
                {"status_frames", app::statusCountsJson(s)},
                {"ms_per_frame", s.msPerFrame},
                {"cpu_ms_per_frame", cpuMsPerFrame},
                {"cpu_ms_per_joint", joints > 0 ? Json(cpuMsPerFrame / static_cast<double>(joints)) : Json()},
                {"setup_cpu_ms", 1e3 * s.setupCpuSeconds},
                {"real_rig_worst_cm", s.maxPositionErrorCm},
                {"replay_worst_cm", replayAll},
                {"replay_worst_reached_cm", replayReached}};
}

}  // namespace

Json mayaScenesJson(const std::filesystem::path& folder, const std::filesystem::path& workDir,
                    const std::function<void(std::string_view)>& log, const std::vector<AnimatedScene>& scenes)
{
    if (!std::filesystem::is_directory(folder)) return Json();
    Json rows = Json::array();
    for (const AnimatedScene& scene : scenes) {
        const std::filesystem::path rig = folder / scene.rig, clip = folder / scene.clip;
        if (!std::filesystem::exists(rig) || !std::filesystem::exists(clip)) continue;
        if (log)
            log(fmt::format("Maya scenes: {} learned as it comes, its animation inverted", clip.filename().string()));
        try {
            rows.push_back(sceneRow(rig, clip, workDir / (clip.stem().string() + ".out.ma")));
        }
        catch (const Error& e) {
            rows.push_back(Json{{"clip", clip.filename().string()}, {"error", e.what()}});
        }
    }
    return Json{{"scenes", std::move(rows)},
                {"note",
                 "each animated scene of ../shared/maya whose rig the reader evaluates: rig-learn --params auto, "
                 "then rig-invert --clip SCENE.ma with the default settings (no --hybrid), -o OUT.ma read back "
                 "(replay: OUT.ma's joints against the scene's, worst over the frames and over those reached)"}};
}

void compareWithBiped(Json& scenes, double bipedCpuMsPerFrame, int bipedJoints)
{
    const double perJoint = bipedCpuMsPerFrame / static_cast<double>(bipedJoints);
    scenes["fk_biped_cpu_ms_per_joint"] = perJoint;
    for (Json& row : scenes.at("scenes"))
        if (const auto j = row.find("cpu_ms_per_joint"); j != row.end() && j->is_number())
            row["times_fk_biped_per_joint"] = j->get<double>() / perJoint;
}

}  // namespace rig::bench

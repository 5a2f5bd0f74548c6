#include "bench/bench_contacts.h"

#include <algorithm>
#include <numbers>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "adapter/retarget.h"
#include "core/rotation_math.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/contacts.h"
#include "inversion/learn/learner.h"
#include "nodes/clips/target_clip.h"

namespace rig::bench {
namespace {

// One run's figures: the slides, and the real rig's errors on the joints no contact holds (the other targets).
Json runJson(const ClipInversionSummary& s, RigBinding& binding, const ClipTargets& targets,
             const std::vector<std::vector<double>>& values, const std::vector<Contact>& contacts)
{
    std::vector<bool> held(targets.frames.front().size(), false);
    for (const Contact& c : contacts) held[static_cast<std::size_t>(c.output)] = true;
    double sum = 0.0, worst = 0.0, rotationSum = 0.0;
    long long count = 0;
    std::vector<Eigen::Matrix4d> worlds;
    for (std::size_t f = 0; f < values.size(); ++f) {
        binding.evaluate(values[f], worlds);
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            const JointTarget& t = targets.frames[f][k];
            if (!t.active || held[k]) continue;
            const double error = (worlds[k].block<3, 1>(0, 3) - t.world.block<3, 1>(0, 3)).norm();
            sum += error;
            worst = std::max(worst, error);
            rotationSum += orientationAngle(worlds[k].topLeftCorner<3, 3>(), t.world.topLeftCorner<3, 3>());
            ++count;
        }
    }
    const double n = static_cast<double>(std::max(1LL, count));
    return Json{{"max_slide_cm", maxSlideCm(s.contacts)},
                {"mean_slide_cm", meanSlideCm(s.contacts)},
                {"other_mean_position_error_cm", sum / n},
                {"other_max_position_error_cm", worst},
                {"other_mean_rotation_error_deg", rotationSum / n * 180.0 / std::numbers::pi},
                {"ms_per_frame", 1000.0 * s.solveCpuSeconds / std::max(1, s.frames)}};
}

// The clip's targets on the long-legged rig: as the map gives them (the CMU skeleton's proportions) or retargeted
// onto the rig's (its `retarget:`).
ClipTargets longLegsTargets(const BenchOptions& o, const Approximation& a, const std::filesystem::path& mapFile)
{
    const TargetMap map = readTargetMap(mapFile);
    TargetClip clip = readTargetClip(o.clip, map);
    if (map.retarget.enabled) clip = retargetClip(clip, map, rigSkeleton(a));
    return matchTargets(a, clip.joints, clip.worlds);
}

}  // namespace

Json contactsBenchJson(const BenchOptions& o)
{
    const InversionSpec spec = readInversionSpec(o.spec);
    GraphRigFunction rig(o.longLegsRig, GraphRigOptions{spec.params, spec.outputs, {}, spec.set, spec.ranges});
    if (o.log) o.log("contacts: learning the biped with longer legs");
    const Approximation a = learnApproximation(rig, LearnOptions{}, o.longLegsRig.string());
    RigBinding binding(a, rig);
    ClipInversionOptions options;
    options.solver.threads = 1;
    const Solver solver(a, options.solver);
    Json rows = Json::object();
    int frames = 0;
    // The clip as it is (before) and retargeted (after), each with its feet free and held.
    for (const bool retargeted : {false, true}) {
        const ClipTargets targets = longLegsTargets(o, a, retargeted ? o.longLegsMap : o.map);
        frames = std::min(o.frames, static_cast<int>(targets.frames.size()));
        options.contacts = detectContacts(targets, contactJoints(a, targets));
        for (const bool hold : {false, true}) {
            if (o.log)
                o.log(fmt::format("contacts: inverting {} frames{}, contacts {}", frames,
                                  retargeted ? " retargeted" : "", hold ? "held" : "free"));
            options.holdContacts = hold;
            // The faster of two runs: the time per frame on a machine shared with others.
            ClipInversionSummary best;
            std::vector<std::vector<double>> values;
            for (int run = 0; run < 2; ++run) {
                ClipInversionSummary s = invertClip(solver, binding, targets, 0, frames - 1, options, values);
                if (run == 0 || s.solveCpuSeconds < best.solveCpuSeconds) best = std::move(s);
            }
            Json row = runJson(best, binding, targets, values, options.contacts);
            row["contacts"] = best.contacts.size();
            row["multiplier_updates"] = best.multiplierUpdates;
            rows[fmt::format("{}_{}", retargeted ? "retargeted" : "as_is", hold ? "held" : "free")] = std::move(row);
        }
    }
    const auto ratio = [&](const char* held, const char* free) {
        return rows.at(held).at("ms_per_frame").get<double>() / rows.at(free).at("ms_per_frame").get<double>();
    };
    return Json{{"rig", o.longLegsRig.string()},
                {"clip", o.clip.string()},
                {"map_after", o.longLegsMap.string()},
                {"frames", frames},
                {"contacts", rows.at("retargeted_held").at("contacts")},
                {"before", rows.at("as_is_free")},
                {"after", rows.at("retargeted_held")},
                {"runs", rows},
                {"time_ratio", ratio("retargeted_held", "retargeted_free")},
                {"time_ratio_as_is", ratio("as_is_held", "as_is_free")},
                {"learn_seconds", a.training.seconds},
                {"note",
                 "before: the CMU clip as it is, feet free; after: retargeted onto the rig's proportions "
                 "(map_after), contacts detected on the feet (LeftFoot, RightFoot) and held; runs: every "
                 "combination; slides and errors on the real rig, the held feet left out of the other joints' "
                 "errors; ms per frame in the thread's CPU time, the faster of two runs"}};
}

}  // namespace rig::bench

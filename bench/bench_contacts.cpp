#include "bench/bench_contacts.h"

#include <algorithm>
#include <numbers>

#include <fmt/format.h>

#include "core/rotation_math.h"
#include "inversion/clip_inversion.h"
#include "inversion/contacts.h"
#include "inversion/learner.h"
#include "nodes/clips/target_clip.h"
#include "nodes/graph_rig_function.h"
#include "nodes/inversion_spec.h"

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

}  // namespace

Json contactsBenchJson(const BenchOptions& o)
{
    const InversionSpec spec = readInversionSpec(o.spec);
    GraphRigFunction rig(o.longLegsRig, GraphRigOptions{spec.params, spec.outputs, {}, spec.set, spec.ranges});
    if (o.log) o.log("contacts: learning the biped with longer legs");
    const Approximation a = learnApproximation(rig, LearnOptions{}, o.longLegsRig.string());
    RigBinding binding(a, rig);
    const TargetClip clip = readTargetClip(o.clip, o.map.empty() ? TargetMap{} : readTargetMap(o.map));
    const ClipTargets targets = matchTargets(a, clip.joints, clip.worlds);
    const int frames = std::min(o.frames, static_cast<int>(targets.frames.size()));
    ClipInversionOptions options;
    options.solver.threads = 1;
    options.contacts = detectContacts(targets, contactJoints(a, targets));
    const Solver solver(a, options.solver);
    Json rows = Json::object();
    double ms[2] = {0.0, 0.0};
    int updates = 0, measured = 0;
    for (const bool hold : {false, true}) {
        if (o.log) o.log(fmt::format("contacts: inverting {} frames, contacts {}", frames, hold ? "held" : "free"));
        options.holdContacts = hold;
        // The faster of two runs: the time per frame on a machine shared with others.
        ClipInversionSummary best;
        std::vector<std::vector<double>> values;
        for (int run = 0; run < 2; ++run) {
            ClipInversionSummary s = invertClip(solver, binding, targets, 0, frames - 1, options, values);
            if (run == 0 || s.solveCpuSeconds < best.solveCpuSeconds) best = std::move(s);
        }
        Json row = runJson(best, binding, targets, values, options.contacts);
        ms[hold] = row.at("ms_per_frame").get<double>();
        updates = best.multiplierUpdates;
        measured = static_cast<int>(best.contacts.size());
        rows[hold ? "after" : "before"] = std::move(row);
    }
    return Json{{"rig", o.longLegsRig.string()},
                {"clip", o.clip.string()},
                {"frames", frames},
                {"contacts", measured},
                {"before", rows.at("before")},
                {"after", rows.at("after")},
                {"time_ratio", ms[1] / ms[0]},
                {"multiplier_updates", updates},
                {"learn_seconds", a.training.seconds},
                {"note",
                 "contacts detected on the feet (LeftFoot, RightFoot) from the clip's targets; slides and errors on "
                 "the real rig, the held feet left out of the other joints' errors; ms per frame in the thread's CPU "
                 "time, the faster of two runs"}};
}

}  // namespace rig::bench

#include "app/invert/invert_run.h"

#include <cmath>
#include <fstream>
#include <thread>
#include <tuple>

#include <fmt/format.h>

#include "adapter/retarget.h"
#include "app/common/frame_range.h"
#include "app/invert/contacts_run.h"
#include "core/error.h"
#include "graph/rig_file.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/learned_range.h"
#include "inversion/solve/residual_term.h"
#include "inversion/solve/solver_options.h"
#include "nodes/clips/maya_clip.h"

namespace rig::app {
namespace {

// --after: the values that the chunk before reported for clip frame `index` (internal units), read from
// the JSON curves rig-invert wrote for it.
std::vector<double> valuesReported(const std::string& file, const Approximation& a, const TargetClip& clip, int index,
                                   const std::string& frames)
{
    if (index < 0)
        throw Error(
            fmt::format("--after {}: frames {} start at the clip's first chain; there is no frame before them "
                        "to continue from (leave --after out)",
                        file, frames));
    const double number = clip.frameNumbers[static_cast<std::size_t>(index)];
    std::ifstream in(file);
    if (!in)
        throw Error(fmt::format(
            "--after {}: cannot read it; give the curves (.json) rig-invert wrote for the frames before", file));
    nlohmann::json curves;
    try {
        curves = nlohmann::json::parse(in);
    }
    catch (const nlohmann::json::exception& e) {
        throw Error(fmt::format("--after {}: not JSON curves written by rig-invert ({})", file, e.what()));
    }
    if (!curves.is_array())
        throw Error(fmt::format("--after {}: not JSON curves written by rig-invert (no list of frames)", file));
    for (const auto& frame : curves) {
        if (!frame.is_object() || !frame.contains("frame") || !frame["frame"].is_number() ||
            frame["frame"].get<double>() != number)
            continue;
        std::vector<double> values;
        for (const auto& m : a.parameters) {
            const RigParameter& p = m.parameter;
            const auto found = frame.find(p.name);
            if (found == frame.end() || !found->is_number() || !std::isfinite(found->get<double>()))
                throw Error(
                    fmt::format("--after {}: frame {} has no finite value of {}; give curves written with this "
                                "approximation",
                                file, number, p.name));
            values.push_back(parameterInternalValue(p, found->get<double>()));
        }
        return values;
    }
    throw Error(
        fmt::format("--after {}: has no frame {}; frames {} start their chain at frame {}, so the curves "
                    "before must reach the frame before it",
                    file, number, frames, clip.frameNumbers[static_cast<std::size_t>(index) + 1]));
}

std::string learnedFrom(const Approximation& approximation)
{
    return fmt::format(
        "the approximation was learned from {}: give that rig with --rig, or learn one for this rig "
        "with rig-learn",
        approximation.rigFile);
}

// The clip indices of --frames A:B.
std::pair<int, int> frameIndices(const TargetClip& clip, const std::string& frames)
{
    const auto range = parseFrameRange(frames, "--frames", false);
    if (range.step != 1.0)
        throw Error(
            fmt::format("--frames {}: a step is not supported; frames are solved in a warm-start chain", frames));
    const auto index = [&](double number) {
        for (std::size_t i = 0; i < clip.frameNumbers.size(); ++i)
            if (clip.frameNumbers[i] == number) return static_cast<int>(i);
        throw Error(fmt::format("--frames {}: {} has no frame {} (its frames are {} to {})", frames, clip.file, number,
                                clip.frameNumbers.front(), clip.frameNumbers.back()));
    };
    return {index(range.first), index(range.last)};
}

}  // namespace

ClipInversionOptions clipInversionOptions(const SolveSettings& s)
{
    checkSettings(s, Spelling::flag);
    ClipInversionOptions options = s.clip;
    try {
        options.validate();
    }
    catch (const Error& e) {
        throw e.in("bad option");
    }
    return options;
}

LoadedRig loadRig(const InvertJob& job)
{
    LoadedRig out;
    out.approximation = job.loadedApproximation;
    if (!out.approximation)
        out.approximation = std::make_shared<const Approximation>(readApproximationFile(job.approximation));
    const Approximation& approximation = *out.approximation;
    if (approximation.parameters.empty())
        throw Error(
            fmt::format("{}: the approximation models no parameter (all were discarded); learn it again "
                        "with other --params",
                        job.approximation));

    // The rig must have the approximation's parameters, outputs and held plugs: an approximation of another
    // rig (or a name edited by hand) is the approximation's mistake as much as the rig's. The held plugs put
    // the real rig (polish, keys, reports) in the state the approximation was learned in.
    try {
        out.rig = std::make_shared<GraphRigFunction>(job.rig, rigOptionsFor(approximation, job.plugins));
    }
    catch (const RigSelectionError& e) {
        throw Error(fmt::format("{}: {} '{}' does not fit {} ({}); {}", job.approximation, e.kind(), e.name(), job.rig,
                                e.reason(), learnedFrom(approximation)));
    }
    if (job.rigLoaded) job.rigLoaded(*out.rig);
    try {
        if (const auto warning = checkFingerprint(approximation, out.rig->fingerprint(), job.strict);
            !warning.empty() && job.warning)
            job.warning(fmt::format("{}: {}", job.approximation, warning));
    }
    catch (const Error& e) {
        throw Error(fmt::format("{}: {} (--strict)", job.approximation, e.what()));
    }
    return out;
}

RigBinding bindRig(const InvertJob& job, const Approximation& approximation, GraphRigFunction& rig)
{
    // The rig's parameters are scalar plugs: a name edited into a vector ('wrist.rotate') or into a
    // plug the rig does not offer does not bind.
    try {
        return RigBinding(approximation, rig);
    }
    catch (const Error& e) {
        std::string why = e.what();
        if (why.starts_with("RigBinding: ")) why.erase(0, 12);
        throw Error(fmt::format("{}: {} ({} does not offer it as a free keyable number); {}", job.approximation, why,
                                job.rig, learnedFrom(approximation)));
    }
}

TargetClip readTargets(const InvertJob& job, const Approximation& approximation, TargetMap* mapOut)
{
    const TargetMap map = job.map.empty() ? TargetMap{} : readTargetMap(job.map);
    TargetClip clip;
    if (job.targets) {
        clip = applyTargetMap(*job.targets, map);
    } else if (job.frames && job.take.empty() && isMayaFile(job.clip)) {
        // A Maya scene's clip reaches the frames asked for, past its playback range or not.
        const auto range = parseFrameRange(*job.frames, "--frames");
        clip = readMayaClip(job.clip, map, std::pair{range.first, range.last});
    } else {
        clip = readTargetClip(job.clip, map, job.take);
    }
    // A scene that references the rig names its joints under the reference's namespace.
    std::vector<std::string> joints;
    for (const auto& output : approximation.outputs)
        if (!output.helper) joints.push_back(output.name);
    matchNamespaces(clip, joints);
    if (map.retarget.enabled) clip = retargetClip(clip, map, rigSkeleton(approximation));
    if (mapOut) *mapOut = map;
    return clip;
}

ClipTargets matchClipTargets(const Approximation& approximation, const TargetClip& clip)
{
    try {
        return matchTargets(approximation, clip.joints, clip.worlds);
    }
    catch (const Error& e) {
        throw e.in(clip.file);
    }
}

namespace {

// Every target of the clip given the settings' residual term (a target without one is a joint target).
void applyTerm(ClipTargets& targets, TargetTerm term)
{
    if (term == TargetTerm::jointTarget) return;
    const ResidualTerm& kind = positionTerm();
    for (auto& frame : targets.frames)
        for (JointTarget& target : frame)
            if (target.active) setTerm(target, kind);
}

}  // namespace

InvertOutcome invert(const InvertJob& job)
{
    ClipInversionOptions options = clipInversionOptions(job.settings);
    LoadedRig loaded = loadRig(job);
    InvertOutcome out;
    out.approximation = loaded.approximation;
    const Approximation& approximation = *out.approximation;
    TargetMap map;
    out.clip = readTargets(job, approximation, &map);
    const TargetClip& clip = out.clip;
    int last = static_cast<int>(clip.frameNumbers.size()) - 1;
    if (job.frames) std::tie(out.first, last) = frameIndices(clip, *job.frames);
    if (job.frameIndices) {
        std::tie(out.first, last) = *job.frameIndices;
        if (out.first < 0 || out.first > last || last >= static_cast<int>(clip.frameNumbers.size()))
            throw Error(fmt::format("{}: has no frames {} to {} (0-based; it has {} frames)", clip.file, out.first,
                                    last, clip.frameNumbers.size()));
    }
    out.targets = matchClipTargets(approximation, clip);
    applyTargetWeights(out.targets, map, clip);
    applyTerm(out.targets, job.settings.term);
    out.contactsAsked = !job.contacts.empty();
    if (out.contactsAsked)
        options.contacts = readContacts(job.contacts, job.contactsName, approximation, clip, out.targets);
    const Solver solver(approximation, options.solver);
    RigBinding bound = bindRig(job, approximation, *loaded.rig);
    if (!job.after.empty())
        options.continueFrom =
            valuesReported(job.after, approximation, clip, out.first - out.first % options.restartInterval - 1,
                           job.frames ? *job.frames : "(all)");
    std::unique_ptr<HybridSolver> hybrid;
    ChainScratch hybridScratch;
    if (job.settings.hybrid) {
        const int threads = job.settings.clip.solver.threads > 0
                                ? job.settings.clip.solver.threads
                                : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
        hybrid = std::make_unique<HybridSolver>(solver, bound, threads);
        out.hybridBlocks = hybrid->describe();
        if (!hybrid->blocks().empty()) options.realRigFit = RealRigFit::unmodelledOutputs;
        if (!hybrid->blocks().empty())
            options.frameSolve = [&](std::span<const JointTarget> t, std::vector<double>& values, double previousCost,
                                     ChainFrame& frame) {
                hybrid->solveFrame(t, values, previousCost, hybridScratch, frame);
            };
    }
    if (job.progress) {
        const int total = last - out.first + 1;
        // invertClip gives done / total.
        options.progress = [&job, total](double fraction) {
            job.progress(static_cast<int>(std::lround(fraction * total)), total);
        };
    }
    out.summary = invertClip(solver, bound, out.targets, out.first, last, options, out.values, &out.solved);
    out.rig = std::move(loaded.rig);
    return out;
}

std::vector<std::vector<double>> curveValues(const Approximation& approximation,
                                             const std::vector<std::vector<double>>& values)
{
    const auto& parameters = approximation.parameters;
    std::vector<std::vector<double>> out;
    for (const auto& frame : values) {
        auto& row = out.emplace_back();
        for (std::size_t i = 0; i < parameters.size(); ++i)
            row.push_back(parameterUserValue(parameters[i].parameter, frame[i]));
    }
    return out;
}

std::vector<std::vector<double>> curveValues(const InvertOutcome& outcome)
{
    return curveValues(*outcome.approximation, outcome.values);
}

std::string curvesJsonFrames(const Approximation& approximation, std::span<const double> frameNumbers,
                             const std::vector<std::vector<double>>& values)
{
    const auto& parameters = approximation.parameters;
    const auto user = curveValues(approximation, values);
    std::string out;
    for (std::size_t f = 0; f < user.size(); ++f) {
        std::vector<std::pair<std::string, Json>> named;
        for (std::size_t i = 0; i < parameters.size(); ++i)
            named.emplace_back(parameters[i].parameter.name, numberJson(user[f][i]));
        out += (f ? ",\n" : "") + frameJson(frameNumbers[f], named);
    }
    return out;
}

// graph-eval's layout, so that a graph driven by the curves prints the same file.
std::string curvesJsonFile(std::string_view frames)
{
    return fmt::format("[\n{}{}]\n", frames, frames.empty() ? "" : "\n");
}

std::string curvesJson(const InvertOutcome& outcome)
{
    return curvesJsonFile(curvesJsonFrames(
        *outcome.approximation, std::span(outcome.clip.frameNumbers).subspan(static_cast<std::size_t>(outcome.first)),
        outcome.values));
}

std::string curvesCsv(const InvertOutcome& outcome)
{
    std::string out = "frame";
    for (const auto& p : outcome.approximation->parameters) out += "," + p.parameter.name;
    out += "\n";
    const auto values = curveValues(outcome);
    for (std::size_t f = 0; f < values.size(); ++f) {
        out += fmt::format("{}", outcome.clip.frameNumbers[static_cast<std::size_t>(outcome.first) + f]);
        for (const double v : values[f]) out += std::isfinite(v) ? fmt::format(",{}", v) : ",";
        out += "\n";
    }
    return out;
}

std::vector<std::string> unmodelledOutputs(const Approximation& approximation)
{
    std::vector<std::string> names;
    for (const auto& o : approximation.outputs)
        if (!o.modelled) names.push_back(o.name);
    return names;
}

Json statusCountsJson(const ClipInversionSummary& s)
{
    Json counts = Json::object();
    for (int k = 0; k < frameStatusCount; ++k)
        counts[frameStatusKey(static_cast<FrameStatus>(k))] = s.statusFrames[static_cast<std::size_t>(k)];
    return counts;
}

Json residualJointsJson(const ClipInversionSummary& s)
{
    Json joints = Json::object();
    for (const auto& joint : s.residualJoints)
        joints[joint.name] = {{"frames", joint.frames},
                              {"worst_position_error_cm", numberJson(joint.worstPositionErrorCm)},
                              {"worst_rotation_error_deg", numberJson(joint.worstRotationErrorDeg)}};
    return joints;
}

std::string statusCountsText(const ClipInversionSummary& s)
{
    std::string text;
    for (int k = 0; k < frameStatusCount; ++k)
        if (const int n = s.statusFrames[static_cast<std::size_t>(k)]; n > 0)
            text += fmt::format("{}{} {}", text.empty() ? "" : ", ", n, frameStatusName(static_cast<FrameStatus>(k)));
    return text.empty() ? "none" : text;
}

namespace {

// "up to 93.15 deg", "down to -95 deg" or "from -95 to 93.15 deg": the values a parameter took past its range.
std::string valuesLeft(const RangeLeft& r)
{
    const char* unit = r.angular ? " deg" : "";
    if (r.low < r.learnedMin && r.high > r.learnedMax)
        return fmt::format("from {:.4g} to {:.4g}{}", r.low, r.high, unit);
    return r.high > r.learnedMax ? fmt::format("up to {:.4g}{}", r.high, unit)
                                 : fmt::format("down to {:.4g}{}", r.low, unit);
}

// A model mismatch where a parameter left its learned range: which, and the rig-learn flags that learn over the range
// the clip uses (rig-learn --range, --ranges-from: docs/rig-learn.md).
std::string rangeFix(const RangeLeft& r, const std::string& joint, const MismatchFix& fix)
{
    const auto [min, max] = widenedRange(r.learnedMin, r.learnedMax, r.low, r.high);
    const std::string from = fix.clip.empty() ? "CLIP"
                                              : fix.clip + (fix.map.empty() ? "" : " --map " + fix.map) +
                                                    (fix.take.empty() ? "" : " --take " + fix.take) +
                                                    (fix.frames.empty() ? "" : " --frames " + fix.frames);
    return fmt::format(
        "the approximation disagrees with the real rig at {}, which {} moves, at {} on the failed frames, outside the "
        "{:g}..{:g}{} it was learned over; learn the rig again over the range the clip uses: rig-learn {} ... --range "
        "{}={:g}:{:g} (... your other flags), or rig-learn ... --ranges-from {} for every control",
        joint, r.parameter, valuesLeft(r), r.learnedMin, r.learnedMax, r.angular ? " deg" : "",
        fix.rig.empty() ? "RIG" : fix.rig, exactGlob(r.parameter), min, max, from);
}

}  // namespace

std::string failedFramesLine(const ClipInversionSummary& s, double frameNumber, const MismatchFix& fix)
{
    const FrameStatus status = s.firstFailedStatus;
    const std::string why =
        status == FrameStatus::modelMismatch && s.firstFailedRange.found()
            ? rangeFix(s.firstFailedRange, s.firstFailedJoint, fix)
        : status == FrameStatus::modelMismatch
            ? "the approximation and the real rig disagree there, or a target it does not model was not fitted "
              "(--hybrid fits those; learn the rig again where it disagrees)"
        : status == FrameStatus::notConverged ? "the solve used its iterations"
        : status == FrameStatus::nonFinite    ? "the real rig gives a non-finite matrix, error or cost there"
                                              : "a target there is not finite or is singular";
    return fmt::format("{} of {} frames are not an answer on the real rig (first: frame {}, {}, {}): {}",
                       s.failedFrames(), s.frames, frameNumber, frameStatusName(status), s.firstFailedJoint, why);
}

Json rangeLeftJson(const RangeLeft& r)
{
    if (!r.found()) return Json();
    const auto [min, max] = widenedRange(r.learnedMin, r.learnedMax, r.low, r.high);
    return {{"parameter", r.parameter},
            {"unit", r.angular ? "deg" : "rig"},
            {"learned", {numberJson(r.learnedMin), numberJson(r.learnedMax)}},
            {"reached", {numberJson(r.low), numberJson(r.high)}},
            {"suggested", {numberJson(min), numberJson(max)}}};
}

Json invertReport(const InvertOutcome& outcome, const std::optional<std::string>& approximation, const std::string& rig,
                  const std::optional<std::string>& clip, const std::optional<std::string>& curvesFile,
                  const std::string& curvesFingerprint)
{
    const Approximation& a = *outcome.approximation;
    const ClipInversionSummary& s = outcome.summary;
    const auto frameNumber = [&](int index) {
        return index >= 0 ? numberJson(outcome.clip.frameNumbers[static_cast<std::size_t>(index)]) : Json();
    };
    const auto nameOrNull = [](const std::optional<std::string>& name) { return name ? Json(*name) : Json(); };
    // What was not measured (a frame of invalid targets, a run of them) is null, never 0.
    const auto measured = [](bool was, Json value) { return was ? std::move(value) : Json(); };
    Json perFrame = Json::array();
    for (const auto& f : s.perFrame) {
        Json missed = Json::array();
        for (const auto& m : f.missed) missed.push_back(a.outputs[static_cast<std::size_t>(m.output)].name);
        perFrame.push_back({{"frame", frameNumber(f.frame)},
                            {"status", frameStatusName(f.status)},
                            {"termination", terminationName(f.solve.termination)},
                            {"missed_joints", std::move(missed)},
                            {"iterations", f.solve.iterations},
                            {"real_rig_evaluations", f.realRigEvaluations},
                            {"position_error_cm", measured(f.measured(), numberJson(f.positionErrorCm))},
                            {"worst_joint", measured(f.measured(), f.worstJoint)},
                            {"rotation_error_deg", measured(f.measured(), numberJson(f.rotationErrorDeg))},
                            {"worst_rotation_joint", measured(f.measured(), f.worstRotationJoint)},
                            {"model_gap_cm", measured(f.measured(), numberJson(f.modelGapCm))},
                            {"non_finite_joint", f.nonFiniteJoint.empty() ? Json() : Json(f.nonFiniteJoint)}});
    }
    return Json{
        {"approximation", nameOrNull(approximation)},
        {"rig", rig},
        {"held", heldJson(a.held)},
        {"clip", nameOrNull(clip)},
        {"clip_source", outcome.clip.source.empty() ? Json() : Json(outcome.clip.source)},
        {"parameters", a.parameters.size()},
        {"target_joints", outcome.targets.matchedJoints},
        {"frames", s.frames},
        {"status_frames", statusCountsJson(s)},
        {"failed_frames", s.failedFrames()},
        {"first_failure", s.firstFailedFrame >= 0 ? Json{{"frame", frameNumber(s.firstFailedFrame)},
                                                         {"status", frameStatusName(s.firstFailedStatus)},
                                                         {"joint", s.firstFailedJoint},
                                                         {"left_range", rangeLeftJson(s.firstFailedRange)}}
                                                  : Json()},
        {"retried_frames", s.retriedFrames},
        {"retries_kept", s.retriesKept},
        {"residual_joints", residualJointsJson(s)},
        {"max_position_error_cm", measured(s.measured(), numberJson(s.maxPositionErrorCm))},
        {"worst_joint", measured(s.measured(), s.worstJoint)},
        {"worst_frame", frameNumber(s.worstFrame)},
        {"mean_position_error_cm", measured(s.measured(), numberJson(s.meanPositionErrorCm))},
        {"max_rotation_error_deg", measured(s.measured(), numberJson(s.maxRotationErrorDeg))},
        {"worst_rotation_joint", measured(s.measured(), s.worstRotationJoint)},
        {"worst_rotation_frame", frameNumber(s.worstRotationFrame)},
        {"mean_rotation_error_deg", measured(s.measured(), numberJson(s.meanRotationErrorDeg))},
        {"max_model_gap_cm", measured(s.measured(), numberJson(s.maxModelGapCm))},
        {"ms_per_frame", numberJson(s.msPerFrame)},
        {"setup_ms", numberJson(1e3 * s.setupSeconds)},
        {"lead_in_frames", s.leadInFrames},
        {"unmodelled_outputs", unmodelledOutputs(a)},
        {"contacts", contactsJson(s, a, outcome.clip.frameNumbers, outcome.contactsAsked)},
        {"hybrid", outcome.hybridBlocks.empty()
                       ? Json()
                       : Json{{"blocks", outcome.hybridBlocks},
                              {"real_rig_evaluations", s.realRigEvaluations},
                              {"real_rig_evaluations_per_frame",
                               numberJson(s.frames > 0 ? static_cast<double>(s.realRigEvaluations) / s.frames : 0.0)}}},
        // Which curves this report belongs to: a run killed between the two writes leaves a pair that
        // says it does not match.
        {"curves", {{"file", nameOrNull(curvesFile)}, {"fnv1a64", curvesFingerprint}}},
        {"per_frame", std::move(perFrame)}};
}

std::string fingerprintText(const std::string& text) { return fmt::format("{:016x}", fnv1a64(text)); }

}  // namespace rig::app

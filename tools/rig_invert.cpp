// rig-invert: inverts a clip of target joints to rig parameter curves with a learned approximation,
// and measures the result on the real rig (docs/rig-invert.md).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "graph/error.h"
#include "inversion/approximation_io.h"
#include "inversion/clip_inversion.h"
#include "nodes/clips/target_clip.h"
#include "nodes/graph_rig_function.h"
#include "tools/cli_common.h"
#include "tools/progress_bar.h"
#include "tools/value_output.h"

namespace rig {
namespace {

struct Options {
    std::string approximation;
    std::string rig;
    std::string clip;
    std::string map;
    std::string frames;
    bool framesGiven = false;  // --frames '' is an error, not the whole clip
    std::string output;
    std::string reportJson;
    std::vector<std::string> plugins;
    int threads = 0;
    bool strict = false;
    bool noPartition = false;
    bool blockByBlock = false;
    std::string jacobian = "analytic";
    int polish = 0;
    int restartEvery = ClipInversionOptions{}.restartInterval;
    bool restStarts = false;
    std::string after;  // curves of the chunk before (--after)
    bool quiet = false;
};

double userValue(const RigParameter& p, double value) { return p.angular ? value * 180.0 / std::numbers::pi : value; }

// --after: the values that the chunk before reported for clip frame `index` (internal units), read from
// the JSON curves rig-invert wrote for it.
std::vector<double> valuesReported(const std::string& file, const Approximation& a, const TargetClip& clip, int index,
                                   const std::string& frames)
{
    if (index < 0)
        throw Error(fmt::format("--after {}: frames {} start at the clip's first chain; there is no frame before them "
                                "to continue from (leave --after out)",
                                file, frames));
    const double number = clip.frameNumbers[static_cast<std::size_t>(index)];
    std::ifstream in(file);
    if (!in)
        throw Error(fmt::format("--after {}: cannot read it; give the curves (.json) rig-invert wrote for the frames before",
                                file));
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
                throw Error(fmt::format("--after {}: frame {} has no finite value of {}; give curves written with this "
                                        "approximation",
                                        file, number, p.name));
            values.push_back(p.angular ? found->get<double>() * std::numbers::pi / 180.0 : found->get<double>());
        }
        return values;
    }
    throw Error(fmt::format("--after {}: has no frame {}; frames {} start their chain at frame {}, so the curves before "
                            "must reach the frame before it",
                            file, number, frames, clip.frameNumbers[static_cast<std::size_t>(index) + 1]));
}

// graph-eval's layout, so that a graph driven by the curves prints the same file.
std::string curvesJson(const Approximation& a, const TargetClip& clip, int first,
                       const std::vector<std::vector<double>>& values)
{
    std::string out = "[\n";
    for (std::size_t f = 0; f < values.size(); ++f) {
        std::vector<std::pair<std::string, cli::Json>> named;
        for (std::size_t i = 0; i < a.parameters.size(); ++i)
            named.emplace_back(a.parameters[i].parameter.name,
                               cli::numberJson(userValue(a.parameters[i].parameter, values[f][i])));
        out += cli::frameJson(clip.frameNumbers[first + f], named) + (f + 1 < values.size() ? ",\n" : "\n");
    }
    return out + "]\n";
}

std::string curvesCsv(const Approximation& a, const TargetClip& clip, int first,
                      const std::vector<std::vector<double>>& values)
{
    std::string out = "frame";
    for (const auto& p : a.parameters) out += "," + p.parameter.name;
    out += "\n";
    for (std::size_t f = 0; f < values.size(); ++f) {
        out += fmt::format("{}", clip.frameNumbers[first + f]);
        for (std::size_t i = 0; i < a.parameters.size(); ++i) {
            const double v = userValue(a.parameters[i].parameter, values[f][i]);
            out += std::isfinite(v) ? fmt::format(",{}", v) : ",";
        }
        out += "\n";
    }
    return out;
}

std::string reportJson(const Options& o, const Approximation& a, const TargetClip& clip,
                       const ClipTargets& targets, const ClipInversionSummary& s, const std::string& curvesFingerprint)
{
    cli::Json perFrame = cli::Json::array();
    for (const auto& f : s.perFrame) {
        cli::Json missed = cli::Json::array();
        for (const int k : f.solve.missedOutputs) missed.push_back(a.outputs[static_cast<std::size_t>(k)].name);
        perFrame.push_back({{"frame", cli::numberJson(clip.frameNumbers[f.frame])},
                            {"termination", terminationName(f.solve.termination)},
                            {"missed_joints", std::move(missed)},
                            {"iterations", f.solve.iterations},
                            {"position_error_cm", cli::numberJson(f.positionErrorCm)},
                            {"rotation_error_deg", cli::numberJson(f.rotationErrorDeg)},
                            {"worst_joint", f.worstJoint},
                            {"non_finite_joint", f.nonFiniteJoint.empty() ? cli::Json() : cli::Json(f.nonFiniteJoint)}});
    }
    cli::Json stuckJoints = cli::Json::object();
    for (const auto& joint : s.stuckJoints)
        stuckJoints[joint.name] = {{"frames", joint.frames}, {"worst_position_error_cm", cli::numberJson(joint.worstErrorCm)}};
    const cli::Json report{
        {"approximation", o.approximation},
        {"rig", o.rig},
        {"clip", o.clip},
        {"parameters", a.parameters.size()},
        {"target_joints", targets.matchedJoints},
        {"frames", s.frames},
        {"converged_frames", s.convergedFrames},
        {"stuck_frames", s.stuckFrames},
        {"retried_frames", s.retriedFrames},
        {"retries_kept", s.retriesKept},
        {"stuck_joints", std::move(stuckJoints)},
        {"max_position_error_cm", cli::numberJson(s.maxPositionErrorCm)},
        {"mean_position_error_cm", cli::numberJson(s.meanPositionErrorCm)},
        {"max_rotation_error_deg", cli::numberJson(s.maxRotationErrorDeg)},
        {"mean_rotation_error_deg", cli::numberJson(s.meanRotationErrorDeg)},
        {"worst_joint", s.worstJoint},
        {"worst_frame", s.worstFrame >= 0 ? cli::numberJson(clip.frameNumbers[s.worstFrame]) : cli::Json()},
        {"ms_per_frame", cli::numberJson(s.msPerFrame)},
        {"lead_in_frames", s.leadInFrames},
        {"non_finite_frames", s.nonFiniteFrames},
        // Which curves this report belongs to: a run killed between the two writes leaves a pair that
        // says it does not match.
        {"curves", {{"file", o.output}, {"fnv1a64", curvesFingerprint}}},
        {"per_frame", std::move(perFrame)}};
    return cli::jsonText(report, 2) + "\n";
}

void printReport(const Options& o, const Approximation& a, const TargetClip& clip, const ClipTargets& targets,
                 const ClipInversionSummary& s)
{
    std::cout << fmt::format("rig-invert: {} on {} with {} ({} parameters, {} target joints)\n", o.clip, o.rig,
                             o.approximation, a.parameters.size(), targets.matchedJoints);
    if (!targets.unmatchedJoints.empty())
        std::cout << fmt::format("  {} clip joints are not outputs of the approximation and were not targets\n",
                                 targets.unmatchedJoints.size());
    std::cout << fmt::format("\n{:>8}  {:<14} {:>5}  {:>12}  {:>12}  {}\n", "frame", "termination", "iter",
                             "error cm", "error deg", "worst joint");
    for (const auto& f : s.perFrame)
        std::cout << fmt::format("{:>8}  {:<14} {:>5}  {:>12.4g}  {:>12.4g}  {}\n", clip.frameNumbers[f.frame],
                                 terminationName(f.solve.termination), f.solve.iterations, f.positionErrorCm,
                                 f.rotationErrorDeg, f.worstJoint);
    std::cout << fmt::format("\nframes            {} ({} converged to the targets, {} stuck: stationary with a "
                             "residual, {} not converged)\n",
                             s.frames, s.convergedFrames, s.stuckFrames, s.frames - s.convergedFrames - s.stuckFrames);
    if (!s.stuckJoints.empty()) {
        // The joints stuck frames left short of their targets, the largest real-rig error first.
        std::string joints;
        const std::size_t shown = std::min<std::size_t>(s.stuckJoints.size(), 6);
        for (std::size_t i = 0; i < shown; ++i)
            joints += fmt::format("{}{} ({:.3g} cm, {} frames)", i ? ", " : "", s.stuckJoints[i].name,
                                  s.stuckJoints[i].worstErrorCm, s.stuckJoints[i].frames);
        if (shown < s.stuckJoints.size()) joints += fmt::format(" and {} more", s.stuckJoints.size() - shown);
        std::cout << fmt::format("stuck joints      {}\n", joints);
    }
    if (s.nonFiniteFrames > 0)
        std::cout << fmt::format("real rig          NOT FINITE at {} frames (first: {} at frame {})\n", s.nonFiniteFrames,
                                 s.firstNonFiniteJoint, clip.frameNumbers[s.firstNonFiniteFrame]);
    std::cout << fmt::format("real-rig error    worst {:.4g} cm, {:.4g} deg ({} at frame {}); mean {:.4g} cm, "
                             "{:.4g} deg\n",
                             s.maxPositionErrorCm, s.maxRotationErrorDeg, s.worstJoint,
                             s.worstFrame >= 0 ? clip.frameNumbers[s.worstFrame] : 0.0, s.meanPositionErrorCm,
                             s.meanRotationErrorDeg);
    std::cout << fmt::format("time              {:.4g} ms per frame (solver only{})\n", s.msPerFrame,
                             s.leadInFrames ? fmt::format("; {} lead-in frames not counted", s.leadInFrames) : "");
    std::cout << fmt::format("curves            {}\n", o.output);
}

int run(const Options& o)
{
    // Everything that can be checked before the work is.
    cli::checkOutputFile(o.output, "curves.json");
    const auto extension = std::filesystem::path(o.output).extension();
    if (extension != ".json" && extension != ".csv")
        throw Error(fmt::format("-o {}: the curves are written as .json or .csv; give one of those", o.output));
    if (!o.reportJson.empty()) cli::checkOutputFile(o.reportJson, "report.json", "--report-json");
    cli::checkDistinctFiles({{"the approximation", o.approximation}, {"the rig file", o.rig}, {"the clip", o.clip},
                             {"the map", o.map}, {"--after", o.after}},
                            {{"-o", o.output}, {"--report-json", o.reportJson}});
    ClipInversionOptions options;
    options.solver.threads = o.threads;
    options.solver.partition = !o.noPartition;
    options.solver.coupledBlocks = !o.blockByBlock;
    if (o.jacobian == "analytic") options.solver.jacobian = JacobianMethod::analytic;
    else if (o.jacobian == "fd") options.solver.jacobian = JacobianMethod::finiteDifference;
    else throw Error(fmt::format("--jacobian {}: expected analytic or fd", o.jacobian));
    if (o.polish < 0)
        throw Error(fmt::format("--polish {}: give 0 (the approximation only) or more real-rig corrections per frame",
                                o.polish));
    if (o.restartEvery < 1)
        throw Error(fmt::format("--restart-every {}: give 1 or more frames between warm-start restarts (default {})",
                                o.restartEvery, ClipInversionOptions{}.restartInterval));
    options.polishCorrections = o.polish;
    options.restartInterval = o.restartEvery;
    options.coldStart = !o.restStarts;
    try {
        options.validate();
    }
    catch (const std::invalid_argument& e) {
        throw Error(fmt::format("bad option: {}", e.what()));
    }

    Approximation approximation;
    try {
        approximation = readApproximationFile(o.approximation);
    }
    catch (const ApproximationFileError& e) {
        throw Error(e.what());
    }
    if (approximation.parameters.empty())
        throw Error(fmt::format("{}: the approximation models no parameter (all were discarded); learn it again "
                                "with other --params",
                                o.approximation));

    GraphRigOptions rigOptions;
    for (const auto& p : approximation.parameters) rigOptions.parameterGlobs.push_back(p.parameter.name);
    for (const auto& out : approximation.outputs) rigOptions.outputGlobs.push_back(out.name);
    rigOptions.plugins = o.plugins;
    // The rig must have the approximation's parameters and outputs: an approximation of another rig (or a
    // name edited by hand) is the approximation's mistake as much as the rig's.
    const auto learnedFrom = [&] {
        return fmt::format("the approximation was learned from {}: give that rig with --rig, or learn one for this "
                           "rig with rig-learn",
                           approximation.rigFile);
    };
    std::optional<GraphRigFunction> loaded;
    try {
        loaded.emplace(o.rig, rigOptions);
    }
    catch (const RigSelectionError& e) {
        throw Error(fmt::format("{}: {} '{}' does not fit {} ({}); {}", o.approximation, e.kind(), e.name(), o.rig,
                                e.reason(), learnedFrom()));
    }
    GraphRigFunction& rig = *loaded;
    std::vector<cli::NamedFile> read;
    for (const auto& file : rig.files()) read.push_back({"a file the rig reads", file});
    cli::checkDistinctFiles(read, {{"-o", o.output}, {"--report-json", o.reportJson}});
    try {
        if (const auto warning = checkFingerprint(approximation, rig.fingerprint(), o.strict); !warning.empty())
            std::cerr << "warning: " << o.approximation << ": " << warning << "\n";
    }
    catch (const ApproximationFileError& e) {
        throw Error(fmt::format("{}: {} (--strict)", o.approximation, e.what()));
    }

    const TargetMap map = o.map.empty() ? TargetMap{} : readTargetMap(o.map);
    const TargetClip clip = readTargetClip(o.clip, map);
    int first = 0, last = static_cast<int>(clip.frameNumbers.size()) - 1;
    if (o.framesGiven) {
        const auto range = cli::parseFrameRange(o.frames, "--frames");
        if (range.step != 1.0)
            throw Error(fmt::format("--frames {}: a step is not supported; frames are solved in a warm-start chain",
                                    o.frames));
        const auto index = [&](double number) {
            for (std::size_t i = 0; i < clip.frameNumbers.size(); ++i)
                if (clip.frameNumbers[i] == number) return static_cast<int>(i);
            throw Error(fmt::format("--frames {}: {} has no frame {} (its frames are {} to {})", o.frames, o.clip,
                                    number, clip.frameNumbers.front(), clip.frameNumbers.back()));
        };
        first = index(range.first);
        last = index(range.last);
    }

    ClipTargets targets;
    try {
        targets = matchTargets(approximation, clip.joints, clip.worlds);
    }
    catch (const std::invalid_argument& e) {
        throw Error(fmt::format("{}: {}", o.clip, e.what()));
    }
    const Solver solver(approximation, options.solver);
    // The rig's parameters are scalar plugs: a name edited into a vector ('wrist.rotate') or into a
    // plug the rig does not offer does not bind.
    std::optional<RigBinding> bound;
    try {
        bound.emplace(approximation, rig);
    }
    catch (const std::invalid_argument& e) {
        std::string why = e.what();
        if (why.starts_with("RigBinding: ")) why.erase(0, 12);
        throw Error(fmt::format("{}: {} ({} does not offer it as a free keyable number); {}", o.approximation, why, o.rig,
                                learnedFrom()));
    }
    RigBinding& binding = *bound;
    if (!o.after.empty())
        options.continueFrom = valuesReported(o.after, approximation, clip, first - first % options.restartInterval - 1,
                                              o.framesGiven ? o.frames : "(all)");
    cli::ProgressBar bar("inverting");
    options.progress = [&](double fraction) { bar.update(fraction); };
    std::vector<std::vector<double>> values;
    const auto summary = invertClip(solver, binding, targets, first, last, options, values);
    bar.finish();

    const std::string curves = extension == ".csv" ? curvesCsv(approximation, clip, first, values)
                                                   : curvesJson(approximation, clip, first, values);
    cli::writeFileAtomically(o.output, curves);
    if (!o.reportJson.empty())
        cli::writeFileAtomically(o.reportJson, reportJson(o, approximation, clip, targets, summary,
                                                          fmt::format("{:016x}", fnv1a64(curves))));
    if (!o.quiet) printReport(o, approximation, clip, targets, summary);
    // Measured as wrong: never an exit code of success.
    if (summary.nonFiniteFrames > 0) {
        std::cerr << oneLine(fmt::format("error: the real rig gives a non-finite matrix at {} of {} frames (first: {} at "
                                         "frame {}); the rig cannot follow these curves there",
                                         summary.nonFiniteFrames, summary.frames, summary.firstNonFiniteJoint,
                                         clip.frameNumbers[summary.firstNonFiniteFrame]))
                  << '\n';
        return 3;
    }
    return 0;
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    CLI::App app("Inverts a clip of target joints to rig parameter curves with a learned approximation "
                 "(docs/rig-invert.md).",
                 "rig-invert");
    app.add_option("approximation", options.approximation, "Approximation file written by rig-learn")->required();
    app.add_option("--rig", options.rig, "The rig file the approximation was learned from")->required();
    app.add_option("--clip", options.clip, "Targets: a .bvh file, or a .json file of world matrices (graph-eval)")
        ->required();
    app.add_option("--map", options.map, "Map file: scale of the clip and target-to-rig joint names");
    app.add_option("--frames", options.frames, "Frames A:B of the clip, inclusive, in the clip's numbering");
    app.add_option("-o,--output", options.output, "Curves to write: .json or .csv, angles in degrees")->required();
    app.add_option("--report-json", options.reportJson, "Write the report as JSON to this file");
    app.add_option("--threads", options.threads, "Threads for the solver (0: all cores); results do not depend on it")
        ->check(rig::cli::threadCount());
    app.add_option("--jacobian", options.jacobian, "analytic (default) or fd (finite differences, in parallel)");
    app.add_flag("--no-partition", options.noPartition, "Solve all parameters as one dense problem");
    app.add_flag("--block-by-block", options.blockByBlock,
                 "Solve the partition's blocks one after another, each outer block held (faster, a worse optimum "
                 "on unreachable targets)");
    app.add_option("--polish", options.polish, "Real-rig corrections per frame (0: approximation only)");
    app.add_option("--restart-every", options.restartEvery,
                   "Frames between warm-start restarts (chunks of a clip then match one run)");
    app.add_option("--after", options.after,
                   "JSON curves rig-invert wrote for the frames before these: this run continues them (the curves "
                   "of chunks then equal one run's)");
    app.add_flag("--rest-starts", options.restStarts,
                 "Restart frames start from the rest values instead of the approximation's initial guess");
    app.add_flag("--strict", options.strict, "Refuse an approximation learned from another version of the rig");
    app.add_option("--plugin", options.plugins, "Load a plugin before reading the rig");
    app.add_flag("-q,--quiet", options.quiet, "Print nothing but errors and warnings");
    return rig::cli::runMain(app, argc, argv, [&] {
        options.framesGiven = app.count("--frames") > 0;
        return rig::run(options);
    });
}

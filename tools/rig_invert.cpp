// rig-invert: inverts a clip of target joints to rig parameter curves with a learned approximation,
// and measures the result on the real rig (docs/rig-invert.md).
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>

#include <fmt/format.h>

#include "app/common/output_file.h"
#include "app/common/progress_bar.h"
#include "app/invert/invert_run.h"
#include "app/invert/keys_run.h"
#include "app/invert/maya_scene_output.h"
#include "app/report/html_report.h"
#include "core/error.h"
#include "tools/cli_common.h"
#include "tools/solve_flags.h"

namespace rig {
namespace {

// The inversion's inputs and rig-invert's own options.
struct Options : app::InversionInputs {
    std::string clip;
    std::string frames;
    bool framesGiven = false;  // --frames '' is an error, not the whole clip
    std::string output;
    std::string reportJson;
    std::string after;  // curves of the chunk before (--after)
    bool quiet = false;
    app::KeySettings keys;
    bool keysGiven = false;  // --key-tolerance or --key-tolerance-deg: keys instead of a value per frame
    std::string html;
};

void printReport(const Options& o, const app::InvertOutcome& outcome, const app::KeysOutcome* keys,
                 const std::vector<app::SceneCurveDifference>& sceneCurves)
{
    const Approximation& a = *outcome.approximation;
    const TargetClip& clip = outcome.clip;
    const ClipTargets& targets = outcome.targets;
    const ClipInversionSummary& s = outcome.summary;
    std::cout << fmt::format("rig-invert: {} on {} with {} ({} parameters, {} target joints)\n", o.clip, o.rig,
                             o.approximation, a.parameters.size(), targets.matchedJoints);
    if (!clip.source.empty()) std::cout << fmt::format("  clip: {}\n", clip.source);
    if (!a.held.empty())
        std::cout << fmt::format("  the rig is held as the approximation was learned: {}\n", app::heldText(a.held));
    if (!targets.unmatchedJoints.empty())
        std::cout << fmt::format("  {} clip joints are not outputs of the approximation and were not targets\n",
                                 targets.unmatchedJoints.size());
    std::cout << fmt::format("\n{:>8}  {:<15} {:>5}  {:>12}  {:<14} {:>12}  {}\n", "frame", "status", "iter",
                             "error cm", "joint", "error deg", "joint");
    for (const auto& f : s.perFrame)
        if (f.measured())
            std::cout << fmt::format("{:>8}  {:<15} {:>5}  {:>12.4g}  {:<14} {:>12.4g}  {}\n",
                                     clip.frameNumbers[f.frame], frameStatusName(f.status), f.solve.iterations,
                                     f.positionErrorCm, f.worstJoint, f.rotationErrorDeg, f.worstRotationJoint);
        else
            std::cout << fmt::format("{:>8}  {:<15} {:>5}  {:>12}  {:<14} {:>12}\n", clip.frameNumbers[f.frame],
                                     frameStatusName(f.status), f.solve.iterations, "-", "", "-");
    const auto frameNumber = [&](int index) { return index >= 0 ? clip.frameNumbers[index] : 0.0; };
    std::cout << fmt::format("\nframes            {}: {}\n", s.frames, app::statusCountsText(s));
    if (!s.residualJoints.empty()) {
        // The joints left off their targets on the real rig, the largest error first, each with its worst position
        // and rotation errors apart (each in its own unit).
        std::string joints;
        const std::size_t shown = std::min<std::size_t>(s.residualJoints.size(), 6);
        for (std::size_t i = 0; i < shown; ++i) {
            const auto& joint = s.residualJoints[i];
            joints += fmt::format("{}{} ({:.3g} cm, {:.3g} deg, {} frames)", i ? ", " : "", joint.name,
                                  joint.worstPositionErrorCm, joint.worstRotationErrorDeg, joint.frames);
        }
        if (shown < s.residualJoints.size()) joints += fmt::format(" and {} more", s.residualJoints.size() - shown);
        std::cout << fmt::format("residual joints   {}\n", joints);
    }
    if (!s.measured())
        std::cout << "real-rig error    not measured (no frame has a target it could be measured against)\n";
    else {
        std::cout << fmt::format(
            "real-rig error    worst {:.4g} cm ({} at frame {}), {:.4g} deg ({} at frame {}); mean {:.4g} cm, "
            "{:.4g} deg\n",
            s.maxPositionErrorCm, s.worstJoint, frameNumber(s.worstFrame), s.maxRotationErrorDeg, s.worstRotationJoint,
            frameNumber(s.worstRotationFrame), s.meanPositionErrorCm, s.meanRotationErrorDeg);
        std::cout << fmt::format(
            "model gap         {:.3g} cm at worst (the approximation against the real rig at the answers)\n",
            s.maxModelGapCm);
    }
    const std::vector<std::string> unmodelled = app::unmodelledOutputs(a);
    if (!outcome.hybridBlocks.empty())
        std::cout << fmt::format("hybrid            {}\n                  {:.4g} real-rig evaluations per frame\n",
                                 outcome.hybridBlocks, s.frames > 0 ? double(s.realRigEvaluations) / s.frames : 0.0);
    else if (!unmodelled.empty())
        std::cout << fmt::format(
            "not modelled      {} (non-compositional: their targets were not fitted, so frames that miss them "
            "are model mismatches; --hybrid fits them on the real rig)\n",
            fmt::join(unmodelled, ", "));
    if (outcome.contactsAsked) {
        std::cout << fmt::format("contacts          {}: foot slide on the real rig worst {:.4g} cm, mean {:.4g} cm\n",
                                 s.contacts.size(), maxSlideCm(s.contacts), meanSlideCm(s.contacts));
        for (const ContactSlide& c : s.contacts)
            std::cout << fmt::format("                  {} frames {} to {}: {:.4g} cm\n", a.outputs[c.output].name,
                                     clip.frameNumbers[c.first], clip.frameNumbers[c.last], c.slideCm);
    }
    std::cout << fmt::format(
        "time              {:.4g} ms per frame (solver only{}); setup {:.3g} ms, once\n", s.msPerFrame,
        s.leadInFrames ? fmt::format("; {} lead-in frames not counted", s.leadInFrames) : "", 1e3 * s.setupSeconds);
    if (keys) std::cout << app::keysText(outcome, *keys);
    std::cout << app::sceneCurvesText(sceneCurves);
    std::cout << fmt::format("curves            {}\n", o.output);
    if (!o.html.empty()) std::cout << fmt::format("report page       {}\n", o.html);
}

// The curves, the report and the page of one run, given to `files`, which commits them together.
void setOutputs(app::OutputFiles& files, const Options& o, const app::InvertOutcome& outcome,
                const app::KeysOutcome* keys, TangentType tangent, const std::string& threeJs,
                const std::vector<app::SceneCurveDifference>& sceneCurves)
{
    const auto extension = std::filesystem::path(o.output).extension();
    std::string curves;
    if (extension == ".anim") curves = app::curvesAnim(outcome, keys, tangent);
    else if (extension == ".ma") curves = app::curvesMayaScene(outcome, keys, tangent, o.rig, o.output);
    else if (extension == ".csv") curves = keys ? app::keyedCurvesCsv(outcome, *keys) : app::curvesCsv(outcome);
    else curves = keys ? app::keyedCurvesJson(outcome, *keys) : app::curvesJson(outcome);
    if (!o.reportJson.empty()) {
        app::Json report =
            app::invertReport(outcome, o.approximation, o.rig, o.clip, o.output, app::fingerprintText(curves));
        if (keys) report["keys"] = app::keysReport(outcome, *keys);
        if (outcome.clip.scene) report["scene_curves"] = app::sceneCurvesJson(sceneCurves);
        files.set(o.reportJson, app::jsonText(report, 2) + "\n");
    }
    files.set(o.output, std::move(curves));
    if (!o.html.empty()) files.set(o.html, app::htmlReport(outcome, keys, {o.clip, o.rig, o.approximation}, threeJs));
}

int run(const Options& o)
{
    // Everything that can be checked before the work is.
    app::checkOutputFile(o.output, "curves.json");
    const auto extension = std::filesystem::path(o.output).extension();
    if (extension != ".json" && extension != ".csv" && extension != ".anim" && extension != ".ma")
        throw Error(fmt::format("-o {}: the curves are written as .json, .csv, .anim or .ma (Maya); give one of those",
                                o.output));
    if (extension == ".ma") app::checkMayaSceneOutput(o.rig, o.output);
    app::OutputFiles files;
    files.add(o.output, "curves.json");
    if (!o.reportJson.empty()) files.add(o.reportJson, "report.json", "--report-json");
    if (!o.html.empty()) files.add(o.html, "report.html", "--html");
    const TangentType tangent = app::keyTangent(o.keys.tangent);
    if (o.keysGiven) app::checkKeySettings(o.keys);
    const std::string threeJs = o.html.empty() ? std::string() : app::readThreeJs();
    const std::vector<app::NamedFile> outputs{{"-o", o.output}, {"--report-json", o.reportJson}, {"--html", o.html}};
    app::checkDistinctFiles({{"the approximation", o.approximation},
                             {"the rig file", o.rig},
                             {"the clip", o.clip},
                             {"the map", o.map},
                             {"--after", o.after},
                             {"--contacts", o.contacts == "auto" ? std::string() : o.contacts}},
                            outputs);
    app::InvertJob job;
    static_cast<app::InversionInputs&>(job) = o;
    job.clip = o.clip;
    if (o.framesGiven) job.frames = o.frames;
    job.after = o.after;
    job.warning = [](const std::string& warning) { std::cerr << "warning: " << warning << "\n"; };
    job.rigLoaded = [&](const GraphRigFunction& rig) {
        std::vector<app::NamedFile> read;
        for (const auto& file : rig.files()) read.push_back({"a file the rig reads", file});
        app::checkDistinctFiles(read, outputs);
    };
    app::ProgressBar bar("inverting");
    job.progress = [&](int done, int total) { bar.update(static_cast<double>(done) / total); };
    const app::InvertOutcome outcome = app::invert(job);
    bar.finish();
    std::optional<app::KeysOutcome> keys;
    if (o.keysGiven) {
        app::ProgressBar keying("keying");
        keys = app::keyCurves(outcome, o.keys, [&](double fraction) { keying.update(fraction); });
    }
    const app::KeysOutcome* keyed = keys ? &*keys : nullptr;

    const auto sceneCurves = app::sceneCurveDifferences(outcome);
    setOutputs(files, o, outcome, keyed, tangent, threeJs, sceneCurves);
    files.commit();
    const ClipInversionSummary& summary = outcome.summary;
    if (!o.quiet) printReport(o, outcome, keyed, sceneCurves);
    // Measured as wrong: never an exit code of success.
    if (summary.failedFrames() > 0) {
        std::cerr << "error: "
                  << oneLine(app::failedFramesLine(
                         summary, outcome.clip.frameNumbers[static_cast<std::size_t>(summary.firstFailedFrame)],
                         {o.rig, o.clip, o.map, o.take, o.framesGiven ? o.frames : ""}))
                  << '\n';
        return 3;
    }
    if (keys && (keys->keyed.error.maxPositionCm > o.keys.toleranceCm ||
                 keys->keyed.error.maxRotationDeg > o.keys.toleranceDeg)) {
        const KeyedError& e = keys->keyed.error;
        const auto& joint = outcome.approximation->outputs[static_cast<std::size_t>(e.worstOutputOverall)].name;
        const double frame = outcome.clip.frameNumbers[static_cast<std::size_t>(outcome.first + e.worstFrame)];
        std::cerr << oneLine(fmt::format("error: the keyed curves leave the real rig {:.4g} cm and {:.4g} deg from the "
                                         "dense curves ({} at frame {}), over the tolerance of {} cm and {} deg",
                                         e.maxPositionCm, e.maxRotationDeg, joint, frame, o.keys.toleranceCm,
                                         o.keys.toleranceDeg))
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
    CLI::App app(
        "Inverts a clip of target joints to rig parameter curves with a learned approximation "
        "(docs/rig-invert.md).",
        "rig-invert");
    app.add_option("approximation", options.approximation, "Approximation file written by rig-learn")->required();
    app.add_option("--rig", options.rig, "The rig file the approximation was learned from")->required();
    app.add_option("--clip", options.clip,
                   "Targets: a BVH file, an animation assimp reads (FBX, glTF, Collada, X, ...: docs/clips.md), a "
                   "Maya ASCII scene (its joints over its playback range), or a .json file of world matrices "
                   "(graph-eval); read by content")
        ->required();
    app.add_option("--take", options.take,
                   "The clip file's animation to invert: a name or 0-based index (default: the first)")
        ->check(rig::cli::nonEmpty("a take's name or 0-based index, or leave --take out for the first"));
    app.add_option("--map", options.map, "Map file: scale of the clip and target-to-rig joint names");
    app.add_option("--frames", options.frames, "Frames A:B of the clip, inclusive, in the clip's numbering");
    app.add_option("-o,--output", options.output,
                   "Curves to write: .json, .csv, .anim (Maya's animImportExport), angles in degrees, or .ma (a Maya "
                   "scene that references the rig's scene and drives its controls)")
        ->required();
    app.add_option("--report-json", options.reportJson, "Write the report as JSON to this file");
    const rig::cli::SolveFlags solveFlags(app, rig::app::SolveSettings{});
    app.add_option("--contacts", options.contacts,
                   "Hold planted joints (feet) with a priority above the other targets: auto (detected from the "
                   "clip) or a file of frame ranges per joint (docs/retargeting.md)")
        ->check(rig::cli::nonEmpty("auto or a contacts file, or leave --contacts out"));
    app.add_option("--after", options.after,
                   "JSON curves rig-invert wrote for the frames before these: this run continues them (the curves "
                   "of chunks then equal one run's)");
    app.add_flag("--strict", options.strict, "Refuse an approximation learned from another version of the rig");
    app.add_option("--plugin", options.plugins, "Load a plugin before reading the rig");
    app.add_option("--key-tolerance", options.keys.toleranceCm,
                   "Write keys instead of a value per frame, the real rig's joints within this many cm of the dense "
                   "curves' (default 0.1 with --key-tolerance-deg)");
    app.add_option("--key-tolerance-deg", options.keys.toleranceDeg,
                   "The same for the joints' rotations, in degrees (default 0.5 with --key-tolerance)");
    app.add_option("--key-tangent", options.keys.tangent,
                   "Tangent type of the keys: auto (default), spline, clamped, plateau, linear, flat, step, stepnext");
    app.add_option("--html", options.html,
                   "Write a self-contained page that plays the clip with the rig overlaid, its errors and curves");
    app.add_flag("-q,--quiet", options.quiet, "Print nothing but errors and warnings");
    return rig::cli::runMain(app, argc, argv, [&] {
        options.framesGiven = app.count("--frames") > 0;
        options.keysGiven = app.count("--key-tolerance") + app.count("--key-tolerance-deg") > 0;
        options.settings = solveFlags.settings();
        return rig::run(options);
    });
}

// rig-invert: inverts a clip of target joints to rig parameter curves with a learned approximation,
// and measures the result on the real rig (docs/rig-invert.md).
#include <algorithm>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "core/error.h"
#include "tools/cli_common.h"
#include "tools/invert_run.h"
#include "tools/progress_bar.h"

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
    cli::InvertJob job;
    job.approximationName = o.approximation;
    job.rig = o.rig;
    job.plugins = o.plugins;
    job.strict = o.strict;
    job.clip = o.clip;
    job.map = o.map;
    if (o.framesGiven) job.frames = o.frames;
    job.after = o.after;
    job.settings = {o.threads, o.noPartition, o.blockByBlock, o.jacobian, o.polish, o.restartEvery, o.restStarts};
    job.warning = [](const std::string& warning) { std::cerr << "warning: " << warning << "\n"; };
    job.rigLoaded = [&](const GraphRigFunction& rig) {
        std::vector<cli::NamedFile> read;
        for (const auto& file : rig.files()) read.push_back({"a file the rig reads", file});
        cli::checkDistinctFiles(read, {{"-o", o.output}, {"--report-json", o.reportJson}});
    };
    cli::ProgressBar bar("inverting");
    job.progress = [&](int done, int total) { bar.update(static_cast<double>(done) / total); };
    const cli::InvertOutcome outcome = cli::invert(job);
    bar.finish();

    const std::string curves = extension == ".csv" ? cli::curvesCsv(outcome) : cli::curvesJson(outcome);
    cli::writeFileAtomically(o.output, curves);
    if (!o.reportJson.empty())
        cli::writeFileAtomically(o.reportJson, cli::jsonText(cli::invertReport(outcome, o.approximation, o.rig, o.clip,
                                                                               o.output, cli::fingerprintText(curves)),
                                                             2) +
                                                   "\n");
    const ClipInversionSummary& summary = outcome.summary;
    if (!o.quiet) printReport(o, *outcome.approximation, outcome.clip, outcome.targets, summary);
    // Measured as wrong: never an exit code of success.
    if (summary.nonFiniteFrames > 0) {
        std::cerr << oneLine(fmt::format("error: the real rig gives a non-finite matrix at {} of {} frames (first: {} at "
                                         "frame {}); the rig cannot follow these curves there",
                                         summary.nonFiniteFrames, summary.frames, summary.firstNonFiniteJoint,
                                         outcome.clip.frameNumbers[summary.firstNonFiniteFrame]))
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

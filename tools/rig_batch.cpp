// rig-batch: inverts a motion library as shards on this machine or on a Slurm cluster, then merges them into
// one curves file per clip (rig-invert's, byte for byte) and a library report (docs/cluster.md).
#include <filesystem>
#include <iostream>
#include <limits>

#include <fmt/format.h>

#include "app/batch/batch_backend.h"
#include "app/batch/batch_run.h"
#include "app/common/progress_bar.h"
#include "core/error.h"
#include "tools/cli_common.h"
#include "tools/solve_flags.h"

namespace rig {
namespace {

struct Options {
    app::BatchJob job;
    int task = 0;
    bool taskGiven = false;
    bool jobsGiven = false;  // --jobs 0 is an error, not the default
    bool quiet = false;
};

void printSummary(const app::BatchJob& job, const app::Json& report)
{
    const app::Json& totals = report["totals"];
    std::cout << fmt::format("rig-batch: {} clips, {} shards ({} done before, {} run on {}, {} failed)\n\n",
                             totals["clips"].get<int>(), totals["shards"].get<int>(),
                             totals["shards_reused"].get<int>(), totals["shards_run"].get<int>(), job.backend,
                             totals["shards_failed"].get<int>());
    std::cout << fmt::format("{:<16} {:>7} {:>7} {:>8} {:>6} {:>10} {:>10} {:>9}  {}\n", "clip", "frames", "reached",
                             "best fit", "failed", "worst cm", "worst deg", "ms/frame", "curves");
    // A non-finite figure is null in JSON: shown as nan, never as a number.
    const auto number = [](const app::Json& x) {
        return x.is_number() ? x.get<double>() : std::numeric_limits<double>::quiet_NaN();
    };
    for (const app::Json& c : report["clips"]) {
        if (!c["complete"].get<bool>()) {
            std::cout << fmt::format("{:<16} {:>7}  no curves: a shard failed\n", c["name"].get<std::string>(),
                                     c["frames"].get<int>());
            continue;
        }
        std::cout << fmt::format(
            "{:<16} {:>7} {:>7} {:>8} {:>6} {:>10.4g} {:>10.4g} {:>9.4g}  {}\n", c["name"].get<std::string>(),
            c["frames"].get<int>(), c["status_frames"]["reached"].get<int>(), c["status_frames"]["best_fit"].get<int>(),
            c["failed_frames"].get<int>(), number(c["max_position_error_cm"]), number(c["max_rotation_error_deg"]),
            number(c["ms_per_frame"]), c["curves"]["file"].get<std::string>());
    }
    // A large worst error beside 0 failed frames reads as a contradiction unless the table says what each counts.
    std::cout << "worst cm, worst deg: the real rig's largest errors over a clip's frames, best fits (least-squares "
                 "answers) included;\nfailed: frames of any other status (docs/rig-invert.md); the joints: "
                 "residual_joints in report.json\n";
    if (!report["unmodelled_outputs"].empty())
        std::cout << fmt::format("\nnot modelled      {} (non-compositional: {})\n",
                                 fmt::join(report["unmodelled_outputs"].get<std::vector<std::string>>(), ", "),
                                 report["hybrid"].get<bool>()
                                     ? "fitted on the real rig by --hybrid"
                                     : "their targets were not fitted, so frames that miss them are model "
                                       "mismatches; --hybrid fits them on the real rig");
    const app::Json& fps = totals["frames_per_second"];
    std::cout << fmt::format("\ntime              {:.3g} s running {} shards{}, {:.3g} s merging\n",
                             totals["run_seconds"].get<double>(), totals["shards_run"].get<int>(),
                             fps.is_null() ? "" : fmt::format(" ({:.4g} frames per second)", fps.get<double>()),
                             totals["merge_seconds"].get<double>());
    std::cout << fmt::format("report            {}\n", (std::filesystem::absolute(job.out) / "report.json").string());
}

int run(Options& o)
{
    if (o.taskGiven) {
        if (!o.job.approximation.empty() || !o.job.rig.empty() || !o.job.clips.empty())
            throw Error(
                fmt::format("--task {}: runs one shard of the batch in --out with the inputs its manifest "
                            "names; give only --out with it",
                            o.task));
        if (o.job.out.empty()) throw Error(fmt::format("--task {}: give the batch's folder with --out", o.task));
        app::dieWithDriver();
        app::runShard(o.job.out, o.task);
        return 0;
    }
    if (o.jobsGiven && o.job.jobs < 1)
        throw Error(
            fmt::format("--jobs {}: give 1 or more processes (local) or tasks running at once (slurm)", o.job.jobs));
    if (o.job.approximation.empty())
        throw Error("no approximation given; give the approximation file rig-learn wrote as the first argument");
    if (o.job.rig.empty()) throw Error("--rig: give the rig file the approximation was learned from");
    if (o.job.clips.empty())
        throw Error("--clips: give clip files (BVH, FBX, glTF, Collada, ..., .json) or folders of them");
    if (o.job.out.empty()) throw Error("--out: give the folder for the curves and the report");
    std::error_code ec;
    o.job.program = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec) throw Error(fmt::format("cannot find rig-batch's own program to start per shard ({})", ec.message()));
    app::stopTasksOnSignals();
    o.job.warning = [](const std::string& warning) { std::cerr << "warning: " << warning << "\n"; };
    app::ProgressBar bar("inverting");
    o.job.progress = [&](int done, int total) {
        bar.update(total > 0 ? static_cast<double>(done) / total : 1.0, fmt::format("{}/{} shards", done, total));
    };
    const app::BatchOutcome outcome = app::runBatch(o.job);
    bar.finish();
    if (!o.quiet) printSummary(o.job, outcome.report);
    // Measured failures: never an exit code of success.
    if (!outcome.failures.empty()) {
        std::cerr << oneLine(fmt::format("error: {} of {} shards failed ({}{}); their clips have no curves; run "
                                         "rig-batch again to retry them (finished shards are kept)",
                                         outcome.failures.size(), outcome.report["totals"]["shards"].get<int>(),
                                         outcome.failures.front(),
                                         outcome.failures.size() > 1 ? "; see report.json for the others" : ""))
                  << '\n';
        return 3;
    }
    if (outcome.failedClips > 0) {
        std::cerr << oneLine(fmt::format("error: {} clips have frames that are not an answer on the real rig "
                                         "(failed_frames in report.json); the first: {}",
                                         outcome.failedClips, outcome.firstFailedFrames))
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
    rig::app::BatchJob& job = options.job;
    CLI::App app(
        "Inverts a motion library as shards on this machine or a Slurm cluster and merges them into "
        "rig-invert's curves, one file per clip (docs/cluster.md).",
        "rig-batch");
    app.add_option("approximation", job.approximation, "Approximation file written by rig-learn");
    app.add_option("--rig", job.rig, "The rig file the approximation was learned from");
    app.add_option("--map", job.map, "Map file: scale of the clips and target-to-rig joint names");
    app.add_option("--clips", job.clips,
                   "Clips (BVH, FBX, glTF, Collada, X, ... or .json; docs/clips.md) and folders of them")
        ->expected(1, -1);
    app.add_option("--take", job.take,
                   "Each clip file's animation to invert: a name or 0-based index (default: the first)")
        ->check(rig::cli::nonEmpty("a take's name or 0-based index, or leave --take out for the first"));
    app.add_option("--contacts", job.contacts,
                   "Hold planted joints (feet) above the other targets: auto (detected per clip) or a file of frame "
                   "ranges per joint, for every clip (docs/retargeting.md)")
        ->check(rig::cli::nonEmpty("auto or a contacts file, or leave --contacts out"));
    app.add_option("--out", job.out, "Folder for the curves (NAME.json per clip), report.json and the batch's files");
    app.add_option("--backend", job.backend, "local (processes on this machine, default) or slurm (sbatch arrays)");
    app.add_option("--jobs", job.jobs,
                   "Shards at once: processes (local; default: the cores) or array tasks running (slurm; default: "
                   "all)");
    app.add_option("--shard-frames", job.shardFrames,
                   "Frames per shard, rounded up to whole --restart-every intervals (default 4800)");
    app.add_option("--retries", job.retries, "New attempts of failed shards (default 1)");
    const rig::cli::SolveFlags solveFlags(app, rig::app::concurrentSolveDefaults(),
                                          "Solver threads per shard (0: all cores); results do not depend on it");
    app.add_flag("--strict", job.strict, "Refuse an approximation learned from another version of the rig");
    app.add_option("--plugin", job.plugins, "Load a plugin before reading the rig");
    app.add_option("--slurm-mem", job.slurmMemory, "Memory per Slurm task (sbatch --mem, e.g. 2G)");
    app.add_option("--slurm-time", job.slurmTime, "Time limit per Slurm task (sbatch --time, e.g. 30 or 1:00:00)");
    app.add_option("--slurm-arg", job.slurmArgs,
                   "More sbatch options, one per flag (e.g. --slurm-arg=--partition=cpu)");
    app.add_option("--task", options.task, "Run shard K of --out's manifest (what each backend task runs)");
    app.add_flag("-q,--quiet", options.quiet, "Print nothing but errors and warnings");
    return rig::cli::runMain(app, argc, argv, [&] {
        options.taskGiven = app.count("--task") > 0;
        options.jobsGiven = app.count("--jobs") > 0;
        job.settings = solveFlags.settings();
        // What the file system refuses (a link loop, a folder this user may not read) is the user's to fix.
        try {
            return rig::run(options);
        }
        catch (const std::filesystem::filesystem_error& e) {
            throw rig::Error(fmt::format("{}: {}; check the path and its permissions",
                                         e.path1().empty() ? "a file of the batch" : e.path1().string(),
                                         e.code().message()));
        }
    });
}

// rig-bench: the talk's figures side by side in one run (Jacobian, inversion per frame, a peer solver,
// training, accuracy) and how they grow with rig size, written as JSON (docs/performance.md).
#include <pthread.h>
#include <unistd.h>

#include <csignal>
#include <thread>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>

#include <fmt/format.h>

#include "app/common/output_file.h"
#include "bench/bench_common.h"
#include "bench/bench_suite.h"
#include "core/error.h"
#include "tools/cli_common.h"

namespace rig {
namespace {

struct Options {
    bool quick = false;
    std::string json;
    bool jsonGiven = false;  // --json "" is an error, not no report
    std::string rig, spec, clip, map, makeRigs, python;
    std::optional<int> frames;
    std::vector<int> crowd, chain;
    std::optional<int> realtimeMax, realtimeFrames;
    bool noScaling = false;
    bool noCrowd = false;
    bool noChain = false;
    bool noMayaScenes = false;
    bool noCharacters = false;
    bool quiet = false;
};

// A figure of the report with its unit, "-" when it is missing (null).
std::string figure(const bench::Json& j, std::string_view unit = "", int digits = 3)
{
    if (!j.is_number()) return "-";
    return fmt::format("{:.{}g}{}{}", j.get<double>(), digits, unit.empty() ? "" : " ", unit);
}

std::string text(const bench::Json& j) { return j.is_string() ? j.get<std::string>() : j.dump(); }

// `clause` with the ratio `key` of `row` in it, or nothing where the row has no such figure (--quick's crowds).
std::string ratioClause(std::string_view clause, const bench::Json& row, const char* key)
{
    const auto j = row.find(key);
    return j != row.end() && j->is_number() ? fmt::format(fmt::runtime(clause), figure(*j)) : std::string();
}

void printSummary(const bench::Json& r)
{
    const auto& jac = r.at("jacobian");
    const auto& inv = r.at("invert");
    const auto& cer = r.at("ceres");
    const auto& train = r.at("train");
    const auto& machine = r.at("machine");
    std::cout << fmt::format("machine     {} cores, {}, {} build\n", figure(machine.at("cores")),
                             text(machine.at("compiler")), text(machine.at("build_type")));
    std::cout << fmt::format("jacobian    real graph (fd) {}, approximation fd {}, analytic {} ({}x the real graph)\n",
                             figure(jac.at("blackbox_fd_ms"), "ms"), figure(jac.at("approx_fd_ms"), "ms"),
                             figure(jac.at("approx_analytic_ms"), "ms"), figure(jac.at("speedup_analytic"), "", 4));
    std::cout << fmt::format("inversion   {} per frame (1 thread), {} (2 threads); Gauss-Newton on the real graph {}\n",
                             figure(inv.at("ms_per_frame"), "ms"), figure(inv.at("threads2_ms_per_frame"), "ms"),
                             figure(inv.at("blackbox_ms_per_frame"), "ms"));
    if (cer.at("ms_per_frame").is_null()) std::cout << fmt::format("ceres       - ({})\n", text(cer.at("note")));
    else
        std::cout << fmt::format("ceres       {} per frame ({}), ours {} on the same frames\n",
                                 figure(cer.at("ms_per_frame"), "ms"), text(cer.at("linear_solver")),
                                 figure(cer.at("ours_ms_per_frame"), "ms"));
    if (const auto ik = r.find("ik_legs"); ik != r.end() && !ik->is_null())
        std::cout << fmt::format(
            "ik legs     {} per frame (hybrid, 1 thread), {} real-rig evaluations per frame, worst {}; leg joints "
            "{} from FK's at worst\n",
            figure(ik->at("cpu_ms_per_frame"), "ms"), figure(ik->at("real_rig_evaluations_per_frame"), "", 4),
            figure(ik->at("real_rig").at("max_position_error_cm"), "cm"),
            figure(ik->at("leg_joints_vs_fk_max_cm"), "cm"));
    if (const auto ik = r.find("ik_legs_constraints"); ik != r.end() && !ik->is_null())
        std::cout << fmt::format(
            "ik chains   {} per frame (planar chains, 1 thread), {} unmodelled outputs, {} training evaluations, "
            "worst {}; leg joints {} from FK's at worst\n",
            figure(ik->at("cpu_ms_per_frame"), "ms"), figure(ik->at("unmodelled_outputs"), "", 4),
            figure(ik->at("training_evaluations"), "", 6), figure(ik->at("real_rig").at("max_position_error_cm"), "cm"),
            figure(ik->at("leg_joints_vs_fk_max_cm"), "cm"));
    if (const auto every = r.find("every_joint"); every != r.end() && !every->is_null())
        std::cout << fmt::format(
            "every joint {} outputs, {} unmodelled, {} twist shares, {} training evaluations, "
            "validation {} per unit moved\n",
            figure(every->at("outputs"), "", 4), figure(every->at("unmodelled_outputs"), "", 4),
            figure(every->at("twist_shares"), "", 4), figure(every->at("training_evaluations"), "", 6),
            figure(every->at("validation_max_relative_error"), "cm"));
    std::cout << fmt::format("training    {} evaluations, {}\n", figure(train.at("evaluations"), "", 6),
                             figure(train.at("seconds"), "s"));
    const auto threadsLine = [](const std::string& what, const bench::Json& t) {
        std::cout << fmt::format(
            "training    {}: {} on 1 rig instance, {} on 2 ({})\n", what, figure(t.at("seconds_1_threads"), "s"),
            figure(t.at("seconds_2_threads"), "s"),
            t.at("same_approximation").get<bool>() ? "the same approximation" : "DIFFERENT approximations");
    };
    threadsLine("biped", train.at("threads"));
    for (const auto& row : r.at("scaling"))
        if (!row.at("train_threads").is_null())
            threadsLine(fmt::format("{} {}", text(row.at("rig")), figure(row.at("count"), "", 6)),
                        row.at("train_threads"));
    if (const auto crowd = r.find("crowd_realtime"); crowd != r.end() && !crowd->is_null())
        for (const auto& t : crowd->at("by_threads"))
            std::cout << fmt::format(
                "crowd       {} look-at bipeds at 30 fps on {} thread(s): frame median {}, p99 {}; real heads' aim "
                "within {}{}\n",
                figure(t.at("agents_at_30fps"), "", 4), figure(t.at("threads")), figure(t.at("frame_ms_median"), "ms"),
                figure(t.at("frame_ms_p99"), "ms"), figure(t.at("lookat_max_error_deg"), "deg"),
                ratioClause("; CPU per biped up to {}x that of 16", t, "per_agent_growth"));
    if (const auto maya = r.find("maya_load"); maya != r.end() && !maya->is_null())
        std::cout << fmt::format("maya load   the largest scene ({} bytes) in {}; {} scenes\n",
                                 figure(maya->at("largest_bytes"), "", 9),
                                 figure(maya->at("largest_load_seconds"), "s"), maya->at("scenes").size());
    if (const auto scenes = r.find("maya_scenes"); scenes != r.end() && !scenes->is_null())
        for (const auto& s : scenes->at("scenes"))
            std::cout << (s.contains("error")
                              ? fmt::format("maya scene  {}: {}\n", text(s.at("clip")), text(s.at("error")))
                              : fmt::format("maya scene  {}: {} joints, {} parameters ({} unmodelled outputs{}), {} "
                                            "evaluations; {} of {} frames reached, {} per frame{}; OUT.ma replay {}\n",
                                            text(s.at("clip")), figure(s.at("joints")),
                                            figure(s.at("parameters_modelled")), figure(s.at("unmodelled_outputs")),
                                            s.value("within_epsilon", true) ? "" : ", over epsilon",
                                            figure(s.at("training_evaluations"), "", 6), figure(s.at("reached")),
                                            figure(s.at("frames")), figure(s.at("ms_per_frame"), "ms"),
                                            ratioClause(" ({}x the FK biped's CPU time per joint)", s,
                                                        "times_fk_biped_per_joint"),
                                            figure(s.at("replay_worst_reached_cm"), "cm")));
    if (const auto characters = r.find("random_characters"); characters != r.end() && !characters->is_null()) {
        const auto line = [](const std::string& name, const bench::Json& row) {
            const auto& fk = row.at("fk_on_ik_clip");
            const auto& ik = row.at("ik");
            std::cout << fmt::format(
                "characters  {}: {} unmodelled outputs FK, {} IK; IK's clip reached {} of {} frames FK, {} IK; {} "
                "per frame FK, {} IK ({}x; FK on its own clip {})\n",
                name, figure(row.at("fk").at("unmodelled_outputs")), figure(ik.at("unmodelled_outputs")),
                figure(fk.at("reached"), "", 6), figure(fk.at("frames"), "", 6), figure(ik.at("reached"), "", 6),
                figure(fk.at("cpu_ms_per_frame"), "ms"), figure(ik.at("cpu_ms_per_frame"), "ms"),
                figure(row.at("ratio")), figure(row.at("fk").at("cpu_ms_per_frame"), "ms"));
        };
        for (const auto& row : characters->at("constructions")) line(text(row.at("construction")), row);
        line("issue #46's constructions", *characters);
    }
    for (const auto& row : r.at("scaling"))
        std::cout << fmt::format("scaling     {} {}: {} parameters, {} per frame, jacobian {}, {} evaluations\n",
                                 text(row.at("rig")), figure(row.at("count"), "", 6),
                                 figure(row.at("parameters"), "", 6), figure(row.at("ms_per_frame"), "ms"),
                                 figure(row.at("jacobian_ms"), "ms"), figure(row.at("train_evaluations"), "", 7));
}

constexpr int maxCrowd = 512;
constexpr int maxChain = 2000;

// A fresh folder (mkdtemp's `pattern`), removed when the run is interrupted (SIGINT, SIGTERM): the signals
// are blocked in every thread and taken by a thread of their own with sigwait, so the removal runs as ordinary
// code, not in a signal handler. They are blocked before the folder exists: a signal in between stays pending
// for the watcher, instead of killing the process with the folder left behind. Destroyed at the end of a
// normal run, which removes the folder too.
class TemporaryFolder {
public:
    explicit TemporaryFolder(std::string pattern)
    {
        sigset_t signals, previous;
        sigemptyset(&signals);
        for (const int s : {SIGINT, SIGTERM, SIGUSR1}) sigaddset(&signals, s);
        pthread_sigmask(SIG_BLOCK, &signals, &previous);  // before any worker thread starts: they inherit it
        if (!mkdtemp(pattern.data())) {
            pthread_sigmask(SIG_SETMASK, &previous, nullptr);
            throw Error(fmt::format("cannot make a temporary folder {}", pattern));
        }
        dir_ = pattern;
        watcher_ = std::thread([this, signals] {
            int received = 0;
            sigwait(&signals, &received);
            if (received == SIGUSR1) return;  // the run ended: the destructor cleans up
            std::error_code ignored;
            std::filesystem::remove_all(dir_, ignored);
            std::_Exit(128 + received);
        });
    }
    ~TemporaryFolder()
    {
        pthread_kill(watcher_.native_handle(), SIGUSR1);
        watcher_.join();
        std::error_code ignored;
        std::filesystem::remove_all(dir_, ignored);
    }
    TemporaryFolder(const TemporaryFolder&) = delete;
    TemporaryFolder& operator=(const TemporaryFolder&) = delete;
    const std::filesystem::path& path() const { return dir_; }

private:
    std::filesystem::path dir_;
    std::thread watcher_;
};

// The measurement's options: --quick's or the full run's, with the flags' files and sizes, checked before any
// work.
bench::BenchOptions benchOptions(const Options& o)
{
    bench::BenchOptions options = o.quick ? bench::quickOptions() : bench::fullOptions();
    if (!o.rig.empty()) options.rig = o.rig;
    if (!o.spec.empty()) options.spec = o.spec;
    if (!o.clip.empty()) options.clip = o.clip;
    if (!o.map.empty()) options.map = o.map;
    if (!o.makeRigs.empty()) options.makeRigs = o.makeRigs;
    if (!o.python.empty()) options.python = o.python;
    if (o.frames) {
        if (*o.frames < 1) throw Error(fmt::format("--frames {}: give at least 1 frame", *o.frames));
        options.frames = *o.frames;
        options.ceresFrames = std::min(options.ceresFrames, *o.frames);
    }
    if (o.realtimeMax) {
        if (*o.realtimeMax < 0 || *o.realtimeMax > maxCrowd)
            throw Error(fmt::format("--realtime-max {}: give 0 (no crowd_realtime row) to {} bipeds", *o.realtimeMax,
                                    maxCrowd));
        options.realtimeMaxAgents = *o.realtimeMax;
    }
    if (o.realtimeFrames) {
        if (*o.realtimeFrames < 1)
            throw Error(fmt::format("--realtime-frames {}: give at least 1 frame", *o.realtimeFrames));
        options.realtimeFrames = *o.realtimeFrames;
    }
    if (!o.crowd.empty()) options.crowdSizes = o.crowd;
    if (!o.chain.empty()) options.chainSizes = o.chain;
    if (o.noCrowd) options.crowdSizes.clear();
    if (o.noChain) options.chainSizes.clear();
    if (o.noMayaScenes) options.mayaScenes = false;
    if (o.noCharacters) options.characters.perConstruction = options.characters.randomCharacters = 0;
    // Bounded before any work: 512 bipeds of about 290 nodes each stay within GraphModel::maxNodes (200 000);
    // a chain of 2000 joints has 6000 parameters, each moving every joint below it (n^2 / 2 Jacobian entries).
    for (const int n : options.crowdSizes)
        if (n < 1 || n > maxCrowd) throw Error(fmt::format("--crowd {}: a crowd has 1 to {} bipeds", n, maxCrowd));
    for (const int n : options.chainSizes)
        if (n < 1 || n > maxChain) throw Error(fmt::format("--chain {}: a chain has 1 to {} joints", n, maxChain));
    for (const auto& [file, flag] : {std::pair{options.rig, "--rig"},
                                     {options.spec, "--spec"},
                                     {options.clip, "--clip"},
                                     {options.map, "--map"},
                                     {options.makeRigs, "--make-rigs"},
                                     {options.longLegsRig, "the contacts row's rig"},
                                     {options.longLegsMap, "the contacts row's map"}})
        if (!std::filesystem::exists(file))
            throw Error(fmt::format("{} {}: no such file{}; check the path", flag, file.string(),
                                    std::string_view(flag) == "--clip" ? " (Debian package assimp-testmodels)" : ""));
    if (!o.quiet) options.log = [](std::string_view line) { std::cerr << "rig-bench: " << line << "\n"; };
    return options;
}

// Every figure: the biped's, then the scaling rows' (generated rigs in options.workDir).
bench::Json measure(const Options& o, const bench::BenchOptions& options)
{
    const auto start = std::chrono::steady_clock::now();
    bench::Json report = bench::Json::object();
    report["machine"] = bench::machineDescription();
    report["mode"] = o.quick ? "quick" : "full";
    bench::runBipedBench(options, report);
    if (o.noScaling) {
        report["scaling"] = bench::Json::array();
        report["growth"] = bench::Json();
    } else {
        bench::runScaling(options, report);
    }
    bench::Json load = bench::Json::array();
    for (const double l : bench::loadAverage()) load.push_back(l);
    report["load_average_at_end"] = std::move(load);
    report["seconds"] = bench::secondsSince(start);
    return report;
}

// rig-learn --threads promises the same approximation for any count: a difference is a measured failure
// (exit code 3).
int checkSameApproximations(const bench::Json& report)
{
    std::vector<std::string> differing;
    if (!report.at("train").at("threads").at("same_approximation").get<bool>()) differing.push_back("the biped");
    for (const auto& row : report.at("scaling"))
        if (!row.at("train_threads").is_null() && !row.at("train_threads").at("same_approximation").get<bool>())
            differing.push_back(fmt::format("{} {}", row.at("rig").get<std::string>(), row.at("count").get<int>()));
    if (differing.empty()) return 0;
    std::string list;
    for (const auto& name : differing) list += (list.empty() ? "" : ", ") + name;
    std::cerr << fmt::format("error: training on 1 and 2 rig instances gave different approximations for {}\n", list);
    return 3;
}

int run(const Options& o)
{
    if (o.jsonGiven) {
        app::checkOutputFile(o.json, "bench.json", "--json");
        app::checkDistinctFiles({{"the rig file", o.rig},
                                 {"the spec", o.spec},
                                 {"the clip", o.clip},
                                 {"the map", o.map},
                                 {"the rig generator", o.makeRigs}},
                                {{"--json", o.json}});
    }
    bench::BenchOptions options = benchOptions(o);

    // Generated rigs go to a fresh folder, removed at the end.
    const TemporaryFolder folder((std::filesystem::temp_directory_path() / "rig-bench.XXXXXX").string());
    options.workDir = folder.path();

    const bench::Json report = measure(o, options);
    if (o.jsonGiven) app::writeFileAtomically(o.json, report.dump(2) + "\n");
    if (!o.quiet) printSummary(report);
    return checkSameApproximations(report);
}

}  // namespace
}  // namespace rig

int main(int argc, char** argv)
{
    rig::Options options;
    CLI::App app(
        "Measures the talk's figures side by side in one run: Jacobians (black box against the "
        "approximation), inversion per frame (ours, Ceres, Gauss-Newton on the real rig), training, real-rig "
        "accuracy, and their growth on generated rigs (docs/performance.md). Run it from the source folder.",
        "rig-bench");
    app.add_flag("--quick", options.quick, "A smoke run: under a minute, fewer frames and small generated rigs");
    app.add_option("--json", options.json, "Write every figure as JSON to this file");
    app.add_option("--rig", options.rig, "The biped rig (default rigs/biped.yaml)");
    app.add_option("--spec", options.spec,
                   "Its inversion parameters and outputs, and the plugs held while learning (default "
                   "rigs/biped_inversion.yaml)");
    app.add_option("--clip", options.clip, "Target clip (default /usr/share/assimp/models/BVH/01_01.bvh)");
    app.add_option("--map", options.map, "Map file of the clip (default rigs/maps/cmu_to_biped.yaml)");
    app.add_option("--make-rigs", options.makeRigs, "The rig generator (default scripts/make_rigs.py)");
    app.add_option("--python", options.python, "Python interpreter for the generator (default python3)");
    app.add_option("--frames", options.frames, "Clip frames to invert with our solver (default: all; --quick 240)");
    app.add_option("--crowd", options.crowd, "Crowd sizes (bipeds) for the scaling rows")->delimiter(',');
    app.add_option("--chain", options.chain, "Chain lengths (joints) for the scaling rows")->delimiter(',');
    app.add_flag("--no-crowd", options.noCrowd, "No crowd rows");
    app.add_option("--realtime-max", options.realtimeMax,
                   "Largest look-at crowd of the crowd_realtime row (default 512; --quick 2; 0: no such row)");
    app.add_option("--realtime-frames", options.realtimeFrames,
                   "Frames timed per crowd of the crowd_realtime row (default 60; --quick 5)");
    app.add_flag("--no-chain", options.noChain, "No chain rows");
    app.add_flag("--no-maya-scenes", options.noMayaScenes,
                 "No maya_scenes row (the animated scenes of ../shared/maya learned and inverted; not with --quick)");
    app.add_flag("--no-characters", options.noCharacters,
                 "No random_characters row (random characters of issue #46 learned and inverted in FK and IK mode; "
                 "not with --quick)");
    app.add_flag("--no-scaling", options.noScaling, "Measure the biped only");
    app.add_flag("-q,--quiet", options.quiet, "Print nothing but errors");
    return rig::cli::runMain(app, argc, argv, [&] {
        options.jsonGiven = app.count("--json") > 0;
        return rig::run(options);
    });
}

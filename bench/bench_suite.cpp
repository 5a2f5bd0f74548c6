#include "bench/bench_suite.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <random>
#include <thread>

#include <fmt/format.h>
#include <oneapi/tbb/task_arena.h>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "app/common/output_file.h"
#include "app/invert/invert_run.h"
#include "bench/bench_characters.h"
#include "bench/bench_cold_start.h"
#include "bench/bench_contacts.h"
#include "bench/bench_crowd.h"
#include "bench/bench_maya.h"
#include "core/error.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/clip/real_rig_solve.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/solve/solver.h"
#include "nodes/clips/target_clip.h"
#ifdef RIG_BENCH_HAVE_CERES
#include "bench/bench_ceres.h"
#endif

namespace rig::bench {

BenchOptions quickOptions()
{
    BenchOptions o;
    o.frames = 240;
    o.ceresFrames = 120;
    o.blackBoxFrames = 10;
    o.coldStartPoses = 100;
    o.timingBudget = 0.2;
    o.talkOrderer = false;
    o.crowdSizes = {1, 2};
    o.chainSizes = {17, 34};
    o.scalingFrames = 10;
    o.realtimeFrames = 5;
    o.realtimeMaxAgents = 2;
    o.mayaScenes = false;  // a minute and more of learning
    // 14 characters learned in two modes: 13 s.
    o.characters.perConstruction = 0;
    o.characters.randomCharacters = 0;
    return o;
}

BenchOptions fullOptions()
{
    BenchOptions o;
    o.crowdSizes = {1, 2, 4, 8, 16, 32, 64};
    o.chainSizes = {17, 34, 67, 134};
    return o;
}

namespace {

using Clock = std::chrono::steady_clock;

void say(const BenchOptions& o, const std::string& line)
{
    if (o.log) o.log(line);
}

// The biped's spec, as rig-learn --spec reads it; it must name the parameters.
InversionSpec readSpec(const std::filesystem::path& file)
{
    InversionSpec spec = readInversionSpec(file);
    if (spec.params.empty()) throw Error(fmt::format("{}: no 'params' list of plug globs", file.string()));
    return spec;
}

LearnOptions learnOptions(Orderer orderer, bool relativeFrames = true, int threads = 1)
{
    LearnOptions o;  // rig-learn's defaults
    o.orderer = orderer;
    o.relativeFrames = relativeFrames;
    o.threads = threads;
    return o;
}

// Training wall time on 1 and 2 rig instances, and whether both wrote the same approximation (training
// time aside), as rig-learn --threads promises.
Json threadsJson(RigFunction& rig, const std::string& rigFile)
{
    Json out = Json::object();
    std::vector<std::string> texts;
    for (const int threads : {1, 2}) {
        Approximation a = learnApproximation(rig, learnOptions(Orderer::structured, true, threads), rigFile);
        out[fmt::format("seconds_{}_threads", threads)] = a.training.seconds;
        a.training.seconds = 0.0;
        texts.push_back(approximationToYaml(a));
    }
    out["same_approximation"] = texts[0] == texts[1];
    return out;
}

Json trainingJson(const Approximation& a, std::size_t rigParameters)
{
    return Json{
        {"evaluations", a.training.evaluations},
        {"order_evaluations", a.training.orderEvaluations},
        {"seconds", a.training.seconds},
        {"orderer", a.training.orderer},
        {"parameters", static_cast<long long>(rigParameters)},
        {"modelled", static_cast<long long>(a.parameters.size())},
        {"discarded", static_cast<long long>(a.discarded.size())},
        {"validation_max_position_error_cm", a.validation.maxPositionErrorCm},
        {"validation_max_rotation_error_deg", a.validation.maxRotationErrorDeg},
        {"validation_max_relative_error", a.validation.maxRelativeError},
        {"within_epsilon", a.validation.withinEpsilon},
        {"relative_outputs", static_cast<long long>(std::count_if(a.outputs.begin(), a.outputs.end(),
                                                                  [](const auto& out) { return out.parent >= 0; }))}};
}

// A run of frames through the library's clip inversion (invertClip), as rig-invert runs it: warm-start
// chains restarted every 120 frames from the initial guess, stuck frames retried, a chunk joining its
// chain with untimed lead-in frames, the real rig measured against the targets at every frame.
struct ClipRun {
    ClipInversionSummary summary;
    std::vector<std::vector<double>> values;  // per reported frame

    int frames() const { return summary.frames; }
    double msPerFrame() const { return summary.msPerFrame; }
    double cpuMsPerFrame() const { return frames() ? 1e3 * summary.solveCpuSeconds / frames() : 0.0; }
    double meanIterations() const
    {
        double sum = 0.0;
        for (const auto& f : summary.perFrame) sum += f.solve.iterations;
        return sum / std::max(frames(), 1);
    }
    double meanFinalCost() const
    {
        double sum = 0.0;
        for (const auto& f : summary.perFrame) sum += f.solve.finalCost;
        return sum / std::max(frames(), 1);
    }
    // The real rig against the targets, as rig-invert reports it.
    Json errorsJson() const
    {
        return Json{{"frames", frames()},
                    {"status_frames", app::statusCountsJson(summary)},
                    {"max_position_error_cm", summary.maxPositionErrorCm},
                    {"mean_position_error_cm", summary.meanPositionErrorCm},
                    {"max_rotation_error_deg", summary.maxRotationErrorDeg},
                    {"mean_rotation_error_deg", summary.meanRotationErrorDeg}};
    }
};

// Frames [first, last] of `targets`, solved by `solver` (polished on the real rig `polishCorrections`
// times), or by `strategy` in the same chains.
ClipRun invertFrames(const Solver& solver, RigBinding& binding, const ClipTargets& targets, int first, int last,
                     int polishCorrections = 0, FrameSolveStrategy strategy = {}, RealRigFit fit = RealRigFit::none)
{
    ClipInversionOptions options;
    options.polishCorrections = polishCorrections;
    options.frameSolve = std::move(strategy);
    options.realRigFit = fit;
    ClipRun run;
    run.summary = invertClip(solver, binding, targets, first, last, options, run.values);
    return run;
}

// A peer's solve as a chain frame: converged or not, its iterations and final cost.
void peerFrame(bool converged, int iterations, double initialCost, double finalCost, ChainFrame& frame)
{
    frame = ChainFrame{};
    frame.summary.termination = converged ? TerminationType::converged : TerminationType::noConvergence;
    frame.summary.iterations = iterations;
    frame.summary.initialCost = initialCost;
    frame.summary.finalCost = finalCost;
}

#ifdef RIG_BENCH_HAVE_CERES
std::optional<double> ratio(std::optional<double> a, std::optional<double> b)
{
    if (!a || !b || !(*b > 0)) return std::nullopt;
    return *a / *b;
}
#endif

// A solver's figures over a run: timing, convergence and the real rig's errors.
Json runJson(const ClipRun& run, bool singleThread)
{
    int converged = 0;
    for (const auto& f : run.summary.perFrame) converged += f.solve.converged();
    return Json{{"frames", run.frames()},
                {"ms_per_frame", run.msPerFrame()},
                {"cpu_ms_per_frame", singleThread ? Json(run.cpuMsPerFrame()) : Json()},
                {"converged_frames", converged},
                {"mean_iterations", run.meanIterations()},
                {"mean_final_cost", run.meanFinalCost()},
                {"real_rig", run.errorsJson()}};
}

struct Variant {
    std::string name;
    int threads;
    JacobianMethod jacobian;
    bool partition;
    int polish;
    bool coupledBlocks = true;
};

struct VariantResult {
    Json json;
    ClipRun run;
};

VariantResult runVariant(const Variant& v, const Approximation& approximation, RigBinding& binding,
                         const ClipTargets& targets, int frames)
{
    SolverOptions options;
    options.threads = v.threads;
    options.jacobian = v.jacobian;
    options.partition = v.partition;
    options.coupledBlocks = v.coupledBlocks;
    const Solver solver(approximation, options);
    VariantResult result;
    result.run = invertFrames(solver, binding, targets, 0, frames - 1, v.polish);
    result.json = Json{{"name", v.name},
                       {"threads", v.threads},
                       {"jacobian", std::string(jacobianMethodName(v.jacobian))},
                       {"partition", v.partition},
                       {"coupled_blocks", v.partition && v.coupledBlocks},
                       {"polish", v.polish}};
    const Json figures = runJson(result.run, v.threads == 1);
    for (const char* key : {"frames", "ms_per_frame", "cpu_ms_per_frame", "converged_frames", "mean_iterations",
                            "mean_final_cost", "real_rig"})
        result.json[key] = figures.at(key);
    return result;
}

// The partitioned problem's Jacobian, block by block, as one solver iteration per block computes it.
class BlockJacobians {
public:
    BlockJacobians(const Solver& solver, std::span<const JointTarget> targets, std::span<const double> values)
    {
        const Approximation& a = solver.approximation();
        std::vector<PreparedTarget> prepared(targets.size());
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (targets[k].active && !prepareTarget(targets[k], solver.options().rotationScaleCm, prepared[k]))
                throw Error(fmt::format("the target of {} is not usable", a.outputs[k].name));
        for (const PartitionBlock& block : solver.partition(targets).blocks) {
            auto& b = *blocks_.emplace_back(std::make_unique<Block>(a, block));
            b.workspace.holdParameters(values);
            b.workspace.setTargets(prepared);
            for (const int p : block.parameters) b.x.push_back(values[static_cast<std::size_t>(p)]);
        }
    }
    void evaluate()
    {
        for (auto& b : blocks_) b->workspace.jacobian(b->x, JacobianMethod::analytic, 1e-6, false, b->r, b->J);
    }
    int blocks() const { return static_cast<int>(blocks_.size()); }

private:
    struct Block {
        Block(const Approximation& a, const PartitionBlock& block)
            : structure(a, block.parameters, block.outputs),
              workspace(structure),
              r(structure.rows()),
              J(structure.rows(), structure.columnCount())
        {
        }
        ResidualStructure structure;
        ResidualWorkspace workspace;
        std::vector<double> x;
        Eigen::VectorXd r;
        Eigen::MatrixXd J;
    };
    std::vector<std::unique_ptr<Block>> blocks_;
};

Json timingJson(const Timing& t, bool singleThread)
{
    return Json{{"median_ms", t.medianMs},
                {"min_ms", t.minMs},
                {"cpu_median_ms", singleThread ? Json(t.cpuMedianMs) : Json()},
                {"calls", t.calls}};
}

// The inversion variants rig-bench times, by name.
const std::vector<Variant>& bipedVariants()
{
    static const std::vector<Variant> variants{
        {"analytic, 1 thread", 1, JacobianMethod::analytic, true, 0},
        {"analytic, 2 threads", 2, JacobianMethod::analytic, true, 0},
        {"fd, 1 thread", 1, JacobianMethod::finiteDifference, true, 0},
        {"fd, 2 threads", 2, JacobianMethod::finiteDifference, true, 0},
        {"analytic, whole problem, 1 thread", 1, JacobianMethod::analytic, false, 0},
        {"analytic, 1 thread, polish 1", 1, JacobianMethod::analytic, true, 1},
        {"analytic, 1 thread, block by block", 1, JacobianMethod::analytic, true, 0, false},
    };
    return variants;
}

const Variant& variant(const std::string& name)
{
    const auto& variants = bipedVariants();
    const auto it = std::find_if(variants.begin(), variants.end(), [&](const Variant& v) { return v.name == name; });
    if (it == variants.end()) throw internalError(fmt::format("rig-bench: no variant '{}'", name));
    return *it;
}

const std::string partitionedVariant = "analytic, 1 thread";
const std::string wholeVariant = "analytic, whole problem, 1 thread";
const std::string blockByBlockVariant = "analytic, 1 thread, block by block";

// What the biped's sections share: the rig, its approximations, the clip's targets and frame counts, the
// variants' results and the accuracy figures gathered along the way.
struct BipedBench {
    BipedBench(const BenchOptions& options, GraphRigFunction& bipedRig) : o(options), rig(bipedRig) {}

    const BenchOptions& o;
    GraphRigFunction& rig;
    Approximation approximation;  // rig-learn's defaults
    Approximation worldSpace;     // every output in world space, as the talk
    TargetClip clip;
    ClipTargets targets;
    int frames = 0;
    int ceresFrames = 0;
    int blackBoxFrames = 0;
    std::optional<RigBinding> binding;
    std::map<std::string, VariantResult> results;
    Json accuracy = Json::object();

    const VariantResult& result(const std::string& name) const { return results.at(variant(name).name); }
};

// Training: both orderers, world space, and 1 against 2 rig instances.
void trainBiped(BipedBench& b, Json& report)
{
    const BenchOptions& o = b.o;
    GraphRigFunction& rig = b.rig;
    Json train = Json::object();
    Json orderers = Json::object();
    for (const Orderer orderer : {Orderer::talk, Orderer::structured}) {
        if (orderer == Orderer::talk && !o.talkOrderer) {
            orderers["talk"] = Json();
            continue;
        }
        say(o, fmt::format("training the biped's approximation ({} orderer)", ordererName(orderer)));
        Approximation a = learnApproximation(rig, learnOptions(orderer), o.rig.string());
        orderers[std::string(ordererName(orderer))] = trainingJson(a, rig.parameters().size());
        if (orderer == Orderer::structured) b.approximation = std::move(a);
    }
    // The talk's frames (every output in world space), for the figures before parent-relative outputs.
    say(o, "training the biped's approximation in world space (the talk's frames)");
    b.worldSpace = learnApproximation(rig, learnOptions(Orderer::structured, false), o.rig.string());
    orderers["structured_world_space"] = trainingJson(b.worldSpace, rig.parameters().size());
    train["evaluations"] = b.approximation.training.evaluations;
    train["seconds"] = b.approximation.training.seconds;
    train["orderer"] = b.approximation.training.orderer;
    train["orderers"] = std::move(orderers);
    say(o, "training the biped's approximation on 1 and 2 rig instances");
    train["threads"] = threadsJson(rig, o.rig.string());
    if (!o.talkOrderer) train["note"] = "the talk's orderer is not run with --quick";
    report["train"] = std::move(train);
    if (b.approximation.parameters.empty())
        throw Error(fmt::format("{}: the approximation models no parameter", o.rig.string()));
}

// Jacobians: the black box on the real graph against the approximation's, at rest, on the first frame's
// targets.
void timeJacobians(BipedBench& b, Json& report)
{
    const BenchOptions& o = b.o;
    const Approximation& approximation = b.approximation;
    const ClipTargets& targets = b.targets;
    const SolverOptions defaults;
    const double h = defaults.finiteDifferenceStep;
    say(o, "timing Jacobians");
    const auto& firstTargets = targets.frames.front();
    const std::vector<double> rest = approximation.defaults();
    JacobianEvaluator evaluator(approximation, firstTargets, defaults.rotationScaleCm);
    Eigen::MatrixXd jApprox, jBlack;
    Eigen::VectorXd rApprox, rBlack;
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    tbb::task_arena allCores(cores), oneCore(1);
    const Timing analytic =
        timeRepeated([&] { evaluator.jacobian(rest, JacobianMethod::analytic, h, jApprox, rApprox); }, o.timingBudget);
    Timing fdParallel, fdSerial;
    allCores.execute([&] {
        fdParallel = timeRepeated(
            [&] { evaluator.jacobian(rest, JacobianMethod::finiteDifference, h, jApprox, rApprox); }, o.timingBudget);
    });
    oneCore.execute([&] {
        fdSerial = timeRepeated(
            [&] { evaluator.jacobian(rest, JacobianMethod::finiteDifference, h, jApprox, rApprox); }, o.timingBudget);
    });
    RealRigProblem blackBox(*b.binding, defaults.rotationScaleCm);
    blackBox.setTargets(firstTargets);
    const std::uint64_t evaluationsBefore = blackBox.evaluations();
    const Timing blackForward =
        timeRepeated([&] { blackBox.jacobian(rest, h, false, &jBlack, rBlack); }, o.timingBudget, 3);
    const double evaluationsPerJacobian =
        static_cast<double>(blackBox.evaluations() - evaluationsBefore) / static_cast<double>(blackForward.calls + 1);
    const Timing blackCentral =
        timeRepeated([&] { blackBox.jacobian(rest, h, true, &jBlack, rBlack); }, o.timingBudget, 3);
    // Where the approximation is exact, the real rig's Jacobian is the approximation's.
    evaluator.jacobian(rest, JacobianMethod::analytic, h, jApprox, rApprox);
    blackBox.jacobian(rest, h, true, &jBlack, rBlack);
    const double scale = std::max(jApprox.cwiseAbs().maxCoeff(), 1e-300);
    report["jacobian"] =
        Json{{"rows", evaluator.rows()},
             {"columns", evaluator.columns()},
             {"blackbox_fd_ms", blackForward.cpuMedianMs},
             {"blackbox_central_fd_ms", blackCentral.cpuMedianMs},
             {"blackbox_evaluations_per_jacobian", evaluationsPerJacobian},
             {"approx_fd_ms", fdParallel.medianMs},
             {"approx_fd_threads", cores},
             {"approx_fd_serial_ms", fdSerial.cpuMedianMs},
             {"approx_analytic_ms", analytic.cpuMedianMs},
             {"speedup_analytic", blackForward.cpuMedianMs / analytic.cpuMedianMs},
             {"speedup_fd", blackForward.cpuMedianMs / fdParallel.medianMs},
             {"analytic_vs_blackbox_relative_difference", (jApprox - jBlack).cwiseAbs().maxCoeff() / scale},
             {"timings", Json{{"blackbox_fd", timingJson(blackForward, true)},
                              {"blackbox_central_fd", timingJson(blackCentral, true)},
                              {"approx_fd", timingJson(fdParallel, cores == 1)},
                              {"approx_fd_serial", timingJson(fdSerial, true)},
                              {"approx_analytic", timingJson(analytic, true)}}},
             {"note",
              "single-threaded figures are the thread's CPU time (median of ~1 ms batches), the "
              "parallel one wall time; black box: forward differences on the real graph; "
              "approximation: central differences (the solver's), and analytic"}};
}

// Inversion of the clip on the approximation, every variant.
Json invertVariants(BipedBench& b)
{
    Json rows = Json::array();
    for (const Variant& v : bipedVariants()) {
        say(b.o, fmt::format("inverting {} frames ({})", b.frames, v.name));
        const VariantResult& r = b.results[v.name] = runVariant(v, b.approximation, *b.binding, b.targets, b.frames);
        rows.push_back(r.json);
    }
    return rows;
}

// The talk's baseline: Gauss-Newton on the real graph, in the same chains, against ours on the same frames.
void compareBlackBox(BipedBench& b, Json& report)
{
    const BenchOptions& o = b.o;
    const Approximation& approximation = b.approximation;
    RigBinding& binding = *b.binding;
    const ClipTargets& targets = b.targets;
    const int blackBoxFrames = b.blackBoxFrames;
    const SolverOptions defaults;
    RealRigProblem blackBox(binding, defaults.rotationScaleCm);
    say(o, fmt::format("Gauss-Newton on the real graph, {} frames", blackBoxFrames));
    const Solver solver(approximation, SolverOptions{});
    std::uint64_t blackEvaluations = 0;
    const ClipRun black = invertFrames(
        solver, binding, targets, 0, blackBoxFrames - 1, 0,
        [&](std::span<const JointTarget> t, std::vector<double>& values, double, ChainFrame& frame) {
            blackBox.setTargets(std::vector<JointTarget>(t.begin(), t.end()));
            const RealRigSolve s = solveOnRealRig(blackBox, values, defaults);
            blackEvaluations += s.evaluations;
            peerFrame(s.converged, s.iterations, s.initialCost, s.finalCost, frame);
        },
        RealRigFit::everyOutput);
    // Ours on the same frames: the whole problem, as the black box solves it, and the partitioned one.
    const VariantResult sameWhole = runVariant(variant(wholeVariant), approximation, binding, targets, blackBoxFrames);
    const VariantResult samePartitioned =
        runVariant(variant(partitionedVariant), approximation, binding, targets, blackBoxFrames);
    Json blackJson = runJson(black, true);
    blackJson["evaluations_per_frame"] = static_cast<double>(blackEvaluations) / std::max(black.frames(), 1);
    blackJson["ours_cpu_ms_per_frame"] = samePartitioned.run.cpuMsPerFrame();
    blackJson["ours_whole_cpu_ms_per_frame"] = sameWhole.run.cpuMsPerFrame();
    blackJson["ours_whole_mean_final_cost"] = sameWhole.json.at("mean_final_cost");
    blackJson["speedup"] = black.cpuMsPerFrame() / samePartitioned.run.cpuMsPerFrame();
    blackJson["speedup_whole"] = black.cpuMsPerFrame() / sameWhole.run.cpuMsPerFrame();
    blackJson["note"] =
        "The solver's minimizer on the real graph with forward-difference Jacobians, serial, the real rig's step "
        "policy (Gauss-Newton, backtracked, then damped: inversion/clip/real_rig_solve.h), the solver's tolerances, "
        "the "
        "same unknowns, in the chains of invertClip; the first frames of the clip, the first from the initial guess";
    report["blackbox"] = blackJson;
    b.accuracy["blackbox"] = black.errorsJson();
    b.accuracy["approximation_on_blackbox_frames"] = samePartitioned.run.errorsJson();
    b.accuracy["approximation_whole_on_blackbox_frames"] = sameWhole.run.errorsJson();
}

// A peer: Ceres on the same residuals, in the same chains, against ours on the same frames.
void compareCeres([[maybe_unused]] BipedBench& b, Json& report)
{
    Json ceres = Json::object();
#ifdef RIG_BENCH_HAVE_CERES
    const BenchOptions& o = b.o;
    const Approximation& approximation = b.approximation;
    RigBinding& binding = *b.binding;
    const ClipTargets& targets = b.targets;
    const int ceresFrames = b.ceresFrames;
    const SolverOptions defaults;
    const Solver headlineSolver(approximation, defaults);
    {
        const VariantResult oursPartitioned =
            runVariant(variant(partitionedVariant), approximation, binding, targets, ceresFrames);
        const VariantResult oursWhole = runVariant(variant(wholeVariant), approximation, binding, targets, ceresFrames);
        const VariantResult oursBlockByBlock =
            runVariant(variant(blockByBlockVariant), approximation, binding, targets, ceresFrames);
        Json rows = Json::array();
        std::optional<double> best;
        Json bestRow;
        // Both dense solvers, with our tolerances (equal stopping rules: the headline) and with Ceres' own.
        for (const bool ceresTolerances : {false, true})
            for (const CeresLinearSolver linear :
                 {CeresLinearSolver::denseQr, CeresLinearSolver::denseNormalCholesky}) {
                const std::string tolerances = ceresTolerances ? "ceres defaults" : "ours";
                say(o, fmt::format("Ceres ({}, {} tolerances) on {} frames", ceresLinearSolverName(linear), tolerances,
                                   ceresFrames));
                CeresInverter inverter(approximation, defaults, linear, ceresTolerances);
                const ClipRun run = invertFrames(
                    headlineSolver, binding, targets, 0, ceresFrames - 1, 0,
                    [&](std::span<const JointTarget> t, std::vector<double>& values, double, ChainFrame& frame) {
                        const CeresSolve s = inverter.solve(std::vector<JointTarget>(t.begin(), t.end()), values);
                        peerFrame(s.converged, s.iterations, s.initialCost, s.finalCost, frame);
                    });
                Json row = Json{{"linear_solver", ceresLinearSolverName(linear)}, {"tolerances", tolerances}};
                const Json figures = runJson(run, true);
                for (const char* key : {"frames", "ms_per_frame", "cpu_ms_per_frame", "converged_frames",
                                        "mean_iterations", "mean_final_cost", "real_rig"})
                    row[key] = figures.at(key);
                const double cpuMs = run.cpuMsPerFrame();
                if (!ceresTolerances && (!best || cpuMs < *best)) {
                    best = cpuMs;
                    bestRow = row;
                }
                rows.push_back(std::move(row));
            }
        ceres["version"] = ceresVersion();
        ceres["ms_per_frame"] = orNull(best);
        ceres["linear_solver"] = bestRow.at("linear_solver");
        ceres["frames"] = ceresFrames;
        ceres["mean_final_cost"] = bestRow.at("mean_final_cost");
        ceres["ours_ms_per_frame"] = oursPartitioned.run.cpuMsPerFrame();
        ceres["ours_whole_ms_per_frame"] = oursWhole.run.cpuMsPerFrame();
        ceres["ours_mean_final_cost"] = oursPartitioned.json.at("mean_final_cost");
        ceres["ours_whole_mean_final_cost"] = oursWhole.json.at("mean_final_cost");
        ceres["ours_block_by_block_ms_per_frame"] = oursBlockByBlock.run.cpuMsPerFrame();
        ceres["ours_block_by_block_mean_final_cost"] = oursBlockByBlock.json.at("mean_final_cost");
        ceres["speedup_ours"] = orNull(ratio(best, oursPartitioned.run.cpuMsPerFrame()));
        ceres["speedup_ours_whole"] = orNull(ratio(best, oursWhole.run.cpuMsPerFrame()));
        ceres["variants"] = std::move(rows);
        ceres["note"] =
            "Levenberg-Marquardt, 1 thread, our residuals and analytic Jacobian as one dense residual "
            "block over all parameters, bounds on limited controls; CPU time per frame; the headline is "
            "the faster dense solver with our tolerances";
        b.accuracy["ceres"] = bestRow.at("real_rig");
    }
#else
    ceres["ms_per_frame"] = Json();
    ceres["note"] = "rig-bench was built without Ceres: apt-get install libceres-dev, then configure and build again";
    b.accuracy["ceres"] = Json();
#endif
    report["ceres"] = std::move(ceres);
}

// The leg joints (`legs`: output names) of an IK-mode run against the FK approximation's solution of the same frames,
// on the real rig: the IK knee is the FK knee (a sliding hinge), so the two should agree.
std::pair<double, double> legsAgainstFk(BipedBench& b, const Approximation& ik, RigBinding& binding, const ClipRun& run,
                                        int frames, const std::vector<std::string>& legs)
{
    const ClipRun& fk = b.result(partitionedVariant).run;
    std::vector<std::pair<int, int>> pairs;  // (FK output, IK output)
    for (std::size_t k = 0; k < ik.outputs.size(); ++k) {
        if (std::find(legs.begin(), legs.end(), ik.outputs[k].name) == legs.end()) continue;
        for (std::size_t f = 0; f < b.approximation.outputs.size(); ++f)
            if (b.approximation.outputs[f].name == ik.outputs[k].name)
                pairs.emplace_back(static_cast<int>(f), static_cast<int>(k));
    }
    double worst = 0.0, sum = 0.0;
    long long count = 0;
    std::vector<Eigen::Matrix4d> fkWorlds, ikWorlds;
    for (int f = 0; f < std::min(frames, fk.frames()); ++f) {
        b.binding->evaluate(fk.values[static_cast<std::size_t>(f)], fkWorlds);
        binding.evaluate(run.values[static_cast<std::size_t>(f)], ikWorlds);
        for (const auto& [i, k] : pairs) {
            const double d = (fkWorlds[static_cast<std::size_t>(i)].block<3, 1>(0, 3) -
                              ikWorlds[static_cast<std::size_t>(k)].block<3, 1>(0, 3))
                                 .norm();
            worst = std::max(worst, d);
            sum += d;
            ++count;
        }
    }
    return {worst, count ? sum / static_cast<double>(count) : 0.0};
}

const std::vector<std::string> bipedLegs{"LeftUpLeg",  "LeftLeg",  "LeftFoot",  "LeftToeBase",
                                         "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase"};

// The biped with IK legs (the spec beside the biped's, biped_inversion_ik.yaml): learned in IK mode, inverted on
// one thread, its leg joints against the FK approximation's on the same frames. Without helper frames (`helpers`
// false) the legs stay unmodelled and the hybrid solve fits them on the real rig; with them (found as rig-learn
// finds them) the legs are planar-chain constraint operators and the approximation's solve alone inverts them.
Json ikLegsBench(BipedBench& b, bool helpers)
{
    const BenchOptions& o = b.o;
    const auto specFile = o.spec.parent_path() / "biped_inversion_ik.yaml";
    if (!std::filesystem::exists(specFile)) return Json();
    const InversionSpec spec = readSpec(specFile);
    GraphRigOptions rigOptions{spec.params, spec.outputs, {}, spec.set, spec.ranges};
    rigOptions.autoHelpers = helpers;
    GraphRigFunction rig(o.rig, rigOptions);
    say(o, fmt::format("learning the biped with IK legs ({})", helpers ? "constraints" : "hybrid"));
    auto start = Clock::now();
    const Approximation approximation = learnApproximation(rig, LearnOptions{}, o.rig.string());
    const double learnSeconds = secondsSince(start);
    const ClipTargets targets = matchTargets(approximation, b.clip.joints, b.clip.worlds);
    const int frames = std::min(b.frames, static_cast<int>(targets.frames.size()));
    RigBinding binding(approximation, rig);
    const Solver solver(approximation, SolverOptions{});
    HybridSolver hybrid(solver, binding, 1);
    ChainScratch scratch;
    say(o, fmt::format("inverting {} frames with IK legs", frames));
    const ClipRun run =
        helpers ? invertFrames(solver, binding, targets, 0, frames - 1, 0)
                : invertFrames(
                      solver, binding, targets, 0, frames - 1, 0,
                      [&](std::span<const JointTarget> t, std::vector<double>& values, double previousCost,
                          ChainFrame& frame) { hybrid.solveFrame(t, values, previousCost, scratch, frame); },
                      RealRigFit::unmodelledOutputs);
    const auto [worst, mean] = legsAgainstFk(b, approximation, binding, run, frames, bipedLegs);
    Json json = runJson(run, true);
    json["spec"] = specFile.string();
    json["learn_seconds"] = learnSeconds;
    json["training_evaluations"] = approximation.training.evaluations;
    json["validation_max_relative_error"] = approximation.validation.maxRelativeError;
    long long unmodelled = 0;
    for (const ApproximationOutput& out : approximation.outputs) unmodelled += out.modelled ? 0 : 1;
    json["unmodelled_outputs"] = unmodelled;
    json["constraint_outputs"] = approximation.constraints.size();
    if (!helpers) json["hybrid_blocks"] = hybrid.describe();
    json["real_rig_evaluations_per_frame"] =
        run.frames() ? static_cast<double>(run.summary.realRigEvaluations) / run.frames() : 0.0;
    json["leg_joints_vs_fk_max_cm"] = worst;
    json["leg_joints_vs_fk_mean_cm"] = mean;
    json["note"] =
        helpers ? "legs in IK mode with stretch (the spec's set:), helper frames found as rig-learn finds them: the "
                  "thighs, shins and feet planar-chain constraint operators on their IK goal and pole, the toes "
                  "relative to the feet; the approximation's solve alone, no real-rig evaluation; thread CPU time per "
                  "frame; leg joints against the FK approximation's solution of the same frames"
                : "legs in IK mode with stretch (the spec's set:), learned without helper frames: the thighs, shins, "
                  "feet and toes unmodelled and fitted on the real rig after the approximation's solve; thread CPU "
                  "time per frame, one rig instance; leg joints against the FK approximation's solution of the same "
                  "frames (the IK knee is the FK knee: a sliding hinge)";
    return json;
}

// The biped with every joint as an output (the spec's parameters, its outputs left out): the eyes aims and the twist
// joints twist shares (constraint operators), found as rig-learn finds them. Learning only: what is modelled, at
// what cost in rig evaluations, and the validation.
Json everyJointBench(const BenchOptions& o)
{
    const InversionSpec spec = readSpec(o.spec);
    GraphRigOptions rigOptions{spec.params, {}, {}, spec.set, spec.ranges};
    rigOptions.autoHelpers = true;
    GraphRigFunction rig(o.rig, rigOptions);
    say(o, "learning the biped with every joint as an output");
    const auto start = Clock::now();
    const Approximation a = learnApproximation(rig, LearnOptions{}, o.rig.string());
    long long unmodelled = 0, shares = 0;
    for (const ApproximationOutput& out : a.outputs) unmodelled += out.modelled ? 0 : 1;
    for (const ConstraintBase& c : a.constraints) shares += c.kind == ConstraintKind::twistShare ? 1 : 0;
    return Json{{"outputs", a.outputs.size()},
                {"unmodelled_outputs", unmodelled},
                {"constraint_outputs", a.constraints.size()},
                {"twist_shares", shares},
                {"training_evaluations", a.training.evaluations},
                {"learn_seconds", secondsSince(start)},
                {"validation_max_relative_error", a.validation.maxRelativeError},
                {"within_epsilon", a.validation.withinEpsilon},
                {"singular_poses", a.validation.singularPoses},
                {"note",
                 "every joint of the biped an output, helper frames found as rig-learn finds them: the eyes "
                 "aims at eyes_ctrl, the 8 twist joints twist shares; validation skips the limit poses where "
                 "the rig's twist is decided by rounding (singular_poses)"}};
}

// The clip's targets for the biped, and the frame counts of the sections.
void readBipedClip(BipedBench& b, double loadSeconds, Json& report)
{
    const BenchOptions& o = b.o;
    const TargetMap map = o.map.empty() ? TargetMap{} : readTargetMap(o.map);
    b.clip = readTargetClip(o.clip, map);
    b.targets = matchTargets(b.approximation, b.clip.joints, b.clip.worlds);
    b.frames = std::min(o.frames, static_cast<int>(b.targets.frames.size()));
    b.ceresFrames = std::min(o.ceresFrames, b.frames);
    b.blackBoxFrames = std::min(o.blackBoxFrames, b.frames);
    report["biped"] = Json{{"rig", o.rig.string()},
                           {"parameters", static_cast<long long>(b.rig.parameters().size())},
                           {"modelled_parameters", static_cast<long long>(b.approximation.parameters.size())},
                           {"outputs", static_cast<long long>(b.approximation.outputs.size())},
                           {"clip", o.clip.string()},
                           {"clip_frames", static_cast<long long>(b.targets.frames.size())},
                           {"target_joints", b.targets.matchedJoints},
                           {"load_seconds", loadSeconds}};
}

// The inversion's headline figures: the variants' per frame and the black box's on its frames.
Json invertSummary(const BipedBench& b, Json variantRows, const Json& blackJson)
{
    const VariantResult& headline = b.result(partitionedVariant);
    const auto result = [&](const std::string& name) -> const VariantResult& { return b.result(name); };
    const std::string& whole = wholeVariant;
    const std::string& blockByBlock = blockByBlockVariant;
    return Json{{"frames", b.frames},
                {"ms_per_frame", headline.run.cpuMsPerFrame()},
                {"wall_ms_per_frame", headline.run.msPerFrame()},
                {"threads2_ms_per_frame", result("analytic, 2 threads").run.msPerFrame()},
                {"fd_ms_per_frame", result("fd, 1 thread").run.cpuMsPerFrame()},
                {"fd_threads2_ms_per_frame", result("fd, 2 threads").run.msPerFrame()},
                {"whole_ms_per_frame", result(whole).run.cpuMsPerFrame()},
                {"polish1_ms_per_frame", result("analytic, 1 thread, polish 1").run.cpuMsPerFrame()},
                {"block_by_block_ms_per_frame", result(blockByBlock).run.cpuMsPerFrame()},
                {"block_by_block_mean_final_cost", result(blockByBlock).json.at("mean_final_cost")},
                {"blackbox_ms_per_frame", blackJson.at("cpu_ms_per_frame")},
                {"blackbox_frames", blackJson.at("frames")},
                {"speedup_vs_blackbox_same_frames", blackJson.at("speedup")},
                {"variants", std::move(variantRows)},
                {"note",
                 "1-thread figures are the thread's CPU time per frame, 2-thread ones wall "
                 "time; solver and polish (the real rig's error measure excluded), through "
                 "invertClip as rig-invert runs it: warm starts from the previous frame, "
                 "restarts every 120 frames from the initial guess, stuck frames retried"}};
}

// The real rig against the clip with each method's parameters: the figures gathered along the way, the
// variants', and the world-space approximation's.
Json accuracyJson(BipedBench& b)
{
    Json& accuracy = b.accuracy;
    accuracy["approximation"] = b.result(partitionedVariant).run.errorsJson();
    accuracy["approximation_whole"] = b.result(wholeVariant).run.errorsJson();
    accuracy["approximation_polish1"] = b.result("analytic, 1 thread, polish 1").run.errorsJson();
    accuracy["approximation_fd"] = b.result("fd, 1 thread").run.errorsJson();
    {
        // Before parent-relative outputs: the world-space approximation, which discards what it cannot order.
        say(b.o, fmt::format("inverting {} frames with the world-space approximation", b.frames));
        RigBinding worldBinding(b.worldSpace, b.rig);
        const ClipTargets worldTargets = matchTargets(b.worldSpace, b.clip.joints, b.clip.worlds);
        Json before = runVariant(variant(partitionedVariant), b.worldSpace, worldBinding, worldTargets, b.frames)
                          .run.errorsJson();
        before["modelled_parameters"] = static_cast<long long>(b.worldSpace.parameters.size());
        accuracy["approximation_world_space"] = std::move(before);
    }
    accuracy["note"] = "real rig re-evaluated with each method's parameters, against the clip's joints";
    return std::move(accuracy);
}

}  // namespace

void runBipedBench(const BenchOptions& o, Json& report)
{
    const InversionSpec spec = readSpec(o.spec);
    GraphRigOptions rigOptions;
    rigOptions.parameterGlobs = spec.params;
    rigOptions.outputGlobs = spec.outputs;
    rigOptions.held = spec.set;  // the spec's state: learned in it, and every real-rig figure measured in it
    rigOptions.ranges = spec.ranges;
    auto start = Clock::now();
    GraphRigFunction rig(o.rig, rigOptions);
    const double loadSeconds = secondsSince(start);
    BipedBench b(o, rig);
    trainBiped(b, report);
    readBipedClip(b, loadSeconds, report);
    b.binding.emplace(b.approximation, rig);

    timeJacobians(b, report);
    Json variantRows = invertVariants(b);
    compareBlackBox(b, report);
    report["invert"] = invertSummary(b, std::move(variantRows), report.at("blackbox"));
    compareCeres(b, report);
    report["ik_legs"] = ikLegsBench(b, false);
    report["ik_legs_constraints"] = ikLegsBench(b, true);
    report["every_joint"] = everyJointBench(o);

    say(o, "cold starts: random poses of the approximation from rest");
    report["cold_start"] = coldStartJson(b.approximation, o.coldStartPoses);
    report["accuracy"] = accuracyJson(b);
    report["contacts"] = contactsBenchJson(o);
    say(o, "Maya scenes: each of ../shared/maya read into a graph");
    report["maya_load"] = mayaLoadJson(o.mayaFolder);
    report["maya_scenes"] =
        o.mayaScenes && !o.workDir.empty() ? mayaScenesJson(o.mayaFolder, o.workDir, o.log) : Json();
    if (!report.at("maya_scenes").is_null())
        compareWithBiped(report["maya_scenes"], report.at("invert").at("ms_per_frame").get<double>(),
                         report.at("biped").at("target_joints").get<int>());
    report["random_characters"] = o.workDir.empty() ? Json() : randomCharactersJson(o.characters, o.workDir, o.log);

    // The look-at crowd played in real time, every member inverted with this approximation (written for the
    // graph's rigInversion nodes to read).
    if (o.realtimeMaxAgents > 0 && !o.workDir.empty()) {
        const auto file = o.workDir / "biped.approx.yaml";
        app::writeFileAtomically(file.string(), approximationToYaml(b.approximation));
        report["crowd_realtime"] = crowdRealtimeJson(o, file);
    } else {
        report["crowd_realtime"] = Json();
    }
}

// --- scaling ---

namespace {

struct ScalingRig {
    std::string kind;
    int count;
    std::filesystem::path file;
    std::vector<std::string> params, outputs;
    std::vector<HeldPlug> held{};  // the biped's held plugs for every member of a crowd (biped0001:, ...)
};

ScalingRig makeRig(const BenchOptions& o, const InversionSpec& biped, const std::string& kind, int count)
{
    ScalingRig r{kind, count, o.workDir / fmt::format("{}{}.yaml", kind, count), {}, {}};
    std::string command = fmt::format("{} {} {} {} -o {}", shellQuote(o.python), shellQuote(o.makeRigs.string()), kind,
                                      count, shellQuote(r.file.string()));
    if (kind == "crowd") {
        command += " --rig " + shellQuote(std::filesystem::absolute(o.rig).string());
        // Each member under its namespace: the biped's globs with any member's prefix.
        for (const auto& p : biped.params) r.params.push_back("biped*:" + p);
        for (const auto& p : biped.outputs) r.outputs.push_back("biped*:" + p);
        for (int member = 1; member <= count; ++member)
            for (const auto& h : biped.set) r.held.push_back({fmt::format("biped{:04d}:{}", member, h.plug), h.value});
    } else {
        r.params = {"chain*.rotate?"};
    }
    if (std::system(command.c_str()) != 0) throw Error(fmt::format("could not write a generated rig: {}", command));
    return r;
}

// Crowd: every member follows the clip (members are independent problems). Chain: a smooth random
// motion within a third of each parameter's range, evaluated on the real rig (reachable targets).
ClipTargets scalingTargets(const ScalingRig& r, const Approximation& a, RigBinding& binding, const TargetClip& clip,
                           int frames)
{
    if (r.kind == "crowd") {
        // Every biped of the crowd follows the clip: its joints ("biped3:Hips") take the clip's ("Hips").
        std::vector<std::string> joints;
        std::vector<std::size_t> source;
        for (const auto& out : a.outputs) {
            const auto colon = out.name.rfind(':');
            const std::string name = colon == std::string::npos ? out.name : out.name.substr(colon + 1);
            const auto found = std::find(clip.joints.begin(), clip.joints.end(), name);
            if (found == clip.joints.end()) continue;
            joints.push_back(out.name);
            source.push_back(static_cast<std::size_t>(found - clip.joints.begin()));
        }
        std::vector<std::vector<Eigen::Matrix4d>> worlds;
        for (int f = 0; f < std::min(frames, static_cast<int>(clip.worlds.size())); ++f) {
            auto& frame = worlds.emplace_back();
            for (const std::size_t j : source) frame.push_back(clip.worlds[static_cast<std::size_t>(f)][j]);
        }
        return matchTargets(a, joints, worlds);
    }
    ClipTargets t;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> amplitude, phase, frequency;
    for (const auto& m : a.parameters) {
        amplitude.push_back((m.parameter.max - m.parameter.min) / 6.0 * unit(rng));
        phase.push_back(2 * std::numbers::pi * unit(rng));
        frequency.push_back(0.5 + 1.5 * unit(rng));
    }
    std::vector<double> values = a.defaults();
    std::vector<Eigen::Matrix4d> worlds;
    for (int f = 0; f < frames; ++f) {
        const double time = static_cast<double>(f) / std::max(frames, 1);
        for (std::size_t p = 0; p < values.size(); ++p)
            values[p] = a.parameters[p].parameter.defaultValue +
                        amplitude[p] * std::sin(2 * std::numbers::pi * frequency[p] * time + phase[p]);
        binding.evaluate(values, worlds);
        auto& frame = t.frames.emplace_back(a.outputs.size());
        for (std::size_t k = 0; k < worlds.size(); ++k) {
            frame[k].active = true;
            frame[k].world = worlds[k];
        }
    }
    t.matchedJoints = static_cast<int>(a.outputs.size());
    return t;
}

// A scaling rig inverted over the scaling frames, and its Jacobian's cost: the partition's blocks, and
// the black box's forward differences on the real graph (BenchOptions::scalingBlackBox).
struct ScalingSolve {
    ClipRun run;
    int blocks = 0;
    Timing jacobian;
    std::optional<double> blackMs;
};

ScalingSolve invertScalingRig(const BenchOptions& o, const ScalingRig& r, const Approximation& a, RigBinding& binding,
                              const TargetClip& clip)
{
    // Frame 0, a cold start from rest, is a lead-in: the rows compare steady warm-started frames, which
    // a handful of frames then measures without one outlier dominating.
    const int frames = std::min(o.scalingFrames + 1, static_cast<int>(clip.worlds.size()));
    const ClipTargets targets = scalingTargets(r, a, binding, clip, frames);
    const int first = std::min(1, frames - 1);

    say(o, fmt::format("scaling: {} {}: inverting {} frames", r.kind, r.count, frames - first));
    SolverOptions options;
    options.threads = 1;
    const Solver solver(a, options);
    ScalingSolve s;
    s.run = invertFrames(solver, binding, targets, first, frames - 1);

    const auto& firstTargets = targets.frames[static_cast<std::size_t>(first)];
    BlockJacobians blocks(solver, firstTargets, s.run.values.front());
    s.blocks = blocks.blocks();
    s.jacobian = timeRepeated([&] { blocks.evaluate(); }, o.timingBudget / 2, 3);
    if (o.scalingBlackBox) {
        const SolverOptions defaults;
        RealRigProblem black(binding, defaults.rotationScaleCm);
        black.setTargets(firstTargets);
        Eigen::VectorXd rb;
        s.blackMs =
            timeRepeated(
                [&] { black.jacobian(s.run.values.front(), defaults.finiteDifferenceStep, false, nullptr, rb); }, 0.0,
                1)
                .cpuMedianMs;
    }
    return s;
}

// What a scaling rig's learning and solve cost in memory (MB above the resident size before it) and time.
struct ScalingCosts {
    bool peakReset = false;
    double loadSeconds = 0.0, graphMb = 0.0, trainingPeakMb = 0.0, memoryMb = 0.0, approxKb = 0.0;
    Json threads;  // training on 1 and 2 rig instances (the largest crowd), else null
};

// The figures whose growth with the parameter count is fitted, one entry per rig of a kind.
struct Series {
    std::vector<double> params, msPerFrame, jacobianMs, blackBoxMs, evaluations, trainSeconds, memoryMb, approxKb;

    void add(double parameters, const Approximation& a, const ScalingSolve& s, const ScalingCosts& costs)
    {
        params.push_back(parameters);
        msPerFrame.push_back(s.run.cpuMsPerFrame());
        jacobianMs.push_back(s.jacobian.cpuMedianMs);
        blackBoxMs.push_back(s.blackMs.value_or(0.0));
        evaluations.push_back(static_cast<double>(a.training.evaluations));
        trainSeconds.push_back(a.training.seconds);
        memoryMb.push_back(costs.memoryMb);
        approxKb.push_back(costs.approxKb);
    }
};

Json scalingRowJson(const ScalingRig& r, std::size_t parameters, const Approximation& a, const ScalingSolve& s,
                    const ScalingCosts& costs)
{
    return Json{{"rig", r.kind},
                {"count", r.count},
                {"parameters", static_cast<long long>(parameters)},
                {"modelled", static_cast<long long>(a.parameters.size())},
                {"outputs", static_cast<long long>(a.outputs.size())},
                {"blocks", s.blocks},
                {"load_seconds", costs.loadSeconds},
                {"train_evaluations", a.training.evaluations},
                {"train_order_evaluations", a.training.orderEvaluations},
                {"train_seconds", a.training.seconds},
                {"train_threads", costs.threads},
                {"validation_max_relative_error", a.validation.maxRelativeError},
                {"within_epsilon", a.validation.withinEpsilon},
                {"frames", s.run.frames()},
                {"status_frames", app::statusCountsJson(s.run.summary)},
                {"ms_per_frame", s.run.cpuMsPerFrame()},
                {"wall_ms_per_frame", s.run.msPerFrame()},
                {"mean_iterations", s.run.meanIterations()},
                {"jacobian_ms", s.jacobian.cpuMedianMs},
                {"blackbox_jacobian_ms", orNull(s.blackMs)},
                {"max_position_error_cm", s.run.summary.maxPositionErrorCm},
                {"max_rotation_error_deg", s.run.summary.maxRotationErrorDeg},
                {"memory_mb", costs.memoryMb},
                {"memory_graph_mb", costs.graphMb},
                {"memory_training_peak_mb", costs.trainingPeakMb},
                {"memory_peak_reset", costs.peakReset},
                {"approximation_kb", costs.approxKb}};
}

// One scaling row: a generated rig of `kind` and `count`, loaded, learned, inverted and measured.
Json scalingRow(const BenchOptions& o, const InversionSpec& biped, const TargetClip& clip, const std::string& kind,
                int count, Series& series)
{
    const ScalingRig r = makeRig(o, biped, kind, count);
    ScalingCosts costs;
    costs.peakReset = resetPeakResident();
    const double residentBefore = residentMb();

    auto start = Clock::now();
    GraphRigOptions rigOptions;
    rigOptions.parameterGlobs = r.params;
    rigOptions.outputGlobs = r.outputs;
    rigOptions.held = r.held;
    GraphRigFunction rig(r.file, rigOptions);
    costs.loadSeconds = secondsSince(start);
    costs.graphMb = residentMb() - residentBefore;
    say(o, fmt::format("scaling: {} {} ({} parameters): training", kind, count, rig.parameters().size()));
    const Approximation a = learnApproximation(rig, learnOptions(Orderer::structured), r.file.string());
    costs.trainingPeakMb = peakResidentMb() - residentBefore;
    RigBinding binding(a, rig);
    const ScalingSolve s = invertScalingRig(o, r, a, binding, clip);
    costs.memoryMb = peakResidentMb() - residentBefore;
    costs.approxKb = static_cast<double>(approximationToYaml(a).size()) / 1024.0;
    // The largest crowd, the heaviest rig, learned again on 1 and 2 rig instances: after the row's memory is
    // taken, since a second rig instance is this measurement's, not the row's (every row measures the same work).
    if (kind == "crowd" && count == o.crowdSizes.back()) {
        say(o, fmt::format("scaling: {} {}: training on 1 and 2 rig instances", kind, count));
        costs.threads = threadsJson(rig, r.file.string());
    }

    series.add(static_cast<double>(rig.parameters().size()), a, s, costs);
    return scalingRowJson(r, rig.parameters().size(), a, s, costs);
}

Json growthJson(const std::map<std::string, Series>& series)
{
    Json growth = Json::object();
    for (const auto& [kind, ser] : series) {
        auto fit = [&](const std::vector<double>& y) { return orNull(growthExponent(ser.params, y)); };
        growth[kind] = Json{{"ms_per_frame", fit(ser.msPerFrame)},         {"jacobian_ms", fit(ser.jacobianMs)},
                            {"blackbox_jacobian_ms", fit(ser.blackBoxMs)}, {"train_evaluations", fit(ser.evaluations)},
                            {"train_seconds", fit(ser.trainSeconds)},      {"memory_mb", fit(ser.memoryMb)},
                            {"approximation_kb", fit(ser.approxKb)}};
    }
    growth["note"] = "least-squares slope of log(figure) against log(parameters): cost ~ parameters^slope";
    return growth;
}

}  // namespace

void runScaling(const BenchOptions& o, Json& report)
{
    const InversionSpec biped = readSpec(o.spec);
    const TargetMap map = o.map.empty() ? TargetMap{} : readTargetMap(o.map);
    const TargetClip clip = readTargetClip(o.clip, map);
    std::filesystem::create_directories(o.workDir);
    std::vector<std::pair<std::string, int>> rigs;
    for (const int n : o.crowdSizes) rigs.emplace_back("crowd", n);
    for (const int n : o.chainSizes) rigs.emplace_back("chain", n);
    Json rows = Json::array();
    std::map<std::string, Series> series;
    for (const auto& [kind, count] : rigs) rows.push_back(scalingRow(o, biped, clip, kind, count, series[kind]));
    report["scaling"] = std::move(rows);
    report["growth"] = growthJson(series);
}

}  // namespace rig::bench

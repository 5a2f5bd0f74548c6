// A warm-start chain allocates nothing per frame once its storage has grown: the test binary's operator new
// (allocation_counter.h) counts the calls made while the biped's frames are solved, the IK biped's (planar chains)
// and a long chain's (eliminated node by node).
#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "allocation_counter.h"
#include "app/eval/eval_run.h"
#include "graph/yaml_loader.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/random_fk.h"
#include "inversion/solve/block_elimination.h"
#include "inversion/solver_rigs.h"
#include "learned_fixtures.h"

using namespace rig;

TEST_CASE(
    "allocation: a warm-start chain on the biped allocates nothing per frame, restart frames and retries included")
{
    const Approximation a = readApproximationFile(test::bipedApproximation());
    // A smooth motion of every control, its targets moved a few centimetres off (unreachable: every frame
    // ends stuck, with missed joints to list), and a cut at frame 180.
    std::mt19937 rng(31);
    const std::vector<double> from = test::randomValues(a, rng, 0.4), to = test::randomValues(a, rng, 0.4),
                              cut = test::randomValues(a, rng, 0.8);
    std::normal_distribution<double> normal(0.0, 2.0);
    std::vector<Eigen::Vector3d> offsets;
    for (std::size_t k = 0; k < a.outputs.size(); ++k) offsets.emplace_back(normal(rng), normal(rng), normal(rng));
    constexpr int frames = 240, restartInterval = 120;
    std::vector<std::vector<JointTarget>> clip;
    for (int f = 0; f < frames; ++f) {
        std::vector<double> values(a.parameters.size());
        const double s = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * f / frames);
        for (std::size_t p = 0; p < values.size(); ++p) values[p] = f >= 180 ? cut[p] : (1 - s) * from[p] + s * to[p];
        std::vector<JointTarget> targets = test::targetsAt(a, values);
        for (std::size_t k = 0; k < targets.size(); ++k) targets[k].world.block<3, 1>(0, 3) += offsets[k];
        clip.push_back(std::move(targets));
    }

    const Solver solver(a, SolverOptions{});
    const std::vector<double> rest = a.defaults();
    std::vector<double> values = rest;
    ChainScratch scratch;
    ChainFrame frame;
    double previousCost = retryNever;
    int stuck = 0, restarts = 0, retried = 0;
    long counted = 0;
    for (int f = 0; f < frames; ++f) {
        // The first chain grows the storage; the second is counted.
        if (f == restartInterval) {
            test::startCountingAllocations();
        }
        const bool restart = f % restartInterval == 0;
        if (restart) {
            values = rest;  // the same size: no allocation
            solver.initialGuess(clip[static_cast<std::size_t>(f)], values);
            ++restarts;
        }
        // Frames 60 and 180 are retried whatever their cost (as if it had jumped): both chains take that path.
        const double previous = restart ? retryNever : f % restartInterval == 60 ? 0.0 : previousCost;
        solveChainFrame(solver, clip[static_cast<std::size_t>(f)], values, previous, scratch, frame);
        previousCost = frame.summary.finalCost;
        if (f >= restartInterval) {
            stuck += frame.summary.termination == TerminationType::stuck;
            retried += frame.retried;
        }
        if (f == frames - 1) {
            counted = test::stopCountingAllocations();
        }
    }
    CHECK(restarts == 2);
    CHECK(stuck == frames - restartInterval);  // missed joints listed on every counted frame
    CHECK(retried == 1);
    CHECK(!frame.summary.missedOutputs.empty());
    CHECK(counted == 0);
}

TEST_CASE(
    "allocation: the biped with IK legs (planar chains, singular leg blocks) solves its frames without allocating")
{
    // The legs' bases take the twist normals and their blocks the pivoted pseudo-inverse. A smooth motion of every
    // control, restarted from the initial guess every 120 frames. Only the warm-started solves are counted: the cold
    // start's closed-form placement of the chains' goals and poles (pole_hold.h) allocates, restarts and retries.
    const InversionSpec spec = readInversionSpec(test::sourceDir() / "rigs" / "biped_inversion_ik.yaml");
    GraphRigOptions options{spec.params, spec.outputs, {}, spec.set, spec.ranges};
    options.autoHelpers = true;
    GraphRigFunction rig(test::sourceDir() / "rigs" / "biped.yaml", options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, "rigs/biped.yaml");
    REQUIRE(!a.constraints.empty());
    std::mt19937 rng(37);
    const std::vector<double> from = test::randomValues(a, rng, 0.3), to = test::randomValues(a, rng, 0.3);
    constexpr int frames = 240, restartInterval = 120;
    std::vector<std::vector<JointTarget>> clip;
    for (int f = 0; f < frames; ++f) {
        std::vector<double> values(a.parameters.size());
        const double s = 0.5 - 0.5 * std::cos(2.0 * std::numbers::pi * f / frames);
        for (std::size_t p = 0; p < values.size(); ++p) values[p] = (1 - s) * from[p] + s * to[p];
        std::vector<JointTarget> targets = test::targetsAt(a, values);
        for (std::size_t k = 0; k < targets.size(); ++k) targets[k].active = !a.outputs[k].helper;
        clip.push_back(std::move(targets));
    }
    const Solver solver(a, SolverOptions{});
    const std::vector<double> rest = a.defaults();
    std::vector<double> values = rest;
    ChainScratch scratch;
    ChainFrame frame;
    double previousCost = retryNever;
    long counted = 0;
    int solves = 0;
    for (int f = 0; f < frames; ++f) {
        const bool restart = f % restartInterval == 0;
        if (restart) {
            values = rest;  // the same size: no allocation
            solver.initialGuess(clip[static_cast<std::size_t>(f)], values);
        }
        const bool count = f > restartInterval;  // the first chain grows the storage
        if (count) test::startCountingAllocations();
        solveChainFrame(solver, clip[static_cast<std::size_t>(f)], values, restart ? retryNever : previousCost, scratch,
                        frame);
        const long made = count ? test::stopCountingAllocations() : 0;
        if (count && !frame.retried) {
            counted += made;
            ++solves;
        }
        previousCost = frame.summary.finalCost;
    }
    CHECK(solves > 100);
    CHECK(frame.summary.finalCost < 1e-6);
    CHECK(counted == 0);
}

TEST_CASE("allocation: a long chain, eliminated node by node, allocates nothing per frame once its storage has grown")
{
    // A serial chain of 12 joints along x, three rotate channels each: one block of 36 columns.
    test::RandomFk fk;
    for (int j = 0; j < 12; ++j) {
        fk.parent.push_back(j - 1);
        fk.offset.emplace_back(j == 0 ? 0.0 : 10.0, 0.0, 0.0);
        fk.orient.push_back(Eigen::Matrix3d::Identity());
        fk.order.push_back({j % 3, (j + 1) % 3, (j + 2) % 3});
        for (int axis = 0; axis < 3; ++axis) fk.channels.push_back({j, false, axis});
    }
    test::LambdaRig rig = test::lambdaRig(fk, true);
    LearnOptions learn;
    learn.validationPoses = 3;
    const Approximation a = learnApproximation(rig, learn, "chain");
    REQUIRE(a.parameters.size() > static_cast<std::size_t>(BlockElimination::recursiveAbove));
    std::mt19937 rng(12);
    const std::vector<double> from = test::randomValues(a, rng, 0.3), to = test::randomValues(a, rng, 0.3);
    const Solver solver(a, SolverOptions{});
    std::vector<double> values = a.defaults();
    ChainScratch scratch;
    ChainFrame frame;
    constexpr int frames = 40;
    long counted = 0;
    int converged = 0;
    for (int f = 0; f < frames; ++f) {
        std::vector<double> pose(from.size());
        for (std::size_t p = 0; p < pose.size(); ++p) pose[p] = from[p] + (to[p] - from[p]) * f / frames;
        const std::vector<JointTarget> targets = test::targetsAt(a, pose);  // made before counting starts
        const bool count = f >= frames / 2;  // the first half grows the storage; the second is counted
        if (count) test::startCountingAllocations();
        solveChainFrame(solver, targets, values, f == 0 ? retryNever : frame.summary.finalCost, scratch, frame);
        if (count) counted += test::stopCountingAllocations();
        converged += count && frame.summary.converged();
    }
    CHECK(converged == frames / 2);
    CHECK(counted == 0);
}

TEST_CASE("allocation: a crowd's frame allocates nothing")
{
    // The look-at crowd as rig-bench's crowd_realtime plays it (docs/crowds.md): the clip, the lookAt, the
    // rigInversion node's solve and judgement, the rig's joints up to the heads, the graph's push and pull. On one
    // thread: on two, oneTBB's task pools grow when a busy machine makes its threads steal work (seen under ctest -j2),
    // which is the scheduler's, not the frame's.
    if (!std::filesystem::exists(test::cmuClip)) return;
    const std::string file = test::writeCrowd(test::scratchDir("crowd-allocation"), 2).string();
    auto graph = loadGraphFile(file, app::nodeRegistry({}));
    std::vector<Plug> plugs = app::selectPlugs(*graph, file, {"*:inverter.value[*]"}, 1.0);
    for (int i = 0; i < 2; ++i) {
        plugs.push_back(graph->plug(fmt::format("c{:04d}:look.outMatrix[3]", i)));
        plugs.push_back(graph->plug(fmt::format("c{:04d}:Head.worldMatrix", i)));
    }
    std::vector<Value> values;
    // The first frames grow the storage (the first one loads the approximation and solves from rest).
    for (int f = 1; f <= 3; ++f) app::evaluateFrame(*graph, file, f, true, plugs, values);
    test::startCountingAllocations();
    for (int f = 4; f <= 12; ++f) app::evaluateFrame(*graph, file, f, true, plugs, values);
    CHECK(test::stopCountingAllocations() == 0);
}

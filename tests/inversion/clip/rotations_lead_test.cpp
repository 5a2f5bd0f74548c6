// The rotations lead a long chain's frames (solveChainFrame, inversion/clip/clip_inversion.h): after a frame whose
// first step was longer than the angular trust region, the next is solved with the positions weighed a hundredth first.
// Measured against the plain warm-started solve on the same frames: the same answers, fewer iterations where the
// targets are reached, and the lead backed off where they are not.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/random_fk.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

// rig-bench's chain (scripts/make_rigs.py chain): `joints` joints 10 cm apart along x, rotate orders xyz, yzx, zxy in
// turn, every rotate channel a parameter.
test::RandomFk chainFk(int joints)
{
    test::RandomFk fk;
    const std::array<std::array<int, 3>, 3> orders{{{0, 1, 2}, {1, 2, 0}, {2, 0, 1}}};
    for (int j = 0; j < joints; ++j) {
        fk.parent.push_back(j - 1);
        fk.offset.emplace_back(j == 0 ? 0.0 : 10.0, 0.0, 0.0);
        fk.orient.push_back(Eigen::Matrix3d::Identity());
        fk.order.push_back(orders[static_cast<std::size_t>(j % 3)]);
        for (int axis = 0; axis < 3; ++axis) fk.channels.push_back({j, false, axis});
    }
    return fk;
}

Approximation learnChain(test::LambdaRig& rig)
{
    LearnOptions options;
    options.validationPoses = 3;
    return learnApproximation(rig, options, "chain");
}

Approximation longChain(int joints)
{
    test::LambdaRig rig = test::lambdaRig(chainFk(joints), true);
    return learnChain(rig);
}

// rig-bench's chain motion: each parameter a sine about its default, up to a sixth of its range, 0.5 to 2 cycles
// over the frames; the targets the approximation's worlds (reachable), moved by `offsetCm` (a random direction per
// joint: out of reach).
std::vector<std::vector<JointTarget>> chainMotion(const Approximation& a, int frames, double offsetCm)
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::vector<double> amplitude, phase, frequency;
    for (const auto& m : a.parameters) {
        amplitude.push_back((m.parameter.max - m.parameter.min) / 6.0 * unit(rng));
        phase.push_back(2 * std::numbers::pi * unit(rng));
        frequency.push_back(0.5 + 1.5 * unit(rng));
    }
    std::vector<Eigen::Vector3d> offsets;
    for (std::size_t k = 0; k < a.outputs.size(); ++k)
        offsets.push_back(offsetCm * Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5).normalized());
    std::vector<std::vector<JointTarget>> clip;
    std::vector<double> pose(a.parameters.size());
    for (int f = 0; f < frames; ++f) {
        const double time = static_cast<double>(f) / frames;
        for (std::size_t p = 0; p < pose.size(); ++p)
            pose[p] = a.parameters[p].parameter.defaultValue +
                      amplitude[p] * std::sin(2 * std::numbers::pi * frequency[p] * time + phase[p]);
        clip.push_back(test::targetsAt(a, pose));
        for (std::size_t k = 0; k < offsets.size(); ++k) clip.back()[k].world.block<3, 1>(0, 3) += offsets[k];
    }
    return clip;
}

struct ChainRun {
    std::vector<std::vector<double>> values;
    std::vector<TerminationType> terminations;
    std::vector<double> costs;
    int iterations = 0;
    int ledFrames = 0;  // frames solved with the rotations leading
};

// The clip warm-started from frame 0's initial guess (as rig-bench's chain rows): through solveChainFrame, or plainly.
ChainRun runChain(const Solver& solver, const std::vector<std::vector<JointTarget>>& clip, bool chainFrames)
{
    ChainRun run;
    std::vector<double> values = solver.approximation().defaults();
    solver.initialGuess(clip.front(), values);
    ChainScratch scratch;
    ChainFrame frame;
    bool first = true;
    for (const auto& targets : clip) {
        if (chainFrames) {
            run.ledFrames += scratch.lead.rotations;
            // Retried never (a finite previous cost no frame's doubles): only the first frame starts the chain.
            solveChainFrame(solver, targets, values, first ? retryNever : 1e300, scratch, frame);
            first = false;
        } else {
            solver.solve(targets, values, frame.summary);
        }
        run.iterations += frame.summary.iterations;
        run.terminations.push_back(frame.summary.termination);
        run.costs.push_back(frame.summary.finalCost);
        run.values.push_back(values);
    }
    return run;
}

double largestDifference(const ChainRun& a, const ChainRun& b)
{
    double largest = 0.0;
    for (std::size_t f = 0; f < a.values.size(); ++f)
        for (std::size_t p = 0; p < a.values[f].size(); ++p)
            largest = std::max(largest, std::abs(a.values[f][p] - b.values[f][p]));
    return largest;
}

}  // namespace

TEST_CASE("rotations lead: a long chain's frames reach the plain solve's answers in fewer iterations")
{
    const Approximation a = longChain(67);
    const Solver solver(a, SolverOptions{});
    const auto clip = chainMotion(a, 41, 0.0);
    const ChainRun plain = runChain(solver, clip, false), led = runChain(solver, clip, true);
    for (std::size_t f = 0; f < clip.size(); ++f) {
        CAPTURE(f);
        CHECK(plain.terminations[f] == TerminationType::converged);
        CHECK(led.terminations[f] == TerminationType::converged);
    }
    CHECK(largestDifference(plain, led) < 1e-9);  // radians
    MESSAGE("201 parameters, 41 frames: ", plain.iterations, " iterations plain, ", led.iterations, " with ",
            led.ledFrames, " frames led");
    // Measured: 285 plain, 244 with 39 frames led.
    CHECK(led.ledFrames >= 30);
    CHECK(led.iterations <= 0.92 * plain.iterations);
}

TEST_CASE("rotations lead: not where the targets are out of reach, and the answers are the plain solve's")
{
    const Approximation a = longChain(67);
    const Solver solver(a, SolverOptions{});
    const auto clip = chainMotion(a, 41, 2.0);  // every joint 2 cm off
    const ChainRun plain = runChain(solver, clip, false), led = runChain(solver, clip, true);
    for (std::size_t f = 0; f < clip.size(); ++f) {
        CAPTURE(f);
        CHECK(plain.terminations[f] == TerminationType::stuck);
        CHECK(led.terminations[f] == TerminationType::stuck);
    }
    // The same minimum, to the solver's function tolerance: the costs within twice it (each solve stops within it of
    // the minimum, from either side of the valley), the values within what a flat valley leaves (measured 7.3e-5
    // radians, the costs within 1.02e-8 of each other; 6.4e-9 while damping persisted once started).
    for (std::size_t f = 0; f < clip.size(); ++f)
        CHECK(std::abs(led.costs[f] - plain.costs[f]) <= 2e-8 * plain.costs[f]);
    CHECK(largestDifference(plain, led) < 1e-3);
    MESSAGE("targets 2 cm off: ", plain.iterations, " iterations plain, ", led.iterations, " with ", led.ledFrames,
            " frames led");
    // A frame led where the targets are out of reach converges past its first step: the next lead waits 4 frames,
    // then 8, 16, ... Measured: 321 iterations plain, 338 with 4 frames led.
    CHECK(led.ledFrames <= 4);
    CHECK(led.iterations <= 1.1 * plain.iterations);
}

TEST_CASE("rotations lead: position targets alone have no rotation to lead")
{
    const Approximation a = longChain(67);
    const Solver solver(a, SolverOptions{});
    auto clip = chainMotion(a, 21, 0.0);
    for (auto& frame : clip)
        for (JointTarget& t : frame) t.rotationWeight = 0.0;
    const ChainRun plain = runChain(solver, clip, false), led = runChain(solver, clip, true);
    CHECK(led.values == plain.values);  // bit for bit: every frame solved plainly
    CHECK(led.iterations == plain.iterations);
}

TEST_CASE("rotations lead: a chunk from a restart frame solves as the whole clip does")
{
    test::LambdaRig rig = test::lambdaRig(chainFk(67), true);
    const Approximation a = learnChain(rig);
    const Solver solver(a, SolverOptions{});
    ClipTargets clip;
    clip.frames = chainMotion(a, 41, 0.0);
    clip.matchedJoints = static_cast<int>(a.outputs.size());
    RigBinding binding(a, rig);
    ClipInversionOptions options;
    options.restartInterval = 20;
    std::vector<std::vector<double>> whole, chunk;
    const ClipInversionSummary all = invertClip(solver, binding, clip, 0, 40, options, whole);
    invertClip(solver, binding, clip, 20, 40, options, chunk);
    CHECK(all.count(FrameStatus::reached) == 41);
    REQUIRE(chunk.size() == 21);
    // The whole clip's frames 1 to 19 led it into frame 20 with the rotations leading; the restart starts anew.
    for (std::size_t f = 0; f < chunk.size(); ++f) CHECK(chunk[f] == whole[f + 20]);  // bit for bit
}

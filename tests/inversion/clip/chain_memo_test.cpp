// A chain frame whose call is the last one's to the bit is not solved again (ChainMemo,
// inversion/clip/clip_inversion.h): a held pose of a clip. Measured against the same chain solved with the memo left
// out (a fresh scratch each frame, the lead carried over): the same values, summaries and leads to the bit, frame by
// frame, and the held frames taken from the memo.
#include <doctest/doctest.h>

#include <bit>
#include <cmath>
#include <cstdint>

#include "inversion/clip/clip_inversion.h"
#include "inversion/learn/learner.h"
#include "inversion/random_fk.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

// A 6-joint chain, every rotate channel a parameter, learned as rig-bench's chain is.
Approximation sixJointChain()
{
    test::RandomFk fk;
    for (int j = 0; j < 6; ++j) {
        fk.parent.push_back(j - 1);
        fk.offset.emplace_back(j == 0 ? 0.0 : 10.0, 0.0, 0.0);
        fk.orient.push_back(Eigen::Matrix3d::Identity());
        fk.order.push_back({0, 1, 2});
        for (int axis = 0; axis < 3; ++axis) fk.channels.push_back({j, false, axis});
    }
    test::LambdaRig rig = test::lambdaRig(fk, true);
    LearnOptions options;
    options.validationPoses = 3;
    return learnApproximation(rig, options, "chain");
}

// Frames 0..29: the controls sweep; frames 10..19 hold frame 10's pose. `missCm` moves the last joint's target out of
// reach (best-fit frames, which stop by other tests than reached ones).
std::vector<std::vector<JointTarget>> heldClip(const Approximation& a, double missCm)
{
    std::vector<std::vector<JointTarget>> clip;
    std::vector<double> pose = a.defaults();
    for (int f = 0; f < 30; ++f) {
        const double time = f < 10 ? f : f < 20 ? 10 : f - 9;
        for (std::size_t p = 0; p < pose.size(); ++p)
            pose[p] = a.parameters[p].parameter.defaultValue + 0.05 * time * std::sin(1.0 + static_cast<double>(p));
        clip.push_back(test::targetsAt(a, pose));
        clip.back().back().world(1, 3) += missCm;
    }
    return clip;
}

struct Chain {
    std::vector<std::vector<double>> values;
    std::vector<ChainFrame> frames;
};

// The clip as invertClip chains it from frame 0's rest values: one scratch throughout (`memo`), or a fresh one each
// frame with the lead carried, so that no call is ever the scratch's last.
Chain solveChain(const Solver& solver, const std::vector<std::vector<JointTarget>>& clip, bool memo)
{
    Chain chain;
    std::vector<double> values = solver.approximation().defaults();
    ChainScratch kept;
    ChainFrame frame;
    double previousCost = retryNever;
    for (const auto& targets : clip) {
        ChainScratch fresh;
        fresh.lead = kept.lead;
        solveChainFrame(solver, targets, values, previousCost, memo ? kept : fresh, frame);
        if (!memo) kept.lead = fresh.lead;
        previousCost = frame.summary.finalCost;
        chain.values.push_back(values);
        chain.frames.push_back(frame);
    }
    return chain;
}

bool sameBits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

void checkSameChain(const Chain& memo, const Chain& plain)
{
    REQUIRE(memo.values.size() == plain.values.size());
    for (std::size_t f = 0; f < memo.values.size(); ++f) {
        CAPTURE(f);
        CHECK(plain.frames[f].repeated == false);
        for (std::size_t p = 0; p < memo.values[f].size(); ++p) CHECK(sameBits(memo.values[f][p], plain.values[f][p]));
        const SolveSummary &a = memo.frames[f].summary, &b = plain.frames[f].summary;
        CHECK(a.iterations == b.iterations);
        CHECK(a.termination == b.termination);
        CHECK(sameBits(a.finalCost, b.finalCost));
        CHECK(sameBits(a.initialCost, b.initialCost));
        CHECK(a.missedOutputs == b.missedOutputs);
        CHECK(memo.frames[f].retried == plain.frames[f].retried);
    }
}

}  // namespace

TEST_CASE("chain memo: a held pose's frames are the chain's answers to the bit, not solved again")
{
    const Approximation a = sixJointChain();
    const Solver solver(a, SolverOptions{});
    for (const double missCm : {0.0, 3.0}) {
        CAPTURE(missCm);
        const auto clip = heldClip(a, missCm);
        const Chain memo = solveChain(solver, clip, true), plain = solveChain(solver, clip, false);
        checkSameChain(memo, plain);
        // Frame 10 moves, 11 starts at 10's answer; from 12 on, each call is the one before's: the same targets
        // from the answer they gave. Frames whose targets moved are solved.
        int repeated = 0;
        for (std::size_t f = 0; f < clip.size(); ++f) {
            CAPTURE(f);
            if (f <= 10 || f >= 20) CHECK_FALSE(memo.frames[f].repeated);
            repeated += memo.frames[f].repeated;
        }
        CHECK(repeated >= 7);
        for (std::size_t f = 1; f < clip.size(); ++f)
            if (memo.frames[f].repeated) CHECK(memo.values[f] == memo.values[f - 1]);
    }
}

TEST_CASE("chain memo: a call one bit away from the last, or with another solver, is solved")
{
    const Approximation a = sixJointChain();
    const Solver solver(a, SolverOptions{});
    auto clip = heldClip(a, 0.0);
    const std::vector<double> start = a.defaults();
    ChainScratch scratch;
    ChainFrame frame;
    std::vector<double> values = start;
    solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
    const std::vector<double> answer = values;

    values = start;
    solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
    CHECK(frame.repeated);
    CHECK(values == answer);

    SUBCASE("a target")
    {
        clip[5][2].world(0, 3) = std::nextafter(clip[5][2].world(0, 3), 1e9);
        values = start;
        solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
        CHECK_FALSE(frame.repeated);
    }
    SUBCASE("the start")
    {
        values = start;
        values[4] = std::nextafter(values[4], 1e9);
        solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
        CHECK_FALSE(frame.repeated);
    }
    SUBCASE("the previous cost")
    {
        values = start;
        solveChainFrame(solver, clip[5], values, 1.0, scratch, frame);
        CHECK_FALSE(frame.repeated);
    }
    SUBCASE("another solver (of the same approximation)")
    {
        const Solver other(a, SolverOptions{});
        values = start;
        solveChainFrame(other, clip[5], values, retryNever, scratch, frame);
        CHECK_FALSE(frame.repeated);
        CHECK(values == answer);
    }
    SUBCASE("the memo off (a scratch that serves many chains in turn)")
    {
        scratch.memo.on = false;
        values = start;
        solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
        CHECK_FALSE(frame.repeated);
        CHECK(values == answer);
    }
    SUBCASE("the lead")
    {
        values = start;
        scratch.lead.wait = 3;
        solveChainFrame(solver, clip[5], values, retryNever, scratch, frame);
        CHECK_FALSE(frame.repeated);
    }
}

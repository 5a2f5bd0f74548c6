#pragma once
// Inversion on the approximation (section 5 of the talk, and past it; docs/solver.md): joint targets
// -> parameter values. Gauss-Newton with minimum-norm steps, then Levenberg-Marquardt; limits kept by
// projection; analytic or parallel finite-difference Jacobians; independent blocks in parallel.

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "inversion/model/approximation.h"
#include "inversion/solve/continuity.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/partition.h"

namespace rig {

enum class TerminationType {
    converged,      // converged to the targets: a tolerance was met in every block, every target within targetTolerance
    stuck,          // stationary with a residual: a tolerance was met, but some target is further than targetTolerance
                    // (out of the rig's reach, or a local minimum: SolveSummary::missedOutputs says where)
    noConvergence,  // some block used its maxIterations (or its Jacobian stopped being finite)
    invalidTargets,  // an active target is not usable (non-finite, negative weight, singular): values left unchanged
    noTargets,       // no active target, or no parameter reaches one: values left unchanged
};

std::string_view terminationName(TerminationType termination);

// In the manner of Ceres' Solver::Options: every field has a documented default; validate() says
// which field is wrong.
struct SolverOptions {
    // Gauss-Newton iterations before switching to Levenberg-Marquardt (the talk: 30). A Gauss-Newton
    // step that does not lower the cost switches at once. 0: Levenberg-Marquardt from the start.
    int gaussNewtonIterations = 30;
    // Most iterations of both kinds together, per block. At least 1.
    int maxIterations = 100;
    // cm per radian in the rotation residual: a rotation error of 1 degree weighs as much as a
    // position error of rotationScaleCm * pi / 180 cm (with unit weights). The learner's frame radius.
    double rotationScaleCm = 10.0;
    // Converged when an accepted step lowers the cost by no more than this fraction of it, or when the
    // whole Gauss-Newton step's model decrease (half the squared Newton decrement) is no more than that:
    // that step is then not evaluated nor taken.
    double functionTolerance = 1e-8;
    // Converged when a step is no longer than parameterTolerance * (|x| + parameterTolerance)
    // (2-norms over the block's parameters, internal units). Gauss-Newton still takes such a step if it
    // does not raise the cost; Levenberg-Marquardt takes it only if it lowers the cost.
    double parameterTolerance = 1e-10;
    // Converged when the projected gradient max_i |x_i - clamp(x_i - g_i)| is at most this (g = J^T r).
    double gradientTolerance = 1e-12;
    // A target is reached when max(position error, rotationScaleCm * rotation error in radians) is at most
    // this, cm, on the halves it counts. A solve that meets a tolerance above with some target further
    // away ends `stuck` (stationary with a residual), not `converged`.
    double targetTolerance = 1e-3;
    JacobianMethod jacobian = JacobianMethod::analytic;
    // Largest change of an angular parameter in one iteration, radians (default 0.5, about 30 degrees):
    // a longer step is shortened, whole, to this. The linear model of a rotation is only good for a
    // fraction of a turn; without the cap, a near-singular pose (a straight elbow) lets a step swing
    // a control by whole turns onto an equivalent pose, which breaks continuity between frames.
    double maxAngularStep = 0.5;
    // The same on the real rig (real_rig_solve.h: the hybrid solve's second stage), radians. Larger: that stage
    // starts from the approximation's answer, which at a restart can be far from the real rig's (an IK goal left
    // at rest); half a radian led the biped's IK legs into a local minimum from 1 of 6 random poses, while whole
    // turns are taken back by the continuity there (HybridSolver::keepNearReference) in any case.
    double realRigMaxAngularStep = 1.0;
    // Central finite-difference step, in each parameter's internal unit (JacobianMethod::finiteDifference).
    double finiteDifferenceStep = 1e-6;
    // Split the problem into blocks (inversion/solve/partition.h); false solves every parameter together.
    bool partition = true;
    // With partition: solve the blocks together, each step by eliminating the blocks of the partition
    // tree from the leaves up (inversion/solve/block_elimination.h), which reaches the whole problem's optimum.
    // false: one block after another, each outer block fitted on its own outputs and then held (faster
    // per frame, a worse optimum on unreachable targets).
    bool coupledBlocks = true;
    // Threads for one solve: 0 uses the caller's task arena (all cores by default, and nested in a
    // caller's own tbb parallel loops), 1 runs serially without TBB, N > 1 uses the solver's own arena of
    // N (at most the machine's cores). The values are bit-identical for every count. Many concurrent solves: use 0
    // or 1.
    int threads = 0;

    // Throws rig::Error "SolverOptions::<field> = <value>: <rule>".
    void validate() const;
};

struct SolveSummary {
    TerminationType termination = TerminationType::noTargets;
    int iterations = 0;  // Gauss-Newton plus Levenberg-Marquardt, summed over blocks
    int gaussNewtonIterations = 0;
    int levenbergMarquardtIterations = 0;
    // 1/2 |r|^2 over every active target (weighted residuals), before and after.
    double initialCost = 0.0;
    double finalCost = 0.0;
    // Largest errors over active targets on the approximation, unweighted: position over targets with
    // positionWeight > 0, rotation over those with rotationWeight > 0.
    double maxPositionErrorCm = 0.0;
    double maxRotationErrorDeg = 0.0;
    // The output with the largest max(position error, rotationScaleCm * rotation error in radians).
    std::string worstOutput;
    // Outputs (indices into Approximation::outputs, increasing) further than targetTolerance from their
    // targets at the end: where a stuck or unconverged solve left a residual. Empty when converged.
    std::vector<int> missedOutputs;
    int blocks = 0;  // partition blocks solved
    // Some block's first step from the start turned an angle further than SolverOptions::maxAngularStep and was
    // shortened: the linear model at the start did not hold as far as the answer (solveChainFrame lets the rotations
    // lead the next frame).
    bool longFirstStep = false;

    // One line: termination, iterations, blocks, costs, worst errors.
    std::string briefReport() const;
    bool converged() const { return termination == TerminationType::converged; }
};

class Solver {
public:
    // Keeps a reference to `approximation` (it must outlive the solver). Throws rig::Error when the options
    // do not validate, an internal one when a parameter's limits are NaN or reversed.
    Solver(const Approximation& approximation, SolverOptions options);
    ~Solver();
    Solver(Solver&&) noexcept;
    Solver& operator=(Solver&&) noexcept;

    // targets: one per Approximation::outputs. values: one per Approximation::parameters (internal
    // units): in, the warm start (the previous frame, or defaults()); out, the solution. Parameters that
    // reach no active target keep their values; the others are moved onto their limits first.
    // Const and thread-safe: many threads may solve with one Solver at once.
    // Throws an internal rig::Error for wrong sizes, a rig::Error for a non-finite value of a parameter it
    // would solve.
    SolveSummary solve(std::span<const JointTarget> targets, std::span<double> values) const;
    // The same, into `summary`, whose storage is reused: once the solver's scratch and the summary have
    // grown (after the first solves of a set of counted targets), a solve allocates nothing.
    void solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary) const;
    // solve() from a start far from the answer (a chain's first frame: the initial guess, or rest). Where it misses
    // an output an animated switch's weight moves, it is solved again from that start with the weight at the other
    // branch's end, guessed anew there (initialGuess), and the cheaper answer is kept: of two branches that both reach
    // the first joint they blend, the one the start favoured may not reach the rest (an FK leg does not stretch).
    // solve() never flips a switch: along a chain the weight follows the frames.
    void solveCold(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary) const;

    // A start found from the approximation's structure instead of from the warm start (DESIGN: cold
    // starts), for a solve far from the answer: the outputs are taken parents first, and each output's
    // target fixes the parameters that reach it and no output before it, by a small solve on that output
    // alone from several starts a third of a turn apart (each rotation's equivalent values), the others
    // held; where that output leaves some of its parameters free (a reverse foot's roll, on the ankle), with
    // the later outputs that have no parameter of their own (the ball and toe). With parent-relative
    // operators that is each joint's local transform decomposed in its channels. `values`: in, the values
    // to start from (rest, or the previous frame); out, the guess. Parameters that reach no counted target
    // keep their values. invalidTargets and noTargets leave `values` alone, as solve() does; returns the
    // termination a solve would start with (converged: a guess was made). Throws as solve() does.
    TerminationType initialGuess(std::span<const JointTarget> targets, std::span<double> values) const;

    const SolverOptions& options() const;
    const Approximation& approximation() const;
    // The approximation's equivalent values (inversion/solve/continuity.h), made once with the solver.
    const Equivalences& equivalences() const;
    // The partition a solve with these targets uses (built once per set of counted rows, then cached).
    Partition partition(std::span<const JointTarget> targets) const;

    struct Impl;  // the solver's state and plans (inversion/solve/solver_impl.h, internal)

private:
    void solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary, bool cold) const;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rig

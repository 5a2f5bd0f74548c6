#pragma once
// What a solve is asked and what it reports, apart from the solver (solver.h) so that the minimizer and its step
// strategy, which the solver is built on, read them without it: the solver's options, its terminations and its summary.

#include <string>
#include <string_view>
#include <vector>

namespace rig {

enum class JacobianMethod { analytic, finiteDifference };

std::string_view jacobianMethodName(JacobianMethod method);

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
    // Gauss-Newton steps taken before a block stays with Levenberg-Marquardt (the talk: 30). Until then a
    // Gauss-Newton step that does not lower the cost is halved, then damped for one step (StepPolicy).
    // 0: Levenberg-Marquardt from the start.
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
    // Solver::solveOrGiveUp gave up some block: its cost stalled above the tolerance (then noConvergence).
    bool stalled = false;

    // One line: termination, iterations, blocks, costs, worst errors.
    std::string briefReport() const;
    bool converged() const { return termination == TerminationType::converged; }
};

}  // namespace rig

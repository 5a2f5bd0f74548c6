#pragma once
// The hybrid solve (docs/solver.md): for rigs whose approximation leaves some outputs non-compositional (an
// IK leg under a moving root, ApproximationOutput::modelled), first the approximation's solve of what it
// models, then Gauss-Newton on the real rig (real_rig_solve.h) for the parameters that move the outputs it
// does not model: an IK goal, a pole vector, the root on the IK leg's joints. That second stage starts from
// the first one's answer, differentiates the real rig by finite differences on parallel rig instances, and
// runs only over the blocks that need it; every other parameter keeps the approximation's answer.

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/real_rig_solve.h"
#include "inversion/solve/equivalences.h"

namespace rig {

// Parameters solved on the real rig together, and the outputs whose residuals they minimize there.
struct HybridBlock {
    std::vector<int> parameters;  // indices into Approximation::parameters, increasing: each moves an unmodelled output
    std::vector<int> outputs;     // every output they move, modelled or not, increasing
};

// The blocks of an approximation: the parameters with unmodelled outputs, grouped where they move a common
// output. Empty when every output is modelled.
std::vector<HybridBlock> hybridBlocks(const Approximation& approximation);

class HybridSolver {
public:
    // Keeps references to `solver` and `binding` (the real rig, for the approximation's parameters), which
    // must outlive it. `threads`: rig instances per real-rig Jacobian (RealRigProblem).
    HybridSolver(const Solver& solver, RigBinding& binding, int threads);
    ~HybridSolver();

    const std::vector<HybridBlock>& blocks() const { return blocks_; }

    // One frame of a warm-start chain, as solveChainFrame (which it runs first, retry included), then each
    // block on the real rig. At a restart (previousCost = retryNever), or when a block's cost jumps past twice
    // the previous frame's, the block is solved again by continuation from the rest pose and the cheaper
    // answer kept. frame.summary then describes the result on the real rig over every active target:
    // costs, worst errors, missed outputs; converged when every target is within targetTolerance there, stuck
    // when a tolerance was met with a target further (out of reach: a saturated IK), noConvergence when the
    // approximation's solve or a block used its iterations. frame.realRigEvaluations counts this frame's
    // real-rig evaluations (the final measurement included). Whole turns and Euler flips the real-rig stage made are
    // taken back (keepNearReference).
    void solveFrame(std::span<const JointTarget> targets, std::vector<double>& values, double previousCost,
                    ChainScratch& scratch, ChainFrame& frame);

    // One line: blocks, their parameters and outputs.
    std::string describe() const;

private:
    // Block b on the real rig from `values` (out: the solution).
    RealRigSolve solveBlock(std::size_t b, std::span<const JointTarget> targets, std::vector<double>& values);
    // Whether block b starts cheaper from the previous frame's answer (warm_) than from `values`, the
    // approximation's (two real-rig evaluations, added to `evaluations`).
    bool keepWarmStart(std::size_t b, std::span<const JointTarget> targets, std::span<const double> values,
                       int& evaluations);
    // Block b from its parameters' rest values, its targets moved from where the real rig puts its outputs there
    // to `targets` in continuationSteps steps (positions along a line, rotations along the shortest arc).
    RealRigSolve continuation(std::size_t b, std::span<const JointTarget> targets, std::vector<double>& values,
                              int& evaluations);
    static constexpr int continuationSteps = 4;
    // The real-rig stage has no trust region on angles: near a singular pose a step can wind a control by whole
    // turns, or turn a joint's three channels to their other Euler solution, onto the same pose. The values are
    // carried back toward reference_ (the frame before, or the approximation's answer at a restart) by
    // checkedContinuityShift, where the real rig and the approximation find the pose unchanged; its real-rig
    // evaluations are added to `evaluations`.
    void keepNearReference(std::vector<double>& values, int& evaluations);

    const Solver& solver_;
    RigBinding& binding_;
    std::vector<HybridBlock> blocks_;
    std::vector<std::unique_ptr<RealRigProblem>> problems_;  // one per block
    std::vector<double> x_, start_, warm_, reference_;
    Eigen::VectorXd residual_;
    std::vector<Eigen::Matrix4d> worlds_;
    std::vector<JointTarget> blended_;
};

}  // namespace rig

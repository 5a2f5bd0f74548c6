#pragma once
// How the minimizer (minimizer.h) chooses and solves a step, as Ceres splits trust_region_strategy.h from its
// minimizer: StepControl is the strategy (Gauss-Newton while it descends, then Levenberg-Marquardt with
// Nielsen's damping); DenseSystem is the dense linear solve of a step (Cholesky, else the minimum-norm step).
// A partition's coupled solve steps by block elimination instead (block_elimination.h).

#include <functional>
#include <limits>
#include <span>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "inversion/solve/solver_options.h"

namespace rig {

// Levenberg-Marquardt's first damping, relative to the largest diagonal entry of J^T J (Nielsen's tau).
inline constexpr double initialDamping = 1e-4;

// How a problem's steps are chosen beyond SolverOptions: what suits a cheap, smooth model (the approximation)
// and what suits a black box whose forward differences misjudge a kink (the real rig).
struct StepPolicy {
    // A Gauss-Newton step that does not lower the cost is halved up to this many times before damping is tried.
    int backtracks = 0;
    // After a damped step is taken, the next one is Gauss-Newton again (undamped, then backtracked, then damped
    // afresh); true: while SolverOptions::gaussNewtonIterations last and Gauss-Newton has not failed twice with only
    // damped steps between, then Levenberg-Marquardt to the end.
    bool budgetEndsGaussNewton = true;
    // No step is found once the damping passes this multiple of J^T J's largest free diagonal entry.
    double maxDamping = std::numeric_limits<double>::infinity();

    // The approximation's: each step Gauss-Newton first, halved up to 4 times, then damped afresh, within the
    // Gauss-Newton budget. Damping that persisted once started (Levenberg-Marquardt to the end) crawled where a pose
    // turns a constrained end or a switched space far from the warm start: the random characters' IK clips were 1.4 to
    // 3 times slower, and one space switch reached 18 of 60 frames (docs/solver.md, Accept or reject).
    static StepPolicy approximation() { return {4, true, std::numeric_limits<double>::infinity()}; }
    // The real rig's: each step Gauss-Newton first, halved up to 10 times, then damped from 1e-4 to 1e8 of the
    // largest diagonal entry (an IK knee at full extension, where the bend grows as the square root of the goal's
    // approach: Gauss-Newton's direction is poor there but short steps along it descend), whatever the budget.
    static StepPolicy realRig() { return {10, false, 1e8}; }
};

class StepControl {
public:
    StepControl(const SolverOptions& options, StepPolicy policy = StepPolicy::approximation());
    bool gaussNewton() const { return gaussNewton_; }
    // The length of the next trial along the step solved, 1 unless a Gauss-Newton step is being backtracked.
    double scale() const { return scale_; }
    // The damping of the next step; `largestDiagonal` (of the free columns' J^T J) scales the first one.
    double damping(double largestDiagonal);
    // Whether the trial point is taken; adapts the damping. `predicted` (the model's decrease) is asked for
    // only in Levenberg-Marquardt.
    bool accept(double cost, double trialCost, bool smallStep, const std::function<double()>& predicted);
    // Damping that overflowed: no step can be found any more.
    bool exhausted() const;
    // After an accepted step: a Gauss-Newton one counts against its budget; after a damped one the next is
    // Gauss-Newton again while the budget lasts (StepPolicy).
    void accepted();

private:
    const SolverOptions& options_;
    StepPolicy policy_;
    bool gaussNewton_;
    double mu_ = 0.0, nu_ = 2.0;
    int gaussNewtonTaken_ = 0;  // accepted Gauss-Newton steps: the budget's count
    int failedInARow_ = 0;      // Gauss-Newton steps that failed (halvings and all), none taken whole between
    double scale_ = 1.0;
    double ceiling_ = std::numeric_limits<double>::infinity();  // the damping past which no step is found
};

// J^T J as a dense lower triangle, and the damped step from it.
class DenseSystem {
public:
    // `rows`: J's, where known (fewer than the columns: J^T J is singular whatever the values).
    explicit DenseSystem(Eigen::Index columns, Eigen::Index rows = -1);
    // Before a minimization: the undamped steps try Cholesky first again, unless the rows are too few. Within one,
    // once an undamped Cholesky has failed the next undamped steps take the pivoted factor at once (a system
    // singular at one point of a solve mostly stays so: redundant controls). Reset for each minimization so that
    // a step depends on the minimization's own history only (a chunk of a clip solves as the whole clip does).
    void restart() { singular_ = fewerRows_; }
    // Where the normal equations put J^T J (column-major, lower triangle).
    std::span<double> entries() { return {H_.data(), static_cast<std::size_t>(H_.size())}; }
    const Eigen::MatrixXd& matrix() const { return H_; }
    Eigen::MatrixXd& matrix() { return H_; }
    double diagonal(Eigen::Index i) const { return H_(i, i); }
    // A held column's row and column replaced by the identity's.
    void hold(Eigen::Index i);
    // Gauss-Newton (mu = 0) or Levenberg-Marquardt step (J^T J + mu I) delta = -gradient, the held (`fixed`)
    // columns' gradient zero. From a pivoted Cholesky factor undamped, from Cholesky damped where that is well
    // conditioned; a singular system's is the minimum-norm step on its range (range_factor.h), which leaves the
    // (near-)null directions alone: redundant parameters split a change evenly, a parameter with no effect stays.
    // False when no finite step is found.
    bool solve(const Eigen::VectorXd& gradient, double mu, std::span<const char> fixed, Eigen::VectorXd& delta);
    // out = J^T J v.
    void multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) const;

private:
    bool fewerRows_;
    bool singular_;           // an undamped step takes the pivoted factor at once (restart())
    Eigen::MatrixXd H_;       // J^T J, lower triangle
    Eigen::MatrixXd damped_;  // H + mu I, lower triangle: what is factorized
    Eigen::LLT<Eigen::MatrixXd> llt_;
    // The step from a pivoted factor of S (`s`'s lower triangle, H or H + mu I): the minimum-norm one where S is
    // singular. Its factor L and P, M = L2 L1^-1 and I + M M^T (rangeStep), and the step's vectors.
    bool rangeStep(const Eigen::MatrixXd& s, const Eigen::VectorXd& gradient, double threshold, Eigen::VectorXd& delta);
    Eigen::MatrixXd pivoted_, nullityByRank_, nullSquare_;
    std::vector<int> permutation_;
    Eigen::VectorXd permuted_, reduced_, nullVector_;
};

}  // namespace rig

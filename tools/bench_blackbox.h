#pragma once
// The talk's baseline: the real rig as a black box. The same residuals as the solver's
// (inversion/jacobian.h) computed from real-rig evaluations, a finite-difference Jacobian that has to
// evaluate the stateful graph serially, column after column, and a plain Gauss-Newton on it.

#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "inversion/jacobian.h"
#include "inversion/rig_binding.h"
#include "inversion/solver.h"

namespace rig::bench {

class BlackBoxProblem {
public:
    // Unknowns: the approximation's parameters (as the solver's); other rig parameters stay at rest.
    BlackBoxProblem(RigBinding& binding, double rotationScaleCm);

    // One target per Approximation::outputs. Throws rig::Error for an active target that
    // prepareTarget refuses.
    void setTargets(std::span<const JointTarget> targets);
    int rows() const { return static_cast<int>(6 * active_.size()); }
    int columns() const { return static_cast<int>(lower_.size()); }
    // The solver's limits: a control's own limits, unbounded for a free one.
    const std::vector<double>& lower() const { return lower_; }
    const std::vector<double>& upper() const { return upper_; }

    // Residuals at `values` (one real-rig evaluation); returns the cost 1/2 |r|^2.
    double residuals(std::span<const double> values, Eigen::VectorXd& r);
    // Residuals at `values` and the Jacobian by finite differences with step h: forward (columns + 1
    // evaluations) or central (2 columns + 1; one-sided at a limit). Serial: the graph is stateful. `jacobian` may be
    // null (the columns are computed and dropped: timing a problem whose dense Jacobian would not fit).
    void jacobian(std::span<const double> values, double h, bool central, Eigen::MatrixXd* jacobian,
                  Eigen::VectorXd& r);

    std::uint64_t evaluations() const { return evaluations_; }

private:
    RigBinding& binding_;
    double rotationScaleCm_;
    std::vector<int> active_;  // outputs with a target
    std::vector<PreparedTarget> prepared_;
    std::vector<double> lower_, upper_;
    std::vector<double> probe_;
    std::vector<Eigen::Matrix4d> worlds_;
    Eigen::VectorXd rPlus_, rMinus_, column_;
    std::uint64_t evaluations_ = 0;
};

struct BlackBoxSolve {
    int iterations = 0;
    bool converged = false;
    double initialCost = 0.0;
    double finalCost = 0.0;
    std::uint64_t evaluations = 0;  // real-rig evaluations of this solve
};

// Gauss-Newton on the real rig from `values` (the warm start; out: the solution): forward-difference
// Jacobians (the cheapest black box), steps projected on the limits, backtracking when a step does not
// lower the cost, minimum-norm steps on rank-deficient systems. Stops on the solver's tolerances
// (SolverOptions: functionTolerance, parameterTolerance, gradientTolerance, maxIterations,
// finiteDifferenceStep).
BlackBoxSolve gaussNewtonBlackBox(BlackBoxProblem& problem, std::span<double> values, const SolverOptions& options);

}  // namespace rig::bench

#pragma once
// Gauss-Newton on the real rig (docs/solver.md): the talk's baseline, the black box whose Jacobian is taken
// by finite differences, and the second stage of a hybrid solve (hybrid_solve.h), where it fits the
// parameters and outputs the approximation does not model. The residuals are the solver's
// (inversion/solve/jacobian.h), computed from real-rig evaluations.

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "inversion/clip/rig_binding.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"

namespace rig {

class RealRigProblem {
public:
    // Unknowns: `columns` (indices into Approximation::parameters, increasing; empty: every parameter).
    // Residuals: the active targets of `outputs` (indices into Approximation::outputs; empty: every output).
    // `threads`: rig instances evaluating Jacobian columns at the same time (RigFunction::instance; a rig
    // without instances evaluates them one after another). 1: serially on `binding`'s rig, as the talk's
    // baseline does. The values are the same for any count. Other parameters are held (setHeld).
    RealRigProblem(RigBinding& binding, double rotationScaleCm, std::vector<int> columns = {},
                   std::vector<int> outputs = {}, int threads = 1);
    ~RealRigProblem();
    RealRigProblem(const RealRigProblem&) = delete;
    RealRigProblem& operator=(const RealRigProblem&) = delete;

    // One target per Approximation::outputs. Throws rig::Error for an active target that prepareTarget refuses.
    void setTargets(std::span<const JointTarget> targets);
    // Values of every approximation parameter (internal units): the unknowns' are overwritten by each call
    // below, the others held.
    void setHeld(std::span<const double> values);
    int rows() const { return rowOffset_.back(); }
    int columns() const { return static_cast<int>(columns_.size()); }
    const std::vector<int>& columnParameters() const { return columns_; }
    const Approximation& approximation() const { return binding_.approximation(); }
    // Every approximation parameter's value as last given to setHeld (the defaults before).
    const std::vector<double>& held() const { return held_; }
    // The solver's limits per unknown: a control's own limits, unbounded for a free one.
    const std::vector<double>& lower() const { return lower_; }
    const std::vector<double>& upper() const { return upper_; }

    // Residuals at the unknowns `x` (one real-rig evaluation); returns the cost 1/2 |r|^2.
    double residuals(std::span<const double> x, Eigen::VectorXd& r);
    // Residuals at `x` and the Jacobian by finite differences with step h: forward (columns + 1 evaluations)
    // or central (2 columns + 1; one-sided at a limit). `jacobian` may be null (the columns are computed and
    // dropped: timing a problem whose dense Jacobian would not fit). `residualsKnown`: r already holds the
    // residuals at x (the last residuals() call's), which are not evaluated again.
    void jacobian(std::span<const double> x, double h, bool central, Eigen::MatrixXd* jacobian, Eigen::VectorXd& r,
                  bool residualsKnown = false);

    std::uint64_t evaluations() const { return evaluations_; }

private:
    struct Evaluator;
    // Residuals with unknown `column` (or none, -1) moved to `value`, on evaluator `e`.
    void evaluate(Evaluator& e, std::span<const double> x, int column, double value, Eigen::VectorXd& r);

    RigBinding& binding_;
    double rotationScaleCm_;
    std::vector<int> columns_;
    std::vector<int> outputs_;  // the outputs residuals may count
    std::vector<int> active_;   // of those, the ones with an active target
    std::vector<PreparedTarget> prepared_;
    std::vector<const ResidualTerm*> terms_;  // per active target: its term
    std::vector<int> rowOffset_{0};           // per active target: where its rows begin, and the row count last
    std::vector<double> lower_, upper_;
    std::vector<double> held_;
    std::vector<std::unique_ptr<Evaluator>> evaluators_;  // [0] evaluates on binding_
    Eigen::VectorXd column_;
    std::uint64_t evaluations_ = 0;
};

struct RealRigSolve {
    int iterations = 0;
    bool converged = false;  // a tolerance was met (whether or not the targets were reached)
    double initialCost = 0.0;
    double finalCost = 0.0;
    std::uint64_t evaluations = 0;  // real-rig evaluations of this solve
};

// The solver's minimizer (minimizer.h) on the real rig from `x` (the unknowns' start; out: the solution), with
// forward-difference Jacobians (the cheapest black box): Gauss-Newton, then Levenberg-Marquardt where a step
// does not lower the real rig's cost (a kink, as an IK chain's knee at full extension); steps projected on
// the limits and within the angular trust region (SolverOptions::maxAngularStep); minimum-norm steps on
// rank-deficient systems (an under-determined control, such as a pole vector's three channels for one swivel
// angle, takes the smallest change from its start). Stops on the solver's tolerances (SolverOptions:
// functionTolerance, parameterTolerance, gradientTolerance, maxIterations, finiteDifferenceStep). With the
// approximation's `equivalences` (Solver::equivalences()), whole turns and Euler flips are kept near the start.
RealRigSolve solveOnRealRig(RealRigProblem& problem, std::span<double> x, const SolverOptions& options,
                            const Equivalences* equivalences = nullptr);

}  // namespace rig

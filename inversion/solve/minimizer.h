#pragma once
// The one minimizer of every solve (docs/solver.md), split as Ceres splits its own: this loop and its stop
// tests; the step strategy and the dense step (step_strategy.h); the problems it runs on, through
// MinimizerProblem: the approximation's residuals (the solver's blocks and coupled trees, solver.cpp) and the
// real rig's by finite differences (real_rig_solve.h). Both get the same limits, the same angular trust
// region, the same stop tests and the same continuity (whole turns and Euler flips kept near a reference).

#include <algorithm>
#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "inversion/model/approximation.h"
#include "inversion/solve/equivalences.h"
#include "inversion/solve/solver_options.h"
#include "inversion/solve/step_strategy.h"

namespace rig {

// `v` within [lo, hi], the limits of an unknown (infinite for a free one).
inline double clampTo(double v, double lo, double hi) { return std::min(std::max(v, lo), hi); }

// The unknowns of a problem: their limits, which are angles, and their equivalent values.
struct Unknowns {
    // `columns`: indices into approximation.parameters, increasing. `equivalences`: the approximation's
    // (Solver::equivalences()); null: no periods nor Euler triples (values are never moved to equivalents).
    Unknowns(const Approximation& approximation, const Equivalences* equivalences, std::vector<int> columns);
    std::size_t size() const { return columns.size(); }

    std::vector<int> columns;  // per unknown: its parameter, the index of its reference value (minimize's `near`)
    // Only a control's own limits bind; a free one's min..max is just the range it was learned on.
    std::vector<double> lower, upper;
    std::vector<bool> angular;                // in the trust region (SolverOptions::maxAngularStep)
    std::vector<double> period;               // > 0: x and x + period give the same pose (Equivalences::period)
    std::vector<double> defaults;             // the parameters' defaults (an Euler triple's other solution)
    std::vector<std::array<int, 3>> triples;  // unknowns that are Euler angles of one rotation (Equivalences::triples)
};

// What the minimizer needs of a problem: its residuals, and the normal equations J^T J and g = J^T r held
// in the problem's own form (dense, or a block elimination's), with a step solved from them.
class MinimizerProblem {
public:
    virtual ~MinimizerProblem() = default;
    // Residuals r, gradient g and J^T J at x. `atTrial`: x is the point of the last residuals() call, whose rows
    // r holds (a problem may reuse that evaluation). False when r or g is not finite.
    virtual bool linearize(std::span<const double> x, bool atTrial, Eigen::VectorXd& r, Eigen::VectorXd& g) = 0;
    // Residuals at x.
    virtual void residuals(std::span<const double> x, Eigen::VectorXd& r) = 0;
    // J^T J's diagonal entry of a column, and that column held (its row and column made the identity's).
    virtual double diagonal(Eigen::Index column) const = 0;
    virtual void hold(Eigen::Index column) = 0;
    // (J^T J + damping I) delta = -gradient, the `fixed` columns held (their gradient zero). False: no step.
    virtual bool solveStep(const Eigen::VectorXd& gradient, double damping, std::span<const char> fixed,
                           Eigen::VectorXd& delta) = 0;
    // out = J^T J v.
    virtual void multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) = 0;
};

// The loop's vectors, sized once for a problem: a solve allocates nothing.
struct MinimizerState {
    MinimizerState(Eigen::Index rows, Eigen::Index columns);
    std::vector<double> x, trial;  // in: x the start, within the limits; out: the answer
    Eigen::VectorXd r, rTrial, hStep, g, gFree, delta, step;
    Eigen::VectorXd direction;          // the last step solved: a Gauss-Newton step's halvings reuse it
    std::vector<char> fixed;            // per unknown: held at a limit for this step
    std::vector<char> pushedOut;        // per unknown: at a limit a step of this linearization pushed out (held)
    std::vector<double> costs;          // the cost at each iteration's start, where minimize tests for a stall
    std::vector<double> acceptedCosts;  // the cost after each accepted step (the start's first): stationary or not
    // Hints the cache to fetch the vectors (core/prefetch.h).
    void prefetch() const;
};

struct MinimizerResult {
    int gaussNewton = 0;
    int levenbergMarquardt = 0;
    bool converged = false;       // a tolerance was met (whether or not the targets were reached)
    double cost = 0.0;            // 1/2 |r|^2 at the values returned
    double initialCost = 0.0;     // the same at the start
    bool evaluatedAtEnd = false;  // the problem's last evaluation (and state.r) is at the values returned
    // The first step turned some angle further than options.maxAngularStep and was shortened: the linear model at the
    // start did not hold as far as the answer (a long chain's far joints, whose positions are far from linear in the
    // angles of the joints above them).
    bool longFirstStep = false;
    // Given up (GiveUp): the cost above its bounds, and lowered by less than a tenth over the window's iterations.
    bool stalled = false;
};

// When to give a minimization up (stalled, not converged): its cost above both 0.5 targetTolerance^2 and `aboveCost`,
// and lowered by less than a tenth over the last `window` iterations (0: never). A start in another basin, grinding
// against a kink or crawling along a valley, which a caller that would then start afresh leaves
// (Solver::solveOrGiveUp).
struct GiveUp {
    int window = 0;
    double aboveCost = 0.0;
};

// Minimizes 1/2 |r(x)|^2 from state.x (within the limits) within the unknowns' limits: Gauss-Newton then
// Levenberg-Marquardt steps (StepControl, as `policy` says), the columns at a limit whose descent points out held,
// every step shortened whole so that no angle moves more than options.maxAngularStep. Stops on options' tolerances and
// maxIterations. At the end, periodic unknowns and Euler triples are moved to the equivalent values nearest `near`
// (indexed by Unknowns::columns; an Euler flip only where the cost says it is the same pose). `giveUp`: as above.
MinimizerResult minimize(MinimizerProblem& problem, const Unknowns& unknowns, const SolverOptions& options,
                         MinimizerState& state, std::span<const double> near,
                         StepPolicy policy = StepPolicy::approximation(), GiveUp giveUp = {});

}  // namespace rig

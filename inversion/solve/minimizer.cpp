#include "inversion/solve/minimizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/prefetch.h"

namespace rig {
namespace {

// The projected gradient's norm; below gradientTolerance nothing else is done, else the columns at a limit
// whose descent points out are held (state.fixed, state.gFree, J^T J) and `largestDiagonal` is the free
// columns' largest entry of J^T J's diagonal.
double holdAtLimits(MinimizerProblem& problem, const Unknowns& u, const SolverOptions& options, MinimizerState& s,
                    double& largestDiagonal)
{
    const std::size_t n = u.size();
    double projectedGradient = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        const double gc = s.g[static_cast<Eigen::Index>(c)];
        projectedGradient =
            std::max(projectedGradient, std::abs(s.x[c] - clampTo(s.x[c] - gc, u.lower[c], u.upper[c])));
        // At a limit with the descent direction pointing out, or a step of this linearization: held for this step.
        s.fixed[c] = (s.x[c] <= u.lower[c] && gc > 0) || (s.x[c] >= u.upper[c] && gc < 0) || s.pushedOut[c];
    }
    if (projectedGradient <= options.gradientTolerance) return projectedGradient;
    s.gFree = s.g;
    for (std::size_t c = 0; c < n; ++c)
        if (s.fixed[c]) s.gFree[static_cast<Eigen::Index>(c)] = 0.0;
    // Held columns: identity rows and columns (the same set after a rejected step, at the same x and g).
    largestDiagonal = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        const Eigen::Index i = static_cast<Eigen::Index>(c);
        if (!s.fixed[c]) {
            largestDiagonal = std::max(largestDiagonal, problem.diagonal(i));
            continue;
        }
        problem.hold(i);
    }
    return projectedGradient;
}

// The damped step from state.x, times `scale`, within the angular trust region and the limits, into state.trial
// and state.step; false when the system has no solution. `smallStep`: under parameterTolerance. `wholeStep`:
// neither scaled, shortened nor projected. `shortened`: cut to the angular trust region. `repeated`: the trial is the
// last one again (a halving the region cuts back to it), state.trial and state.step left as they were.
bool trialStep(MinimizerProblem& problem, const Unknowns& u, const SolverOptions& options, MinimizerState& s,
               double damping, double scale, bool& smallStep, bool& wholeStep, bool& shortened, bool& repeated)
{
    const std::size_t n = u.size();
    // A Gauss-Newton step backtracked (StepPolicy::backtracks) is the same step halved: x, g and the held columns
    // are those it was solved at.
    if (scale == 1.0 && !problem.solveStep(s.gFree, damping, s.fixed, s.direction)) return false;
    s.delta = scale * s.direction;
    // The rotation trust region (SolverOptions::maxAngularStep): shorten the whole step, keeping its direction.
    double largestTurn = 0.0;
    for (std::size_t c = 0; c < n; ++c)
        if (u.angular[c]) largestTurn = std::max(largestTurn, std::abs(s.delta[static_cast<Eigen::Index>(c)]));
    shortened = largestTurn > options.maxAngularStep;
    if (shortened) s.delta *= options.maxAngularStep / largestTurn;
    // A halved step the region still shortens is the last trial again, to the bit (halving is exact): its cost is
    // known. A foot swung by whole turns: four evaluations of one point before the damped step.
    repeated = shortened && scale < 1.0;
    if (repeated) return true;
    wholeStep = !shortened;
    wholeStep = wholeStep && scale == 1.0;
    // Projection onto the limits; the step actually taken is what the model and tolerances see.
    double stepNorm2 = 0.0, xNorm2 = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        const Eigen::Index i = static_cast<Eigen::Index>(c);
        s.trial[c] = clampTo(s.x[c] + s.delta[i], u.lower[c], u.upper[c]);
        s.step[i] = s.trial[c] - s.x[c];
        wholeStep = wholeStep && s.trial[c] == s.x[c] + s.delta[i];
        stepNorm2 += s.step[i] * s.step[i];
        xNorm2 += s.x[c] * s.x[c];
    }
    smallStep = std::sqrt(stepNorm2) <= options.parameterTolerance * (std::sqrt(xNorm2) + options.parameterTolerance);
    return true;
}

// Columns at a limit that the step solved (state.direction) pushes out, though their gradient does not: held, as
// holdAtLimits holds the others, until the next linearization; returns whether there were any, for the step to be
// solved again. The step then taken is the Gauss-Newton step of the free columns (a projected Newton step), not one the
// limit cuts: a reverse foot's roll at 0, its gradient 0 or pointing in, that the coupled step pushes below 0
// (Grunt_Run's feet) cut every step and, the steps never whole, kept the stop tests of whole steps from ever ending a
// frame.
bool holdPushedOut(MinimizerProblem& problem, const Unknowns& u, MinimizerState& s)
{
    bool any = false;
    for (std::size_t c = 0; c < u.size(); ++c) {
        const double d = s.direction[static_cast<Eigen::Index>(c)];
        if (s.fixed[c] || !((s.x[c] <= u.lower[c] && d < 0) || (s.x[c] >= u.upper[c] && d > 0))) continue;
        s.fixed[c] = s.pushedOut[c] = 1;
        s.gFree[static_cast<Eigen::Index>(c)] = 0.0;
        problem.hold(static_cast<Eigen::Index>(c));
        any = true;
    }
    return any;
}

// Periodic unknowns and Euler triples of state.x moved to the equivalent values nearest `near` where the
// problem's `cost` says they are the same pose. `evaluatedAtX`: whether the problem's last evaluation is at
// state.x; returns whether it still is.
bool keepNear(MinimizerProblem& problem, const Unknowns& u, MinimizerState& s, std::span<const double> near,
              double cost, bool evaluatedAtX)
{
    const std::size_t n = u.size();
    // Of the equivalent values of a periodic control, the one nearest the warm start, so that a solve never
    // adds whole turns (curves stay continuous from frame to frame).
    const auto at = [&](std::size_t c) { return near[static_cast<std::size_t>(u.columns[c])]; };
    const auto wrap = [&](std::size_t c, double x) {
        const double start = at(c);
        if (!(u.period[c] > 0.0) || !std::isfinite(start)) return x;
        // Within half a period of the start (where the remainder is x - start itself) a value is kept as it
        // is: only whole periods are taken off.
        const double d = x - start;
        return std::abs(d) <= 0.5 * u.period[c] ? x : start + std::remainder(d, u.period[c]);
    };
    for (std::size_t c = 0; c < n; ++c) {
        const double wrapped = wrap(c, s.x[c]);
        evaluatedAtX = evaluatedAtX && wrapped == s.x[c];
        s.x[c] = wrapped;
    }
    // And of the two Euler solutions of one pose, the nearer (no flip near gimbal lock, nor through a
    // half turn of all three channels): taken when the problem's cost says it is the same pose.
    for (const auto& triple : u.triples) {
        const auto [a, b, c] = triple;
        const auto half = [&](int i) { return 0.5 * u.period[static_cast<std::size_t>(i)]; };
        std::copy(s.x.begin(), s.x.end(), s.trial.begin());
        const std::size_t ia = static_cast<std::size_t>(a), ib = static_cast<std::size_t>(b),
                          ic = static_cast<std::size_t>(c);
        s.trial[ia] = wrap(ia, s.x[ia] + half(a));
        s.trial[ib] = wrap(ib, 2.0 * u.defaults[ib] + half(b) - s.x[ib]);
        s.trial[ic] = wrap(ic, s.x[ic] + half(c));
        double now = 0.0, other = 0.0;
        for (const std::size_t i : {ia, ib, ic}) {
            now += (s.x[i] - at(i)) * (s.x[i] - at(i));
            other += (s.trial[i] - at(i)) * (s.trial[i] - at(i));
        }
        if (!(other < now)) continue;
        problem.residuals(s.trial, s.rTrial);
        evaluatedAtX = std::abs(0.5 * s.rTrial.squaredNorm() - cost) <= 1e-9 * cost + 1e-12;
        if (evaluatedAtX) {
            std::swap(s.x, s.trial);
            s.r.swap(s.rTrial);
        }
    }
    return evaluatedAtX;
}

// At the start of an iteration (not a halving): records the cost; whether it is above `floor` and more than nine
// tenths of what it was `window` iterations ago.
bool stalls(std::vector<double>& costs, bool iterationStarts, double cost, double floor, int window)
{
    if (!iterationStarts) return false;
    costs.push_back(cost);
    const std::size_t n = costs.size(), w = static_cast<std::size_t>(window);
    return n > w && cost > floor && cost > 0.9 * costs[n - 1 - w];
}

// Ten accepted steps that lowered the cost by at most a millionth of it, above the tolerance: a minimum of the model
// the targets are out of reach of, which damped steps otherwise creep along at a ten-millionth of the cost each to
// maxIterations (a random character's space switch: 100 iterations of one frame).
bool stationary(const std::vector<double>& costs, double cost, double floor)
{
    constexpr std::size_t window = 10;
    const std::size_t n = costs.size();
    return n > window && cost > floor && costs[n - 1 - window] - cost <= 1e-6 * cost;
}

}  // namespace

Unknowns::Unknowns(const Approximation& approximation, const Equivalences* equivalences, std::vector<int> cols)
    : columns(std::move(cols))
{
    constexpr double free = std::numeric_limits<double>::infinity();
    for (const int p : columns) {
        const RigParameter& parameter = approximation.parameters[static_cast<std::size_t>(p)].parameter;
        lower.push_back(parameter.limited ? parameter.min : -free);
        upper.push_back(parameter.limited ? parameter.max : free);
        angular.push_back(parameter.angular);
        period.push_back(equivalences ? equivalences->period[static_cast<std::size_t>(p)] : 0.0);
        defaults.push_back(parameter.defaultValue);
    }
    if (!equivalences) return;
    // The approximation's Euler triples whose three channels are all unknowns here, as unknowns' indices.
    const auto column = [&](int p) {
        const auto it = std::lower_bound(columns.begin(), columns.end(), p);
        return it != columns.end() && *it == p ? static_cast<int>(it - columns.begin()) : -1;
    };
    for (const auto& [a, b, c] : equivalences->triples)
        if (column(a) >= 0 && column(b) >= 0 && column(c) >= 0) triples.push_back({column(a), column(b), column(c)});
}

MinimizerState::MinimizerState(Eigen::Index rows, Eigen::Index columns)
    : x(static_cast<std::size_t>(columns)),
      trial(x.size()),
      r(rows),
      rTrial(rows),
      hStep(columns),
      g(columns),
      gFree(columns),
      delta(columns),
      step(columns),
      direction(columns),
      fixed(x.size(), 0),
      pushedOut(x.size(), 0)
{
}

void MinimizerState::prefetch() const
{
    rig::prefetch(x);
    rig::prefetch(trial);
    rig::prefetch(fixed);
    for (const Eigen::VectorXd* v : {&r, &rTrial, &hStep, &g, &gFree, &delta, &step, &direction})
        prefetchBytes(v->data(), static_cast<std::size_t>(v->size()) * sizeof(double));
}

MinimizerResult minimize(MinimizerProblem& problem, const Unknowns& u, const SolverOptions& o, MinimizerState& s,
                         std::span<const double> near, StepPolicy policy, GiveUp giveUp)
{
    MinimizerResult result;
    s.costs.clear();
    s.acceptedCosts.clear();
    if (giveUp.window > 0) s.costs.reserve(static_cast<std::size_t>(o.maxIterations) + 1);
    s.acceptedCosts.reserve(static_cast<std::size_t>(o.maxIterations) + 1);
    bool finite = problem.linearize(s.x, false, s.r, s.g);
    std::fill(s.pushedOut.begin(), s.pushedOut.end(), 0);
    double cost = 0.5 * s.r.squaredNorm();
    // A cost that overflows (targets 1e160 cm away: finite residuals, an infinite square) compares no step with
    // another: left to run, the damping grows until the steps are negligible and the stop reads as a stationary
    // point (stuck, a best fit). It is a solve that cannot proceed (noConvergence), as non-finite residuals are.
    finite = finite && std::isfinite(cost);
    result.initialCost = cost;
    bool evaluatedAtX = true;
    StepControl control(o, policy);
    // Every target 1e-7 of targetTolerance away at most (its rows' norm is): nothing a further step gains. Along a
    // flat valley of the cost the steps otherwise go on lowering it by more than the function tolerance's fraction
    // until maxIterations (a random character's ikSCsolver foot: frames within 1e-5 cm iterating 100 times).
    const double reachedCost = 0.5 * std::pow(1e-7 * o.targetTolerance, 2);
    // A step that leaves the cost within the tolerance, lowering it by a negligible amount and a small fraction,
    // creeps: where the approximation misses the targets a little, a redundant control otherwise slides along the
    // valley of that miss to maxIterations (an ikSCsolver leg's goal along the leg). Quadratic convergence lowers it by
    // far more.
    const double creepCost = 0.5 * std::pow(o.targetTolerance, 2);
    const double creepDecrease = 0.5 * std::pow(1e-2 * o.targetTolerance, 2);
    // A whole Gauss-Newton step that lands where its linear model said, on a cost the model leaves (its minimum: what
    // no step of the linearization removes) and within the tolerance, is on the floor of the approximation's small
    // miss of targets from the real rig: the next step, from a point the linearization predicted to within a
    // thousandth of the cost, gains about that much, and the solve would form the Jacobian again to find that out
    // (the random characters' IK clips: 3550 iterations, 3314 with the rule). Below floorCost an exact model's
    // quadratic convergence is still under way, and a floor the linearization leaves there is no miss (a long FK
    // chain's step from 1e-4 to 3.4e-13, predicted to 0.24%, went on to 1e-22).
    const double floorCost = creepDecrease;
    constexpr double floorMatch = 1e-3;
    const double stallCost = std::max(0.5 * o.targetTolerance * o.targetTolerance, giveUp.aboveCost);
    double trialCost = cost;
    s.acceptedCosts.push_back(cost);
    while (finite && result.gaussNewton + result.levenbergMarquardt < o.maxIterations) {
        if (giveUp.window > 0 && stalls(s.costs, control.scale() == 1.0, cost, stallCost, giveUp.window)) {
            result.stalled = true;
            break;
        }
        if (cost <= reachedCost) {
            result.converged = true;
            break;
        }
        double largestDiagonal = 0.0;
        if (holdAtLimits(problem, u, o, s, largestDiagonal) <= o.gradientTolerance) {
            result.converged = true;
            break;
        }
        const bool gaussNewton = control.gaussNewton();
        bool smallStep = false, wholeStep = false, shortened = false, repeated = false;
        const auto solveTrial = [&] {
            return trialStep(problem, u, o, s, control.damping(largestDiagonal), control.scale(), smallStep, wholeStep,
                             shortened, repeated);
        };
        bool solved = solveTrial();
        while (solved && control.scale() == 1.0 && holdPushedOut(problem, u, s)) solved = solveTrial();
        if (!solved) break;
        if (result.gaussNewton + result.levenbergMarquardt == 0) result.longFirstStep = shortened;
        // The model's decrease, -(g.s + s^T J^T J s / 2); held columns do not move (s = 0 there).
        const auto predicted = [&] {
            problem.multiply(s.step, s.hStep);
            return -(s.g.dot(s.step) + 0.5 * s.step.dot(s.hStep));
        };
        // An iteration is a step solved; its halvings are its line search, not iterations of their own.
        if (control.scale() == 1.0) (gaussNewton ? result.gaussNewton : result.levenbergMarquardt) += 1;
        // The undamped step whole, the model's minimum: J^T J s = -g makes its decrease -g.s / 2 (half the squared
        // Newton decrement). When that is within the function tolerance, so is any step's, and evaluating it
        // is not worth a residual pass.
        if (gaussNewton && wholeStep && !smallStep) {
            const double model = -0.5 * s.g.dot(s.step);
            if (model >= 0.0 && model <= o.functionTolerance * cost) {
                result.converged = true;
                break;
            }
        }
        if (!repeated) {
            problem.residuals(s.trial, s.rTrial);
            evaluatedAtX = false;
            trialCost = 0.5 * s.rTrial.squaredNorm();
        }
        // The cost the undamped whole step's model predicts: its minimum, the part of the residual no step of the
        // linearization removes.
        const double modelCost = gaussNewton && wholeStep ? cost + 0.5 * s.g.dot(s.step) : -1.0;
        if (control.accept(cost, trialCost, smallStep, predicted)) {
            const double decrease = cost - trialCost;
            std::swap(s.x, s.trial);
            s.r.swap(s.rTrial);
            evaluatedAtX = true;
            cost = trialCost;
            const bool creeping = cost <= creepCost && decrease <= creepDecrease && decrease <= 0.1 * (cost + decrease);
            s.acceptedCosts.push_back(cost);
            const bool floor = modelCost > 0.0 && cost <= creepCost && cost >= floorCost &&
                               std::abs(cost - modelCost) <= floorMatch * cost;
            if (smallStep || decrease <= o.functionTolerance * (cost + decrease) || creeping || floor ||
                stationary(s.acceptedCosts, cost, creepCost)) {
                result.converged = true;
                break;
            }
            finite = problem.linearize(s.x, true, s.r, s.g);
            std::fill(s.pushedOut.begin(), s.pushedOut.end(), 0);
            control.accepted();
        } else if (smallStep) {
            result.converged = true;  // a negligible step that does not help: nothing left to gain
            break;
        } else if (control.exhausted()) {
            break;
        }
    }
    result.evaluatedAtEnd = keepNear(problem, u, s, near, cost, evaluatedAtX);
    result.cost = cost;
    return result;
}

}  // namespace rig

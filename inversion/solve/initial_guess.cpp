// Solver::initialGuess (solver.h): a start found from the approximation's structure, output by output.

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "inversion/solve/solver_impl.h"

namespace rig {
namespace {

// Each angular unknown starts at its value and a third of a turn either way: of three starts a third of a
// turn apart, one lies within a sixth of a turn of any answer, where the cost (1 - cos) is convex enough for
// Gauss-Newton. A limited one starts at the middles of the thirds of its range instead.
void variedStarts(const Approximation& approximation, const BlockPlan& block, const std::vector<int>& columns,
                  std::span<const double> values, std::vector<Varied>& varied)
{
    constexpr std::size_t maxVaried = 4;  // 3^4 starts at most per output
    varied.clear();
    for (std::size_t c = 0; c < columns.size() && varied.size() < maxVaried; ++c) {
        const std::size_t i = static_cast<std::size_t>(columns[c]);
        const RigParameter& p = approximation.parameters[i].parameter;
        if (!p.angular) continue;
        const double v = values[i];
        if (p.limited) {
            const double third = (p.max - p.min) / 3.0;
            varied.push_back({i, {clampTo(v, p.min, p.max), p.min + 0.5 * third, p.max - 0.5 * third}});
        } else {
            const double period = block.unknowns.period[c];
            const double turn = period > 0 ? period : 2.0 * std::numbers::pi;
            varied.push_back({i, {v, v + turn / 3.0, v - turn / 3.0}});
        }
    }
}

// Starts that end at one minimum before the others are left: where a step cannot reach its targets from what the
// steps before it placed (C_Robot_Run.ma's frame solved again from the guess at its warm start), 63 of its 81
// starts ended at the same cost, 2,076 iterations of a 32-parameter solve. Three cut the IK creature's poses
// recovered from the guess from 200 to 197 of 200 (a local minimum three starts share); five kept them.
constexpr int sameMinimumStarts = 9;

}  // namespace

double Solver::Impl::unmovedPositionCost(const BlockPlan& block, std::span<const PreparedTarget> targets,
                                         std::span<const double> values) const
{
    const ResidualStructure& structure = block.structure;
    // Only the built-in terms are known to start with three position rows: any other kind counts as moved.
    const int outputs = static_cast<int>(structure.outputs().size());
    for (int o = 0; o < outputs; ++o)
        if (&structure.term(o) != &jointTargetTerm() && &structure.term(o) != &positionTerm()) return -1.0;
    Borrowed<BlockWorkspace> borrowed(block.pool, [&] { return block.makeWorkspace(); });
    BlockWorkspace& w = *borrowed;
    std::vector<double>& x = w.state.x;
    Eigen::VectorXd& r = w.state.r;
    w.residual.holdParameters(values);
    w.residual.setTargets(targets);
    for (std::size_t c = 0; c < x.size(); ++c) x[c] = values[static_cast<std::size_t>(structure.columns()[c])];
    w.residual.jacobian(x, JacobianMethod::analytic, options.finiteDifferenceStep, false, r, w.J);
    // A rotation about pivot c moves a point p by omega x (p - c): zero for every rotation of the product
    // (at any pose) exactly when every pivot is at p. Rounding aside, which this scale bounds.
    // (The joint target's last three rows are its rotation's.)
    double scale = 1.0;
    for (int o = 0; o < outputs; ++o)
        if (&structure.term(o) == &jointTargetTerm())
            scale = std::max(scale, w.J.middleRows<3>(structure.rowOffset(o) + 3).cwiseAbs().maxCoeff());
    double position = 0.0;
    for (int o = 0; o < outputs; ++o) {
        const Eigen::Index row = structure.rowOffset(o);
        if (w.J.middleRows<3>(row).cwiseAbs().maxCoeff() > 1e-9 * scale) return -1.0;
        position += 0.5 * r.segment<3>(row).squaredNorm();
    }
    return position;
}

TerminationType Solver::initialGuess(std::span<const JointTarget> targets, std::span<double> values) const
{
    Impl& impl = *impl_;
    Borrowed<SolveScratch> scratch(impl.scratchPool, [] { return std::make_unique<SolveScratch>(); });
    std::shared_ptr<const Plan> plan;
    TerminationType termination;
    if (!impl.prepare(targets, values, *scratch, plan, termination)) return termination;

    std::vector<double>& trial = scratch->trial;
    std::vector<double>& best = scratch->best;
    // Outside the step's columns, trial is values throughout: a start resets only the step's columns (a
    // crowd's guess stays linear in its size).
    trial.assign(values.begin(), values.end());
    best.resize(values.size());
    // An output is reached when its residual is within targetTolerance: the solve after the guess polishes it. A
    // thousandth of it was not reached where the approximation misses the real rig's targets a little, and every
    // start was tried (a random character's orient-constrained hands: 1,700 iterations a cold frame); a tenth of it,
    // at some retried frames (the same hands: 2.6e-4 cm at best, all 81 starts of an 11-parameter step).
    const double reachedCost = 0.5 * std::pow(impl.options.targetTolerance, 2);
    std::vector<char> placed(impl.approximation.constraints.size(), 0);
    for (const auto& step : plan->guessSteps(impl.approximation, *impl.equivalences)) {
        const BlockPlan& block = step->plan;
        const std::vector<int>& columns = step->block.parameters;
        // A planar chain's first output: its goal and pole from its end and middle joints' targets (closed form),
        // its anchor guessed already (parents first), by the controls this step fixes first.
        for (const int k : step->block.outputs) {
            const int b = impl.approximation.outputs[static_cast<std::size_t>(k)].constraint;
            if (b < 0 || placed[static_cast<std::size_t>(b)] ||
                impl.approximation.constraints[static_cast<std::size_t>(b)].kind != ConstraintKind::planarChain)
                continue;
            placeChain(impl.approximation, b, impl.poles, targets, step->own, values);
            for (std::size_t c = 0; c < impl.approximation.constraints.size(); ++c)
                placed[c] = placed[c] || impl.approximation.constraints[c].goal ==
                                             impl.approximation.constraints[static_cast<std::size_t>(b)].goal;
            for (std::size_t p = 0; p < values.size(); ++p) trial[p] = values[p];
        }
        // Rotations that cannot move the output's position (every pivot at the joint, as a joint's own
        // rotate channels): its position cost is the same from every start, and a start that reaches the
        // target's rotation is as good as any. Found once a start has missed (a warm or reachable frame's first
        // start mostly reaches, and the test forms the block's Jacobian).
        std::optional<double> floorCost;
        const auto floor = [&] {
            if (!floorCost)
                floorCost = block.rotationsOnly ? impl.unmovedPositionCost(block, scratch->prepared, values) : -1.0;
            return *floorCost;
        };
        variedStarts(impl.approximation, block, columns, values, scratch->varied);
        int starts = 1;
        for (std::size_t i = 0; i < scratch->varied.size(); ++i) starts *= 3;
        // Of the starts' answers, the cheapest; of those as cheap to rounding (another pose the joint's
        // controls reach equally well), the nearest the values given.
        double bestCost = std::numeric_limits<double>::infinity(), bestDistance = 0.0;
        int atBest = 0;  // starts that ended at the best cost so far, to the solve's rounding
        for (int start = 0; start < starts; ++start) {
            for (const int p : columns) trial[static_cast<std::size_t>(p)] = values[static_cast<std::size_t>(p)];
            int code = start;
            for (const Varied& v : scratch->varied) {
                trial[v.parameter] = v.starts[static_cast<std::size_t>(code % 3)];
                code /= 3;
            }
            const MinimizerResult r = impl.solveBlock(block, scratch->prepared, trial, false, values);
            double distance = 0.0;
            for (const int p : columns) {
                const std::size_t i = static_cast<std::size_t>(p);
                distance += (trial[i] - values[i]) * (trial[i] - values[i]);
            }
            if (std::isfinite(r.cost)) {
                const double same = 1e-6 * r.cost + reachedCost;
                atBest = r.cost < bestCost - same ? 1 : atBest + (std::abs(r.cost - bestCost) <= same ? 1 : 0);
            }
            const double slack = 1e-9 * std::min(r.cost, bestCost) + 1e-12;
            const bool cheaper = r.cost < bestCost - slack;
            const bool asCheapAndNearer = r.cost <= bestCost + slack && distance < bestDistance;
            if (cheaper || asCheapAndNearer) {
                bestCost = std::min(r.cost, bestCost);
                bestDistance = distance;
                for (const int p : columns) best[static_cast<std::size_t>(p)] = trial[static_cast<std::size_t>(p)];
            }
            // The earliest start that reaches it: the nearest the values given. The floor is reached within
            // what the solve converges to: its stop tests leave up to functionTolerance of the cost. A minimum that
            // sameMinimumStarts starts ended at is the step's, reached or not.
            if (bestCost <= reachedCost || atBest >= sameMinimumStarts) break;
            if (const double f = floor();
                f >= 0.0 && bestCost <= f * (1.0 + impl.options.functionTolerance) + reachedCost)
                break;
        }
        // No start gave a finite cost: these parameters are left alone. Else the best, which solveBlock kept
        // nearest the values given (whole turns, Euler triples).
        const bool found = std::isfinite(bestCost);
        for (const int p : columns) {
            const std::size_t i = static_cast<std::size_t>(p);
            if (found) values[i] = best[i];
            trial[i] = values[i];
        }
    }
    return TerminationType::converged;
}

}  // namespace rig

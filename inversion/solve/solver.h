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
#include "inversion/solve/equivalences.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/minimizer.h"
#include "inversion/solve/partition.h"
#include "inversion/solve/solver_options.h"

namespace rig {

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
    // solve() that gives up a block whose cost, above 0.5 targetTolerance^2 and `aboveCost`, fell by less than a tenth
    // over ten iterations (SolveSummary::stalled, noConvergence): a warm start in another basin, for a caller that
    // starts afresh at such a cost, and goes on from where it stopped if that does no better (solveChainFrame).
    void solveOrGiveUp(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary,
                       double aboveCost) const;

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
    // The approximation's equivalent values (inversion/solve/equivalences.h), made once with the solver.
    const Equivalences& equivalences() const;
    // The partition a solve with these targets uses (built once per set of counted rows, then cached).
    Partition partition(std::span<const JointTarget> targets) const;
    // Builds what solves with these targets' counted rows use and would otherwise build at the first of them: the
    // plan (partition, blocks, coupled trees) and the initial guess's steps. A caller that times its frames
    // (invertClip) calls it first, so that the one-time setup is not counted as a frame's.
    void prepare(std::span<const JointTarget> targets) const;

    struct Impl;  // the solver's state and plans (inversion/solve/solver_impl.h, internal)

private:
    void solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary, bool cold,
               GiveUp giveUp = {}) const;
    std::unique_ptr<Impl> impl_;
};

}  // namespace rig

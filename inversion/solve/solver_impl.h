#pragma once
// Solver's state (internal to solver.cpp and initial_guess.cpp): options, the equivalences, the plans cached
// per set of counted rows, and the pools of per-solve scratch.

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <oneapi/tbb/task_arena.h>

#include "inversion/solve/pole_hold.h"
#include "inversion/solve/solve_plan.h"
#include "inversion/solve/solver.h"
#include "inversion/solve/switch_hold.h"

namespace rig {

struct Solver::Impl {
    Impl(const Approximation& a, SolverOptions o)
        : approximation(a),
          options(o),
          poles(poleHolds(a)),
          goals(goalHolds(a)),
          aims(aimHolds(a)),
          switches(switchHolds(a))
    {
    }

    const Approximation& approximation;
    SolverOptions options;
    std::vector<PoleHold> poles;               // the planar chains' poles held where the joints do not decide them
    std::vector<GoalHold> goals;               // rigid chains' goals held inside their reach
    std::vector<AimHold> aims;                 // aims' targets held at their distance along the line of sight
    std::vector<SwitchHold> switches;          // a switch's inactive branch held at the warm start
    std::optional<Equivalences> equivalences;  // made once the approximation is checked (Solver's constructor)
    std::optional<tbb::task_arena> arena;
    Pool<SolveScratch> scratchPool;
    std::mutex plansMutex;
    std::map<std::string, std::shared_ptr<const Plan>, std::less<>> plans;

    // The plan of a set of counted rows (one entry per output), cached by `key` (scratch for the rows as a key).
    std::shared_ptr<const Plan> plan(const std::vector<unsigned char>& rows, std::string& key);
    // The plan of the targets' counted rows (Solver::partition, Solver::prepare: `caller` names it in the error).
    std::shared_ptr<const Plan> planFor(std::span<const JointTarget> targets, const char* caller);
    // `reference` (one value per parameter; empty: `values` as given) is what periodic controls and Euler
    // triples are kept nearest to.
    MinimizerResult solveBlock(const BlockPlan& block, std::span<const PreparedTarget> targets,
                               std::span<double> values, bool parallel, std::span<const double> reference = {},
                               GiveUp giveUp = {}) const;
    // The same in a workspace of block.pool that the caller borrowed, and can read after.
    MinimizerResult solveBlock(const BlockPlan& block, BlockWorkspace& w, std::span<const PreparedTarget> targets,
                               std::span<double> values, bool parallel, std::span<const double> reference = {},
                               GiveUp giveUp = {}) const;
    // Prepares the targets and finds their plan; false (with the termination) when there is nothing to solve.
    bool prepare(std::span<const JointTarget> targets, std::span<const double> values, SolveScratch& scratch,
                 std::shared_ptr<const Plan>& plan, TerminationType& termination);
    // For a block of rotations only: the position part of its cost at `values` when no parameter of the
    // block moves any of its outputs' positions (all pivots at the outputs), else -1.
    double unmovedPositionCost(const BlockPlan& block, std::span<const PreparedTarget> targets,
                               std::span<const double> values) const;
};

}  // namespace rig

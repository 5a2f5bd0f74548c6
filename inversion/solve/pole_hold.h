#pragma once
// What the joints cannot determine of a planar chain (inversion/model/constraint.h): its pole's distance from the chain
// and its place along it. Only the plane through the root, the goal and the pole counts, so a solve's minimum-norm
// steps leave those directions where the warm start had them, and the plane's turns push the pole further out
// frame after frame (the biped's pole control went 118 m out over CMU 01_01). After each solve the pole's own
// controls are set so that the pole sits in the plane found, at its rest offset along the chain's line and its rest
// distance from it: the joints are the same, the pole never drifts, and it is reported as held (docs/solver.md).

#include <span>
#include <vector>

#include <Eigen/Core>

#include "inversion/model/approximation.h"
#include "inversion/solve/jacobian.h"

namespace rig {

struct PoleHold {
    int constraint = -1;          // one of the constraints that read the pole (they share its root and goal)
    std::vector<int> parameters;  // the pole's own controls: translations that move the pole's helper alone
    double along = 0.0;           // the pole's rest offset along the chain's line from the root, cm
    double across = 0.0;          // and its rest distance from that line, cm
};

// A hold per pole helper whose own controls are translations moving nothing else; none where the pole is fixed to
// the anchor or moved by anything else too.
std::vector<PoleHold> poleHolds(const Approximation& approximation);

// A cold start for a planar chain (Solver::initialGuess), before its first output is guessed: the goal's own
// translation controls put the goal where the chain's end joint's target says (with its rest offset from that
// joint), and the pole's (when held) in the plane of the middle joint's target, at its rest offset and distance.
// `targets`: one per approximation output; inactive ones give nothing. Only the controls in `free` (increasing: the
// parameters the guess step fixes first, GuessStep::own) move: the others were fixed by outputs guessed before (the
// foot control over a ball's ikSCsolver goal, which the leg's step placed and a placement of the ball's chain took
// away from the leg's targets).
void placeChain(const Approximation& approximation, int constraint, std::span<const PoleHold> holds,
                std::span<const JointTarget> targets, std::span<const int> free, std::span<double> values);

// Moves each hold's controls in `values` (one per approximation parameter) so that its pole sits at its rest
// offset and distance in the plane it spans now. Evaluates only the outputs the chain reads.
void holdPoles(const Approximation& approximation, std::span<const PoleHold> holds, std::span<double> values);

// A rigid chain's goal past its reach (docs/solver.md, goal holds). Where the chain cannot stretch, its shape is the
// same for every reach past the one where it straightens: the joints cannot tell how far past that the goal is, and
// there no step can bring the goal back (the shape's slope is zero), so a solve that takes the goal out leaves the
// chain straight where its targets bend it. The goal is held on the inside of the reach where the shape flattens.
struct GoalHold {
    int constraint = -1;          // one of the constraints that read the goal (they share its root)
    std::vector<int> parameters;  // the goal's own controls: translations that move the goal's helper alone
    double flatReach = 0.0;       // the root-goal distance from which every output of the goal's chains stays put, cm
};

// A hold per goal helper whose own controls are translations moving nothing else and whose chains' shapes all end
// flat over the last knots (a chain without stretch); none for a goal no chain holds still past some reach.
std::vector<GoalHold> goalHolds(const Approximation& approximation);

// Moves each hold's goal whose root-goal distance is past its flatReach back inside it: where the chain's end target
// puts it (with its rest offset from the end, as placeChain does) when that lies inside the flat reach by more than a
// 1e-4 share of the rest reach (a bent target), else along the chain's line to just inside the flat reach, where the
// shape's slope is the bend's (the joints move by under 1e-6 cm). True when a goal moved.
bool holdGoals(const Approximation& approximation, std::span<const GoalHold> holds,
               std::span<const JointTarget> targets, std::span<double> values);

// An aim's target (a planar chain whose shape never changes: docs/rig-learn.md, aims): only its direction from the
// aimed joint counts, so its distance along the line of sight is not identifiable. A solve's minimum-norm steps move
// the target across the line as the aim turns, frame after frame further out (a look-at control went 548 m down the eye
// line); the target is held at the distance it had when the solve started, the joints unchanged.
struct AimHold {
    int constraint = -1;          // one of the aims that read the target (they share its root)
    std::vector<int> parameters;  // the target's own controls: translations that move the target's helper alone
};

// A hold per target helper read only by aims from one point (one eye: two eyes on one target fix its distance);
// none where the target has no own translation controls.
std::vector<AimHold> aimHolds(const Approximation& approximation);

// Each hold's target distance from its aim's root at `values`, into `reaches` (one per hold).
void aimReaches(const Approximation& approximation, std::span<const AimHold> holds, std::span<const double> values,
                std::vector<double>& reaches);

// Moves each hold's target along its line of sight to the distance in `reaches`.
void holdAims(const Approximation& approximation, std::span<const AimHold> holds, std::span<const double> reaches,
              std::span<double> values);

}  // namespace rig

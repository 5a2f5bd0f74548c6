#pragma once
// Animated switches in a solve (docs/solver.md): what the targets cannot decide of a switch's blends
// (inversion/learn/blend_merge.h makes them) while its weight sits at a branch.

#include <vector>

#include "inversion/model/approximation.h"

namespace rig {

// What the targets cannot decide of a switch at a branch: with its weight at 1 the FK branch's own controls (those
// that reach joints only through the FK copies of its blends) move no joint, and at 0 the IK branch's. A solve leaves
// them at its warm start (Solver::solve), as pole_hold.h holds a chain's pole: minimum-norm steps would otherwise move
// them by rounding whenever the weight left its limit by a rounding error.
struct SwitchHold {
    int weight = -1;           // index into Approximation::parameters
    std::vector<int> fk;       // the FK branch's own controls: held while the weight is 1
    std::vector<int> ik;       // the IK branch's: held while it is 0
    std::vector<int> outputs;  // what the weight moves (Approximation::reach): a solve missing one tries the other
                               // branch (Solver::solve)
};
// One per blend weight that has such controls.
std::vector<SwitchHold> switchHolds(const Approximation& approximation);

}  // namespace rig

#pragma once
// Animated switches' approximation from their two branches (docs/rig-learn.md, Blends): the rig learned with every
// switch held at 1 (the IK branch) and at 0 (the FK branch), merged into one approximation whose switched outputs are
// blends (constraint.h, BlendRule) of their two branch copies by their switch's weight, a parameter.
//
// Every output keeps the IK branch's modelling, but a switched output, which becomes a blend reading two helper
// copies of it, NAME@ik (its IK-branch modelling, its inputs the IK copies of switched outputs) and NAME@fk (the FK
// branch's). Outputs found only in one branch (the IK goal and pole helpers) are added as they are. Parameters are the
// union by name, in an order that keeps both branches' orders; each one's operators on a switched output act on that
// branch's copy; the weights come last.

#include <map>
#include <string>
#include <vector>

#include "inversion/model/approximation.h"
#include "inversion/model/constraint.h"

namespace rig {

struct SwitchBranches {
    const Approximation* ik = nullptr;  // learned with every switch held at 1
    const Approximation* fk = nullptr;  // and at 0, with the same outputs
    std::vector<RigParameter> weights;  // the switches, each limited to [0, 1]
    // The switched outputs (the joints whose channels a switch blends), each with its parent joint among the
    // outputs ("" for none), the blend the rig does there (fitBlendRule) and its switch (an index into `weights`).
    struct Switched {
        std::string output, parent;
        BlendRule rule;
        int weight = 0;
    };
    std::vector<Switched> switched;
};

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

// The rig output a blend's branch copy stands for ("LeftUpLeg" for "LeftUpLeg@ik" or "LeftUpLeg@fk"); any other name
// as it is. A copy is never a target, and the real rig has no such joint: rig-invert reads the joint in its place.
std::string rigOutputName(const std::string& name);

// The merged approximation, its held plugs the IK branch's but the weights, the parameters either branch discarded
// and the merge does not model discarded. A switched output a branch leaves unmodelled (no helper frames, so no IK
// chain) is not blended: it stays the IK branch's, not modelled, and its switch and the FK controls that move it
// move it on the real rig only (ModelledParameter::unmodelledOutputs). Its fingerprint is the IK branch's (the caller
// sets the fingerprint of the rig with the weights as parameters). Throws a userInput rig::Error naming what does not
// merge (an output missing from a branch, a switched output in neither, parameters ordered differently by the two
// branches, a weight not limited to [0, 1]).
Approximation mergeSwitchBranches(const SwitchBranches& branches);

}  // namespace rig

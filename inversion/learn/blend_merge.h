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

// The merged approximation, its held plugs the IK branch's but the weights, the parameters either branch discarded
// and the merge does not model discarded. A switched output a branch leaves unmodelled (no helper frames, so no IK
// chain) is not blended: it stays the IK branch's, not modelled, and its switch and the FK controls that move it
// move it on the real rig only (ModelledParameter::unmodelledOutputs). Its fingerprint is the IK branch's (the caller
// sets the fingerprint of the rig with the weights as parameters). Throws a userInput rig::Error naming what does not
// merge (an output missing from a branch, a switched output in neither, parameters ordered differently by the two
// branches, a weight not limited to [0, 1]).
Approximation mergeSwitchBranches(const SwitchBranches& branches);

}  // namespace rig

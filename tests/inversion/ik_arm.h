#pragma once
// A small IK rig whose joints below the clavicle do not compose (per-output modelling, the hybrid solve, and
// rig-learn's report of what it leaves unmodelled): tests/inversion/clip/hybrid_solve_test.cpp,
// tests/inversion/learn/learner_test.cpp, tests/tools/rig_learn_test.cpp.

#include <string>

#include "adapter/graph_rig_function.h"

namespace rig::test {

// A two-bone IK arm under a translating root: the goal and the pole control in world space, the rest chain
// pre-bent 0.01 cm toward the pole (a bend plane of its own), the rest goal within reach.
inline const std::string ikArm = R"(nodes:
  - {name: root_ctrl, type: transform, translate: [0, 140, 0]}
  - {name: clavicle, type: joint, parent: root_ctrl, translate: [5, 0, 0]}
  - {name: shoulder, type: joint, parent: clavicle, translate: [15, 0, 0]}
  - {name: elbow, type: joint, parent: shoulder}
  - {name: wrist, type: joint, parent: elbow}
  - {name: arm_ik_ctrl, type: transform, translate: [65, 130, 0]}
  - {name: arm_pole_ctrl, type: transform, translate: [45, 140, -40]}
  - {name: arm_ik, type: ikHandle, startTranslate: [15, 0, 0], midTranslate: [30, 0, 0], endTranslate: [28, 0, -0.01]}
  - {name: arm_pv, type: poleVectorConstraint, constraintRotatePivot: [15, 0, 0]}
connections:
  - clavicle.worldMatrix -> arm_ik.startParentMatrix
  - clavicle.scale -> arm_ik.startInverseScale
  - arm_ik_ctrl.worldMatrix -> arm_ik.goalMatrix
  - arm_pole_ctrl.worldMatrix -> arm_pv.targetMatrix[0]
  - clavicle.worldMatrix -> arm_pv.pivotSpace
  - arm_pv.constraintTranslate -> arm_ik.poleVector
  - arm_ik.startRotate -> shoulder.rotate
  - arm_ik.midRotate -> elbow.rotate
  - arm_ik.outMidTranslate -> elbow.translate
  - arm_ik.outEndTranslate -> wrist.translate
)";

inline GraphRigOptions ikArmOptions()
{
    return {{"root_ctrl.translate?", "arm_ik_ctrl.translate?", "arm_pole_ctrl.translate?"},
            {"clavicle", "shoulder", "elbow", "wrist"},
            {},
            {}};
}

// The same parameters and outputs as rig-learn flags.
inline const std::string ikArmFlags =
    "--params 'root_ctrl.translate?' 'arm_ik_ctrl.translate?' 'arm_pole_ctrl.translate?' --outputs clavicle "
    "shoulder elbow wrist";

}  // namespace rig::test

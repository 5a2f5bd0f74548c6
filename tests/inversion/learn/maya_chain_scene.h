#pragma once
// The wiring of a two-bone Maya chain j1 -> j2 -> j3 as Maya saves it (tests of the learner's chain inputs): an
// ikRPsolver handle "ikHandle1" on effector1, its pole vector constrained to pole_ctrl, and j1 point-constrained
// to shoulder_ctrl, the constraints reading their targets' translate, pivots and parent matrix apart. A scene
// declares the joints, the effector, the handle and the controls, then appends this (or only the chain's own wiring,
// mayaIkWiring, for a handle without constraints).

#include <string>

namespace rig::test {

// The chain's own wiring: scale compensation down the chain, the effector on j3, the handle on j1 and effector1,
// solved by a node "ikRPsolver" (which a scene creates).
inline const std::string mayaIkWiring = R"(connectAttr "j1.s" "j2.is";
connectAttr "j2.s" "j3.is";
connectAttr "j3.tx" "effector1.tx";
connectAttr "j3.ty" "effector1.ty";
connectAttr "j3.tz" "effector1.tz";
connectAttr "j1.msg" "ikHandle1.hsj";
connectAttr "effector1.hp" "ikHandle1.hee";
connectAttr "ikRPsolver.msg" "ikHandle1.hsv";
)";

inline const std::string mayaChainConnections = R"(createNode poleVectorConstraint -n "pv1" -p "ikHandle1";
	addAttr -ci true -k true -sn "w0" -ln "pole_ctrlW0" -dv 1 -min 0 -at "double";
	setAttr -k on ".w0";
createNode pointConstraint -n "pc1" -p "j1";
	addAttr -ci true -k true -sn "w0" -ln "shoulder_ctrlW0" -dv 1 -min 0 -at "double";
	setAttr -k on ".w0";
createNode ikRPsolver -n "ikRPsolver";
connectAttr "root_jnt.s" "j1.is";
)" + mayaIkWiring + R"(connectAttr "pv1.ctx" "ikHandle1.pvx";
connectAttr "pv1.cty" "ikHandle1.pvy";
connectAttr "pv1.ctz" "ikHandle1.pvz";
connectAttr "ikHandle1.pim" "pv1.cpim";
connectAttr "j1.pm" "pv1.ps";
connectAttr "j1.t" "pv1.crp";
connectAttr "pole_ctrl.t" "pv1.tg[0].tt";
connectAttr "pole_ctrl.rp" "pv1.tg[0].trp";
connectAttr "pole_ctrl.rpt" "pv1.tg[0].trt";
connectAttr "pole_ctrl.pm" "pv1.tg[0].tpm";
connectAttr "pv1.w0" "pv1.tg[0].tw";
connectAttr "pc1.ctx" "j1.tx";
connectAttr "pc1.cty" "j1.ty";
connectAttr "pc1.ctz" "j1.tz";
connectAttr "j1.pim" "pc1.cpim";
connectAttr "j1.rp" "pc1.crp";
connectAttr "j1.rpt" "pc1.crt";
connectAttr "shoulder_ctrl.t" "pc1.tg[0].tt";
connectAttr "shoulder_ctrl.rp" "pc1.tg[0].trp";
connectAttr "shoulder_ctrl.rpt" "pc1.tg[0].trt";
connectAttr "shoulder_ctrl.pm" "pc1.tg[0].tpm";
connectAttr "pc1.w0" "pc1.tg[0].tw";
)";

}  // namespace rig::test

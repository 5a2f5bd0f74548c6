//Maya ASCII 2018 scene
//Name: arm_keyed.ma
//Codeset: UTF-8
// A three-joint arm and its animation in one scene: time curves on its controls, as a rig scene an animator keyed
// in place (the project's own test scene, tests/tools/maya_clip_test.cpp).
requires maya "2018";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "arm_rig";
createNode transform -n "root_ctrl" -p "arm_rig";
createNode joint -n "shoulder_jnt" -p "root_ctrl";
	setAttr ".t" -type "double3" 0 150 0 ;
createNode joint -n "elbow_jnt" -p "shoulder_jnt";
	setAttr ".t" -type "double3" 30 0 0 ;
	setAttr ".jo" -type "double3" 0 0 10 ;
createNode joint -n "wrist_jnt" -p "elbow_jnt";
	setAttr ".t" -type "double3" 25 0 0 ;
createNode transform -n "shoulder_ctrl" -p "arm_rig";
createNode transform -n "elbow_ctrl" -p "arm_rig";
createNode animCurveTL -n "root_ctrl_translateX";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 0 10 8 20 -5;
createNode animCurveTA -n "shoulder_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 -20 12 35 20 0;
createNode animCurveTA -n "elbow_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 2 ".ktv[0:1]"  1 20 20 75;
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 20 -ast 1 -aet 20 ";
	setAttr ".st" 6;
connectAttr "shoulder_ctrl.r" "shoulder_jnt.r";
connectAttr "elbow_ctrl.rz" "elbow_jnt.rz";
connectAttr "root_ctrl_translateX.o" "root_ctrl.tx";
connectAttr "shoulder_ctrl_rotateZ.o" "shoulder_ctrl.rz";
connectAttr "elbow_ctrl_rotateZ.o" "elbow_ctrl.rz";
// End of arm_keyed.ma

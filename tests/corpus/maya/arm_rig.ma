//Maya ASCII 2018 scene
//Name: arm_rig.ma
//Codeset: UTF-8
// A three-joint arm whose controls drive its joints, in metres: the rig that arm_anim.ma references (the project's
// own test scene, tests/tools/maya_clip_test.cpp).
requires maya "2018";
currentUnit -l meter -a degree -t film;
createNode transform -n "arm_rig";
createNode transform -n "root_ctrl" -p "arm_rig";
createNode joint -n "shoulder_jnt" -p "root_ctrl";
	setAttr ".t" -type "double3" 0 1.5 0 ;
createNode joint -n "elbow_jnt" -p "shoulder_jnt";
	setAttr ".t" -type "double3" 0.3 0 0 ;
	setAttr ".jo" -type "double3" 0 0 10 ;
createNode joint -n "wrist_jnt" -p "elbow_jnt";
	setAttr ".t" -type "double3" 0.25 0 0 ;
createNode transform -n "shoulder_ctrl" -p "arm_rig";
createNode transform -n "elbow_ctrl" -p "arm_rig";
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 24 -ast 1 -aet 24 ";
	setAttr ".st" 6;
connectAttr "shoulder_ctrl.r" "shoulder_jnt.r";
connectAttr "elbow_ctrl.rz" "elbow_jnt.rz";
// End of arm_rig.ma

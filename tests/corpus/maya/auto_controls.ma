//Maya ASCII 2023 scene
//Name: auto_controls.ma
//Written for rig-learn --params auto's tests (docs/rig-learn.md): a control with a nurbsCurve shape, locked and
//non-keyable channels, a channel that moves nothing, a switch, a set-driven key, a joint keyed by a time curve,
//a skinCluster that binds two of the three joints, and a curve control that reaches no joint.
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "rig";
createNode transform -n "arm_ctrl" -p "rig";
	addAttr -ci true -k true -sn "bend" -ln "bend" -at "double";
	addAttr -ci true -sn "mode" -ln "mode" -min 0 -max 1 -en "fk:ik" -at "enum";
	addAttr -ci true -k true -sn "twist" -ln "twist" -at "double";
	addAttr -ci true -k true -sn "label" -ln "label" -min 0 -max 0 -en "arm" -at "enum";
	setAttr -l on ".tx";
	setAttr -k off ".sx";
	setAttr -k on ".mode" 1;
createNode nurbsCurve -n "arm_ctrlShape" -p "arm_ctrl";
	setAttr -k off ".v";
createNode nurbsCurve -n "arm_ctrlShapeOrig" -p "arm_ctrl";
	setAttr ".io" yes;
createNode joint -n "shoulder" -p "arm_ctrl";
createNode joint -n "elbow" -p "shoulder";
	setAttr ".t" -type "double3" 10 0 0 ;
createNode joint -n "tip" -p "elbow";
	setAttr ".t" -type "double3" 10 0 0 ;
createNode transform -n "prop_ctrl" -p "rig";
createNode nurbsCurve -n "prop_ctrlShape" -p "prop_ctrl";
createNode animCurveTA -n "elbow_rotateZ";
	setAttr ".tan" 18;
	setAttr -s 2 ".ktv[0:1]"  0 30 24 60;
createNode animCurveUA -n "twist_sdk";
	setAttr -s 2 ".ktv[0:1]"  0 0 10 90;
createNode skinCluster -n "skin1";
connectAttr "elbow_rotateZ.o" "elbow.rz";
connectAttr "arm_ctrl.twist" "twist_sdk.i";
connectAttr "twist_sdk.o" "elbow.ry";
connectAttr "shoulder.wm" "skin1.ma[0]";
connectAttr "elbow.wm" "skin1.ma[1]";
// End of auto_controls.ma

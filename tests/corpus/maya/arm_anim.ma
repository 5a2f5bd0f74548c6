//Maya ASCII 2018 scene
//Name: arm_anim.ma
//Codeset: UTF-8
// An animation of arm_rig.ma, referenced under the namespace "hero", its curves on the rig's controls through the
// reference node's placeholders, as Maya writes them; in centimetres and at 30 fps where the rig is in metres.
file -rdi 1 -ns "hero" -rfn "heroRN" "arm_rig.ma";
file -r -ns "hero" -dr 1 -rfn "heroRN" "arm_rig.ma";
requires maya "2018";
currentUnit -l centimeter -a degree -t ntsc;
createNode reference -n "heroRN";
	setAttr ".ed" -type "dataReferenceEdits" 
		"heroRN"
		"heroRN" 5
		5 4 "heroRN" "|hero:arm_rig|hero:root_ctrl.translateX" "heroRN.placeHolderList[1]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:root_ctrl.translateY" "heroRN.placeHolderList[2]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:shoulder_ctrl.rotateX" "heroRN.placeHolderList[3]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:shoulder_ctrl.rotateZ" "heroRN.placeHolderList[4]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:elbow_ctrl.rotateZ" "heroRN.placeHolderList[5]" 
		"";
createNode animCurveTL -n "root_ctrl_translateX";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 0 6 12.5 12 -4;
createNode animCurveTL -n "root_ctrl_translateY";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 2 ".ktv[0:1]"  1 2 12 -3;
createNode animCurveTA -n "shoulder_ctrl_rotateX";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 -10 7 25 12 5;
createNode animCurveTA -n "shoulder_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 4 ".ktv[0:3]"  1 20 4 -15 9 30 12 10;
createNode animCurveTA -n "elbow_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 15 6 70 12 30;
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 12 -ast 1 -aet 12 ";
	setAttr ".st" 6;
select -ne :time1;
	setAttr ".o" 1;
connectAttr "root_ctrl_translateX.o" "heroRN.phl[1]";
connectAttr "root_ctrl_translateY.o" "heroRN.phl[2]";
connectAttr "shoulder_ctrl_rotateX.o" "heroRN.phl[3]";
connectAttr "shoulder_ctrl_rotateZ.o" "heroRN.phl[4]";
connectAttr "elbow_ctrl_rotateZ.o" "heroRN.phl[5]";
// End of arm_anim.ma

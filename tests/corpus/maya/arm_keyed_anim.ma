//Maya ASCII 2018 scene
//Name: arm_keyed_anim.ma
//Codeset: UTF-8
// An animation of arm_keyed.ma, referenced under the namespace "hero": the rig's own curves disconnected by reference
// edits (attributes by their long names, where the rig's connectAttr wrote short ones) and curves of this scene's
// connected through the placeholders instead, as Maya writes them.
file -rdi 1 -ns "hero" -rfn "heroRN" "arm_keyed.ma";
file -r -ns "hero" -dr 1 -rfn "heroRN" "arm_keyed.ma";
requires maya "2018";
currentUnit -l centimeter -a degree -t film;
createNode reference -n "heroRN";
	setAttr ".ed" -type "dataReferenceEdits" 
		"heroRN"
		"heroRN" 6
		4 "hero:root_ctrl_translateX.output" "|hero:arm_rig|hero:root_ctrl.translateX" 
		""
		4 "hero:shoulder_ctrl_rotateZ.output" "|hero:arm_rig|hero:shoulder_ctrl.rotateZ" 
		""
		4 "hero:elbow_ctrl_rotateZ.output" "|hero:arm_rig|hero:elbow_ctrl.rotateZ" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:root_ctrl.translateX" "heroRN.placeHolderList[1]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:shoulder_ctrl.rotateZ" "heroRN.placeHolderList[2]" 
		""
		5 4 "heroRN" "|hero:arm_rig|hero:elbow_ctrl.rotateZ" "heroRN.placeHolderList[3]" 
		"";
createNode animCurveTL -n "root_ctrl_translateX";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 2 ".ktv[0:1]"  1 -6 20 12;
createNode animCurveTA -n "shoulder_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 40 8 -10 20 25;
createNode animCurveTA -n "elbow_ctrl_rotateZ";
	setAttr ".tan" 18;
	setAttr ".wgt" no;
	setAttr -s 3 ".ktv[0:2]"  1 60 10 5 20 45;
connectAttr "root_ctrl_translateX.o" "heroRN.phl[1]";
connectAttr "shoulder_ctrl_rotateZ.o" "heroRN.phl[2]";
connectAttr "elbow_ctrl_rotateZ.o" "heroRN.phl[3]";
// End of arm_keyed_anim.ma

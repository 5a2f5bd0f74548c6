//Maya ASCII 2018 scene
// A playback range of a billion frames.
requires maya "2018";
currentUnit -l centimeter -a degree -t film;
createNode joint -n "hip";
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 1000000000 -ast 1 -aet 1000000000 ";
	setAttr ".st" 6;

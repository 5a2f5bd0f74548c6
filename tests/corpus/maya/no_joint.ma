//Maya ASCII 2018 scene
//Name: no_joint.ma
// A scene without joints, given as a clip.
requires maya "2018";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "box";
	setAttr ".t" -type "double3" 0 10 0 ;

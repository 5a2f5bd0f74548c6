//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "a";
createNode transform -n "b";
connectAttr "a.wm" "b.pm";
connectAttr "b.wm" "a.pm";

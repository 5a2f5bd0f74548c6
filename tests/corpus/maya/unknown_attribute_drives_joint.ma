//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "ctrl";
createNode joint -n "hip";
connectAttr "ctrl.bogus" "hip.tx";

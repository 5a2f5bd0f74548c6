//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode joint -n "hip";
	setAttr ".tx" 1e400;

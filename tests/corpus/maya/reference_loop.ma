//Maya ASCII 2023 scene
file -r -ns "again" -rfn "againRN" "reference_loop.ma";
requires maya "2023";

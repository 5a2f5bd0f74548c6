#pragma once
// A first map file from a clip's skeleton to a rig's joints (skel2rig --map-for, docs/retargeting.md), for a person
// to edit: joints matched by name (the same name; else case-, prefix- and side-convention-insensitive: Left, L_,
// l_, _l, .L, Right, ...), then by hierarchy where names fail (the only unmatched child of a matched joint against
// the only unmatched child of its match); the scale from the bone lengths; `retarget:` with rootScale auto and the
// left leg when the proportions or rest orientations differ. Comments say how each joint was matched and which
// were left for a person.

#include <filesystem>
#include <string>
#include <vector>

#include "adapter/retarget.h"

namespace rig {

struct FirstMap {
    std::string text;  // the map file
    int sameName = 0;  // clip joints matched by the same name
    int byName = 0;    // by name up to case, prefix and side convention
    int byHierarchy = 0;
    std::vector<std::string> unmatched;  // clip joints left for a person
    double scale = 1.0;                  // clip units to cm
    bool retarget = false;               // the map asks for retargeting
};

// The joints of a rig file at rest, as rig-learn sees them (every joint, parents up the parentMatrix connections):
// loaded with every free keyable number as a parameter at its value. Throws rig::Error for a bad rig file or one
// with no free keyable number.
RigSkeleton rigFileSkeleton(const std::filesystem::path& rigFile);

// `clipFile` and `rigFile` name them in the header comment.
FirstMap firstMap(const RigSkeleton& clip, const std::string& clipFile, const RigSkeleton& rig,
                  const std::string& rigFile);

// The match key of a joint name: its namespace (up to the last ':' or '|') and `prefix` dropped, a side word or
// letter (Left, L_, l_, _l, .L, ...) turned into "l:" or "r:", separators dropped, lower case ("LeftUpLeg",
// "L_UpLeg", "upLeg_l" -> "l:upleg").
std::string jointKey(const std::string& name, const std::string& prefix = "");

}  // namespace rig

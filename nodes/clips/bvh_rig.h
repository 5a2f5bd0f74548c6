#pragma once
// A BVH clip's skeleton as a forward-kinematics rig file (docs/bvh.md): one joint per BVH joint
// (translate = OFFSET, rotateOrder from the order of its rotation channels), End Sites as leaf joints,
// helper joints for rotation channels that repeat an axis, and optionally a bvhClip node driving the
// joints. bvh2rig writes it; tests and tools load it straight from the text.

#include <string>
#include <vector>

#include "nodes/clips/bvh.h"

namespace rig {

struct BvhRigOptions {
    std::string prefix;       // put before every node name (e.g. "mocap:"): letters, digits, '_', ':'
    bool withMotion = false;  // add a bvhClip node reading the clip and driving the joints
};

struct BvhRig {
    std::string text;  // the rig file (YAML), with a header comment naming every channel's plug
    int joints = 0;    // rig joints in all: BVH joints, End Sites and helpers
    int endSites = 0;
    int helpers = 0;       // joints that play rotation channels repeating an axis
    std::string clipNode;  // the bvhClip node's name (withMotion)
};

// The rig of `clip`, read from `clipFile` (named in the header comment; its absolute path is what the
// bvhClip node reads). Throws rig::Error for a prefix no node name can start with, or a clip whose rig
// would be too big to load.
BvhRig bvhRig(const BvhClip& clip, const std::string& clipFile, const BvhRigOptions& options);

}  // namespace rig

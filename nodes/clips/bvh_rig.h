#pragma once
// A BVH clip's skeleton as a forward-kinematics rig file (docs/bvh.md): one joint per BVH joint
// (translate = OFFSET, rotateOrder from the order of its rotation channels), End Sites as leaf joints,
// helper joints for rotation channels that repeat an axis, and optionally a clip node driving the
// joints. skel2rig (bvh2rig) writes it, for BVH files and for any skeleton assimp reads; tests and tools load it
// straight from the text.

#include <string>
#include <vector>

#include "nodes/clips/bvh.h"

namespace rig {

struct BvhRigOptions {
    std::string prefix;       // put before every node name (e.g. "mocap:"): letters, digits, '_', ':'
    bool withMotion = false;  // add a clip node reading the clip and driving the joints
    // skel2rig, for a clip from another format (nodes/clips/assimp_clip.h): the clip node is a skeletonClip
    // playing this take, and the header says where the skeleton comes from (ClipSource::describe).
    bool general = false;
    std::string take{};
    std::string source{};
};

struct BvhRig {
    std::string text;  // the rig file (YAML), with a header comment naming every channel's plug
    int joints = 0;    // rig joints in all: BVH joints, End Sites and helpers
    int endSites = 0;
    int helpers = 0;       // joints that play rotation channels repeating an axis
    std::string clipNode;  // the clip node's name (withMotion)
};

// The rig of `clip`, read from `clipFile` (named in the header comment; its absolute path is what the
// bvhClip node reads). Throws rig::Error for a prefix no node name can start with, or a clip whose rig
// would be too big to load.
BvhRig bvhRig(const BvhClip& clip, const std::string& clipFile, const BvhRigOptions& options);

// The names bvhRig gives the clip's joints without a prefix (legal node names, unique): what the clips read
// through assimp call their joints, so that their targets match skel2rig's rig without a map.
std::vector<std::string> bvhRigJointNames(const BvhClip& clip);

}  // namespace rig

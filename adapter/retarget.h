#pragma once
// Retargeting a clip onto a rig of other proportions (docs/retargeting.md), as a map file's `retarget:` asks:
// each mapped joint's rotation relative to the clip's rest pose is applied to the rig joint's rest orientation
// (through a per-joint rest alignment), and the positions are rebuilt down the rig's hierarchy with the rig's
// rest bone lengths, the root's translation scaled by the root scale; so the targets are a pose the rig can take.
// And the map's `weights:`, per joint, into the targets.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "inversion/clip/clip_inversion.h"
#include "inversion/model/approximation.h"
#include "nodes/clips/target_clip.h"

namespace rig {

// The rig's side: its joints' names, rest world matrices (cm) and parents (an index, -1 for a root), parents
// before children.
struct RigSkeleton {
    std::vector<std::string> joints;
    std::vector<Eigen::Matrix4d> rest;
    std::vector<int> parents;
};

// The approximation's outputs that are not helpers, in outputOrder: rest worlds F_k(0) and parents (an output
// learned in world space has none here; retargetClip falls back on the clip's hierarchy for it).
RigSkeleton rigSkeleton(const Approximation& approximation);

// The sum of the rest distances between consecutive joints of `chain` (indices into `rest`).
double chainLength(const std::vector<Eigen::Matrix4d>& rest, const std::vector<int>& chain);

// The root scale the map asks for: its number, or with rootScale auto the rig's leg length over the clip's along
// `retarget.leg` (the clip's rest pose, after the map's scale). Throws rig::Error at the map's file:line:col for
// a leg joint that the clip (after the map) or the rig does not have, or a leg of no length.
double retargetRootScale(const TargetClip& clip, const TargetMap& map, const RigSkeleton& rig);

// The clip retargeted onto the rig (map.retarget.enabled): the same joints, frames and numbers, each joint that is
// a rig joint given the retargeted world, the others carried rigidly by their nearest such ancestor. Throws
// rig::Error for a clip without a rest pose (JSON matrices, arrays) or an `align:` joint that is not both a clip
// joint and a rig joint.
TargetClip retargetClip(const TargetClip& clip, const TargetMap& map, const RigSkeleton& rig);

// The map's `weights:` into the targets (per frame, the joint's output). Throws rig::Error at the entry's
// file:line:col for a joint that is not a target (not a clip joint after the map matched to an output).
void applyTargetWeights(ClipTargets& targets, const TargetMap& map, const TargetClip& clip);

}  // namespace rig

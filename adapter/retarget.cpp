#include "adapter/retarget.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"

namespace rig {
namespace {

int indexOf(const std::vector<std::string>& names, const std::string& name)
{
    const auto it = std::find(names.begin(), names.end(), name);
    return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

Eigen::Matrix3d rotationOf(const Eigen::Matrix4d& m) { return polarRotation(m.block<3, 3>(0, 0)); }

Eigen::Matrix4d frame(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 3>(0, 0) = rotation;
    m.block<3, 1>(0, 3) = position;
    return m;
}

// What the retargeting of one clip onto one rig needs besides the frames.
struct Plan {
    std::vector<int> clipOfRig;              // per rig joint its clip joint, -1 for none
    std::vector<int> parents;                // per rig joint: the rig's parent, else the clip's (see rigSkeleton)
    std::vector<int> order;                  // rig joints, parents first
    std::vector<Eigen::Matrix3d> alignment;  // per rig joint with a clip joint: its rest in the clip joint's rest
    double rootScale = 1.0;
};

// Rig joints learned in world space have no rig parent: the clip's hierarchy gives one where it can (the nearest
// clip ancestor that is a rig joint), so that their positions are rebuilt with the rig's bone lengths too.
void chooseParents(const TargetClip& clip, const RigSkeleton& rig, Plan& plan)
{
    const int count = static_cast<int>(rig.joints.size());
    std::vector<int> rigOfClip(clip.joints.size(), -1);
    for (int k = 0; k < count; ++k)
        if (plan.clipOfRig[k] >= 0) rigOfClip[static_cast<std::size_t>(plan.clipOfRig[k])] = k;
    plan.parents = rig.parents;
    for (int k = 0; k < count; ++k) {
        if (plan.parents[k] >= 0 || plan.clipOfRig[k] < 0) continue;
        int c = clip.parents.empty() ? -1 : clip.parents[static_cast<std::size_t>(plan.clipOfRig[k])];
        while (c >= 0 && rigOfClip[static_cast<std::size_t>(c)] < 0) c = clip.parents[static_cast<std::size_t>(c)];
        if (c >= 0) plan.parents[k] = rigOfClip[static_cast<std::size_t>(c)];
    }
    // Parents first. The rig's parents are a tree (outputOrder), but renames can turn the clip's hierarchy against
    // the rig's: a fallback parent that closes a cycle is dropped (that joint is placed as a root; a rig skeleton
    // made in code with a cycle loses one of its parents the same way).
    std::vector<char> placed(static_cast<std::size_t>(count), 0);
    while (static_cast<int>(plan.order.size()) < count) {
        const std::size_t before = plan.order.size();
        for (int k = 0; k < count; ++k)
            if (!placed[k] && (plan.parents[k] < 0 || placed[static_cast<std::size_t>(plan.parents[k])])) {
                placed[k] = 1;
                plan.order.push_back(k);
            }
        if (plan.order.size() > before) continue;
        int cut = -1;  // the first unplaced joint with a fallback parent, else the first unplaced one
        for (int k = 0; k < count; ++k) {
            if (placed[k]) continue;
            if (cut < 0) cut = k;
            if (plan.parents[k] != rig.parents[k]) {
                cut = k;
                break;
            }
        }
        plan.parents[cut] = -1;
    }
}

Plan makePlan(const TargetClip& clip, const TargetMap& map, const RigSkeleton& rig)
{
    const RetargetSpec& spec = map.retarget;
    if (clip.restWorlds.size() != clip.joints.size())
        throw Error(
            fmt::format("{}: {} has no rest pose to retarget from (world matrices only); give a skeletal "
                        "clip (BVH, FBX, glTF, ...) or leave 'retarget:' out",
                        spec.where, clip.file));
    Plan plan;
    for (const auto& joint : rig.joints) plan.clipOfRig.push_back(indexOf(clip.joints, joint));
    for (const auto& [joint, where] : spec.alignWhere) {
        const int k = indexOf(rig.joints, joint);
        if (k < 0 || plan.clipOfRig[static_cast<std::size_t>(k)] < 0)
            throw Error(
                fmt::format("{}: 'align' names '{}', which is not both a joint of {} after the map and a "
                            "joint of the rig; check the name (the rig's, after 'joints:')",
                            where, messageExcerpt(joint), clip.file));
    }
    plan.alignment.resize(rig.joints.size(), Eigen::Matrix3d::Identity());
    for (std::size_t k = 0; k < rig.joints.size(); ++k) {
        if (plan.clipOfRig[k] < 0) continue;
        const auto given = spec.align.find(rig.joints[k]);
        plan.alignment[k] =
            given != spec.align.end()
                ? eulerToMatrix(given->second * (std::numbers::pi / 180.0), RotateOrder::xyz)
                : Eigen::Matrix3d(rotationOf(clip.restWorlds[static_cast<std::size_t>(plan.clipOfRig[k])]).transpose() *
                                  rotationOf(rig.rest[k]));
    }
    chooseParents(clip, rig, plan);
    plan.rootScale = retargetRootScale(clip, map, rig);
    return plan;
}

// One frame: the rig joints' retargeted worlds.
void retargetFrame(const std::vector<Eigen::Matrix4d>& clipWorlds, const RigSkeleton& rig, const Plan& plan,
                   std::vector<Eigen::Matrix4d>& out)
{
    out.assign(rig.joints.size(), Eigen::Matrix4d::Identity());
    for (const int k : plan.order) {
        const int c = plan.clipOfRig[k];
        const int p = plan.parents[k];
        const Eigen::Matrix4d* source = c >= 0 ? &clipWorlds[static_cast<std::size_t>(c)] : nullptr;
        // An invalid target stays one, and so do the positions placed from it.
        if ((source && !source->allFinite()) || (p >= 0 && !out[p].allFinite())) {
            out[k].setConstant(std::numeric_limits<double>::quiet_NaN());
            continue;
        }
        // The parent's motion since rest, which carries this joint's rest offset (and its rest orientation when
        // the clip does not have the joint).
        const Eigen::Matrix3d parentTurn =
            p >= 0 ? Eigen::Matrix3d(rotationOf(out[p]) * rotationOf(rig.rest[p]).transpose())
                   : Eigen::Matrix3d::Identity();
        const Eigen::Matrix3d rotation = source ? Eigen::Matrix3d(rotationOf(*source) * plan.alignment[k])
                                                : Eigen::Matrix3d(parentTurn * rotationOf(rig.rest[k]));
        Eigen::Vector3d position = rig.rest[k].block<3, 1>(0, 3);
        if (p >= 0)
            position =
                out[p].block<3, 1>(0, 3) + parentTurn * (rig.rest[k].block<3, 1>(0, 3) - rig.rest[p].block<3, 1>(0, 3));
        else if (source) position = plan.rootScale * source->block<3, 1>(0, 3);
        out[k] = frame(rotation, position);
    }
}

}  // namespace

RigSkeleton rigSkeleton(const Approximation& approximation)
{
    RigSkeleton rig;
    std::vector<int> indexOfOutput(approximation.outputs.size(), -1);
    for (const int o : approximation.outputOrder()) {
        const ApproximationOutput& output = approximation.outputs[static_cast<std::size_t>(o)];
        if (output.helper) continue;
        indexOfOutput[static_cast<std::size_t>(o)] = static_cast<int>(rig.joints.size());
        rig.joints.push_back(output.name);
        rig.rest.push_back(output.rest);
        rig.parents.push_back(output.parent >= 0 ? indexOfOutput[static_cast<std::size_t>(output.parent)] : -1);
    }
    return rig;
}

double chainLength(const std::vector<Eigen::Matrix4d>& rest, const std::vector<int>& chain)
{
    double length = 0.0;
    for (std::size_t i = 1; i < chain.size(); ++i)
        length += (rest[static_cast<std::size_t>(chain[i])].block<3, 1>(0, 3) -
                   rest[static_cast<std::size_t>(chain[i - 1])].block<3, 1>(0, 3))
                      .norm();
    return length;
}

double retargetRootScale(const TargetClip& clip, const TargetMap& map, const RigSkeleton& rig)
{
    const RetargetSpec& spec = map.retarget;
    if (spec.rootScale) return *spec.rootScale;
    std::vector<int> clipLeg, rigLeg;
    for (std::size_t i = 0; i < spec.leg.size(); ++i) {
        clipLeg.push_back(indexOf(clip.joints, spec.leg[i]));
        rigLeg.push_back(indexOf(rig.joints, spec.leg[i]));
        if (clipLeg.back() < 0)
            throw Error(
                fmt::format("{}: leg joint '{}' is not a joint of {} after the map; name the clip's leg "
                            "joints as 'joints:' renames them, or give rootScale as a number",
                            spec.legWhere[i], messageExcerpt(spec.leg[i]), clip.file));
        if (rigLeg.back() < 0)
            throw Error(
                fmt::format("{}: leg joint '{}' is not a joint of the rig (an output of the approximation); "
                            "name the rig's leg joints, or give rootScale as a number",
                            spec.legWhere[i], messageExcerpt(spec.leg[i])));
    }
    const double source = chainLength(clip.restWorlds, clipLeg);
    const double target = chainLength(rig.rest, rigLeg);
    if (!(source > 1e-9) || !(target > 1e-9))
        throw Error(
            fmt::format("{}: the leg has no length in {} (the clip's {} cm, the rig's {} cm); name joints "
                        "from hip to ankle, or give rootScale as a number",
                        spec.rootScaleWhere, source > 1e-9 ? "the rig" : clip.file, source, target));
    return target / source;
}

TargetClip retargetClip(const TargetClip& clip, const TargetMap& map, const RigSkeleton& rig)
{
    const Plan plan = makePlan(clip, map, rig);
    std::vector<int> rigOfClip(clip.joints.size(), -1);
    for (std::size_t k = 0; k < rig.joints.size(); ++k)
        if (plan.clipOfRig[k] >= 0) rigOfClip[static_cast<std::size_t>(plan.clipOfRig[k])] = static_cast<int>(k);
    TargetClip out = clip;
    std::vector<Eigen::Matrix4d> rigWorlds;
    for (std::size_t f = 0; f < clip.worlds.size(); ++f) {
        retargetFrame(clip.worlds[f], rig, plan, rigWorlds);
        auto& worlds = out.worlds[f];
        // Clip parents come before their children, so an ancestor is done before the joints it carries.
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            if (rigOfClip[j] >= 0) {
                worlds[j] = rigWorlds[static_cast<std::size_t>(rigOfClip[j])];
                continue;
            }
            int a = clip.parents.empty() ? -1 : clip.parents[j];
            while (a >= 0 && rigOfClip[static_cast<std::size_t>(a)] < 0) a = clip.parents[static_cast<std::size_t>(a)];
            if (a >= 0)
                worlds[j] = worlds[static_cast<std::size_t>(a)] *
                            clip.worlds[f][static_cast<std::size_t>(a)].inverse() * clip.worlds[f][j];
        }
    }
    return out;
}

void applyTargetWeights(ClipTargets& targets, const TargetMap& map, const TargetClip& clip)
{
    for (const auto& [joint, weight] : map.weights) {
        const int j = indexOf(clip.joints, joint);
        const int o = j < 0 ? -1 : targets.outputOfJoint[static_cast<std::size_t>(j)];
        if (o < 0)
            throw Error(
                fmt::format("{}: weights for '{}', which is not a target ({} after the map has no such joint "
                            "that is an output of the approximation); check the name (the rig's)",
                            weight.where, messageExcerpt(joint), clip.file));
        for (auto& frame : targets.frames) {
            frame[static_cast<std::size_t>(o)].positionWeight = weight.position;
            frame[static_cast<std::size_t>(o)].rotationWeight = weight.rotation;
        }
    }
}

}  // namespace rig

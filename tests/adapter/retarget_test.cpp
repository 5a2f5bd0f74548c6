// Retargeting in map files (adapter/retarget.h, docs/retargeting.md): a CMU clip whose legs are 1.15 times
// longer, retargeted onto the skeleton of the clip as it was, keeps the rig's bone lengths and the clip's
// rotations from rest, its root scaled by the leg ratio; weights reach the targets; every mistake in the new keys
// is one line with the map's file:line:col. Cases needing the CMU clip are skipped when it is absent.
#include <doctest/doctest.h>

#include <filesystem>
#include <limits>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "adapter/first_map.h"
#include "adapter/retarget.h"
#include "core/error.h"
#include "core/rotation_math.h"
#include "nodes/clips/target_clip.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

const fs::path cmuClip = "/usr/share/assimp/models/BVH/01_01.bvh";

// The BVH text with the OFFSETs of the joints below the thighs (the knees, ankles, toes and the toes' End Sites)
// times `factor`: the same motion on longer legs.
std::string longerLegs(const std::string& text, double factor)
{
    std::istringstream in(text);
    std::ostringstream out;
    std::string line, joint;
    const auto isLeg = [](const std::string& j) {
        return j == "LeftLeg" || j == "LeftFoot" || j == "LeftToeBase" || j == "RightLeg" || j == "RightFoot" ||
               j == "RightToeBase";
    };
    while (std::getline(in, line)) {
        std::istringstream words(line);
        std::string word;
        words >> word;
        if (word == "JOINT" || word == "ROOT") words >> joint;
        if (word == "End") joint = joint.ends_with("ToeBase") ? joint + "_end" : "";
        if (word == "OFFSET" && (isLeg(joint) || joint.ends_with("ToeBase_end"))) {
            double x = 0, y = 0, z = 0;
            words >> x >> y >> z;
            line = fmt::format("OFFSET {} {} {}", x * factor, y * factor, z * factor);
        }
        out << line << '\n';
    }
    return out.str();
}

// The clip's own skeleton as a rig: its joints, rest worlds and parents.
RigSkeleton skeletonOf(const TargetClip& clip) { return {clip.joints, clip.restWorlds, clip.parents}; }

Eigen::Matrix3d rotation(const Eigen::Matrix4d& m) { return polarRotation(m.block<3, 3>(0, 0)); }

}  // namespace

TEST_CASE("retargeting a clip with longer legs keeps the rig's bone lengths and the clip's rotations from rest")
{
    if (!fs::exists(cmuClip)) return;
    const auto dir = test::scratchDir("retarget_long_legs");
    const auto longClip = test::writeFile(dir / "long_legs.bvh", longerLegs(test::readFile(cmuClip), 1.15));
    const RigSkeleton rig = skeletonOf(readTargetClip(cmuClip, TargetMap{}));
    const TargetClip source = readTargetClip(longClip, TargetMap{});
    const TargetMap map = readTargetMap(
        test::writeFile(dir / "map.yaml", "retarget:\n  rootScale: auto\n  leg: [LeftUpLeg, LeftLeg, LeftFoot]\n"));
    const TargetClip clip = readTargetClip(longClip, map);
    const TargetClip out = retargetClip(clip, map, rig);
    REQUIRE(out.joints == rig.joints);
    REQUIRE(out.worlds.size() == source.worlds.size());

    // rootScale auto: the rig's hip-knee-ankle length over the clip's.
    const std::vector<int> leg{2, 3, 4};
    REQUIRE(rig.joints[2] == "LeftUpLeg");
    REQUIRE(rig.joints[4] == "LeftFoot");
    const double ratio = chainLength(rig.rest, leg) / chainLength(source.restWorlds, leg);
    CHECK(retargetRootScale(clip, map, rig) == doctest::Approx(ratio).epsilon(1e-15));
    CHECK(ratio == doctest::Approx(1 / 1.15).epsilon(1e-5));

    double worstLength = 0, worstTurn = 0, worstRoot = 0;
    for (std::size_t f = 0; f < out.worlds.size(); f += 7)
        for (std::size_t j = 0; j < rig.joints.size(); ++j) {
            const Eigen::Matrix4d& w = out.worlds[f][j];
            // Rotation from rest: the clip's, joint by joint.
            const Eigen::Matrix3d turn = rotation(w) * rotation(rig.rest[j]).transpose();
            const Eigen::Matrix3d sourceTurn =
                rotation(source.worlds[f][j]) * rotation(source.restWorlds[j]).transpose();
            worstTurn = std::max(worstTurn, orientationAngle(turn, sourceTurn));
            const int p = rig.parents[j];
            if (p < 0) {
                worstRoot = std::max(
                    worstRoot,
                    (w.block<3, 1>(0, 3) - ratio * source.worlds[f][j].block<3, 1>(0, 3)).cwiseAbs().maxCoeff());
                continue;
            }
            // Bone lengths: the rig's.
            const double length = (w.block<3, 1>(0, 3) - out.worlds[f][p].block<3, 1>(0, 3)).norm();
            const double rest = (rig.rest[j].block<3, 1>(0, 3) - rig.rest[p].block<3, 1>(0, 3)).norm();
            worstLength = std::max(worstLength, std::abs(length - rest));
        }
    CHECK(worstLength < 1e-12);
    CHECK(worstTurn < 1e-12);
    CHECK(worstRoot < 1e-12);
    // The same clip retargeted onto its own skeleton with rootScale 1 is the clip (up to rounding).
    const TargetMap same = readTargetMap(test::writeFile(dir / "same.yaml", "retarget:\n  rootScale: 1\n"));
    const TargetClip own = retargetClip(readTargetClip(cmuClip, same), same, rig);
    const TargetClip plain = readTargetClip(cmuClip, TargetMap{});
    double worstSelf = 0;
    for (std::size_t f = 0; f < own.worlds.size(); f += 11)
        for (std::size_t j = 0; j < own.joints.size(); ++j)
            worstSelf = std::max(worstSelf, (own.worlds[f][j] - plain.worlds[f][j]).cwiseAbs().maxCoeff());
    CHECK(worstSelf < 1e-9);
}

TEST_CASE("retargeting: a given alignment turns the rig joint's rest orientation in the clip joint's frame")
{
    if (!fs::exists(cmuClip)) return;
    const auto dir = test::scratchDir("retarget_align");
    const RigSkeleton rig = skeletonOf(readTargetClip(cmuClip, TargetMap{}));
    const TargetMap map = readTargetMap(test::writeFile(dir / "map.yaml", "retarget:\n  align: {Head: [0, 90, 0]}\n"));
    const TargetClip clip = readTargetClip(cmuClip, map);
    const TargetClip out = retargetClip(clip, map, rig);
    const int head = 16;
    REQUIRE(clip.joints[head] == "Head");
    const Eigen::Matrix3d turn = eulerToMatrix(Eigen::Vector3d(0, std::numbers::pi / 2, 0), RotateOrder::xyz);
    for (std::size_t f = 0; f < out.worlds.size(); f += 97)
        CHECK(orientationAngle(rotation(out.worlds[f][head]), rotation(clip.worlds[f][head]) * turn) < 1e-12);
}

TEST_CASE("map weights reach the targets of their joints")
{
    const auto dir = test::scratchDir("retarget_weights");
    const TargetMap map = readTargetMap(
        test::writeFile(dir / "map.yaml", "weights:\n  wrist: {position: 2.5}\n  elbow: {rotation: 0}\n"));
    TargetClip clip;
    clip.file = "clip.json";
    clip.joints = {"shoulder", "elbow", "wrist"};
    ClipTargets targets;
    targets.outputOfJoint = {0, 2, 1};
    targets.frames.assign(2, std::vector<JointTarget>(3));
    applyTargetWeights(targets, map, clip);
    for (const auto& frame : targets.frames) {
        CHECK(frame[0].positionWeight == 1.0);
        CHECK(frame[0].rotationWeight == 1.0);
        CHECK(frame[1].positionWeight == 2.5);  // wrist's output
        CHECK(frame[1].rotationWeight == 1.0);
        CHECK(frame[2].positionWeight == 1.0);  // elbow's
        CHECK(frame[2].rotationWeight == 0.0);
    }
    targets.outputOfJoint = {0, -1, 1};
    CHECK(test::errorOf([&] { applyTargetWeights(targets, map, clip); }) ==
          (dir / "map.yaml").string() +
              ":3:3: weights for 'elbow', which is not a target (clip.json after the map has no such joint that is "
              "an output of the approximation); check the name (the rig's)");
}

TEST_CASE("retarget and weights mistakes are one line with the map's file:line:col and what to do")
{
    const auto dir = test::scratchDir("retarget_errors");
    const std::string m = (dir / "map.yaml").string();
    const auto map = [&](const std::string& text) { return readTargetMap(test::writeFile(dir / "map.yaml", text)); };
    const auto error = [&](const std::string& text) { return test::errorOf([&] { map(text); }); };
    CHECK(error("retarget: [a]\n") ==
          m + ":1:11: 'retarget' must be a map with 'rootScale:', 'leg:' and 'align:' (docs/retargeting.md)");
    CHECK(error("retarget:\n  rootscale: 2\n") ==
          m + ":2:3: unknown key 'rootscale' in 'retarget'; it has 'rootScale:', 'leg:' and 'align:'");
    CHECK(error("retarget:\n  rootScale: big\n") ==
          m + ":2:14: rootScale must be 'auto' or a positive number, got 'big'");
    CHECK(error("retarget:\n  rootScale: 0\n") == m + ":2:14: rootScale must be 'auto' or a positive number, got '0'");
    CHECK(error("retarget:\n  rootScale:\n") == m + ":2:3: rootScale must be 'auto' or a positive number, got nothing");
    CHECK(error("retarget:\n  rootScale: auto\n") ==
          m + ":2:14: rootScale auto needs 'leg:' in 'retarget' (the rig's joints from hip to ankle, [LeftUpLeg, "
              "LeftLeg, LeftFoot]); add it or give rootScale as a number");
    CHECK(error("retarget:\n  leg: [hip]\n") ==
          m + ":2:8: 'leg' must list two or more rig joints from hip to ankle ([LeftUpLeg, LeftLeg, LeftFoot])");
    CHECK(error("retarget:\n  align: {Head: [0, 90]}\n") ==
          m + ":2:17: align of 'Head' must be three angles in degrees, X Y Z ([0, 0, -45])");
    CHECK(error("retarget:\n  align: {Head: [0, .inf, 0]}\n") == m + ":2:21: align of 'Head' is not a finite number");
    CHECK(error("weights: [a]\n") == m + ":1:10: 'weights' must map rig joints to {position: W, rotation: W}");
    CHECK(error("weights:\n  Head: 2\n") == m + ":2:9: the weights of 'Head' must be a map {position: W, rotation: W}");
    CHECK(error("weights:\n  Head: {positon: 2}\n") ==
          m + ":2:10: unknown weight 'positon'; a joint's weights are 'position:' and 'rotation:'");
    CHECK(error("weights:\n  Head: {position: -1}\n") == m + ":2:20: the position weight of 'Head' must be 0 or more, "
                                                             "got -1");
    CHECK(error("weights:\n  Head: {rotation: heavy}\n") ==
          m + ":2:20: the rotation weight must be a number, got 'heavy'");

    // What the clip and the rig decide: a leg joint either lacks, an alignment of a joint that is not both's, a
    // clip without a rest pose.
    TargetClip clip;
    clip.file = "clip.bvh";
    clip.joints = {"hip", "knee", "ankle"};
    clip.parents = {-1, 0, 1};
    clip.worlds.assign(1, std::vector<Eigen::Matrix4d>(3, Eigen::Matrix4d::Identity()));
    clip.restWorlds.assign(3, Eigen::Matrix4d::Identity());
    for (int j = 0; j < 3; ++j) clip.restWorlds[j](1, 3) = -10.0 * j;
    RigSkeleton rig{{"hip", "knee", "ankle"}, clip.restWorlds, clip.parents};
    const auto retarget = [&](const std::string& text) {
        return test::errorOf([&] { retargetClip(clip, map(text), rig); });
    };
    CHECK(retarget("retarget:\n  rootScale: auto\n  leg: [hip, kne, ankle]\n") ==
          m + ":3:14: leg joint 'kne' is not a joint of clip.bvh after the map; name the clip's leg joints as "
              "'joints:' renames them, or give rootScale as a number");
    rig.joints[2] = "foot";
    CHECK(retarget("retarget:\n  rootScale: auto\n  leg: [hip, knee, ankle]\n") ==
          m + ":3:20: leg joint 'ankle' is not a joint of the rig (an output of the approximation); name the rig's "
              "leg joints, or give rootScale as a number");
    CHECK(retarget("retarget:\n  align:\n    ankle: [0, 0, 10]\n") ==
          m + ":3:5: 'align' names 'ankle', which is not both a joint of clip.bvh after the map and a joint of the "
              "rig; check the name (the rig's, after 'joints:')");
    rig.joints[2] = "ankle";
    CHECK(retarget("retarget:\n  rootScale: auto\n  leg: [hip, hip]\n") ==
          m + ":2:14: the leg has no length in clip.bvh (the clip's 0 cm, the rig's 0 cm); name joints from hip to "
              "ankle, or give rootScale as a number");
    clip.restWorlds.clear();
    CHECK(retarget("retarget:\n  rootScale: 2\n") ==
          m + ":2:3: clip.bvh has no rest pose to retarget from (world matrices only); give a skeletal clip (BVH, "
              "FBX, glTF, ...) or leave 'retarget:' out");
}

TEST_CASE("retargeting: a rig joint without a parent takes the clip's, and a target that is not finite stays invalid")
{
    // A leg of 10 + 10 cm in the clip, 8 + 12 cm on the rig, whose knee is learned in world space (no parent).
    TargetClip clip;
    clip.file = "leg.bvh";
    clip.joints = {"hip", "knee", "ankle"};
    clip.parents = {-1, 0, 1};
    for (const double y : {0.0, -10.0, -20.0}) {
        clip.restWorlds.push_back(Eigen::Matrix4d::Identity());
        clip.restWorlds.back()(1, 3) = y;
    }
    Eigen::Matrix4d bent = Eigen::Matrix4d::Identity();
    bent.block<3, 3>(0, 0) = eulerToMatrix(Eigen::Vector3d(0.5, 0, 0), RotateOrder::xyz);
    std::vector<Eigen::Matrix4d> frame{clip.restWorlds[0], bent * clip.restWorlds[1], bent * clip.restWorlds[2]};
    clip.worlds = {frame, frame};
    clip.worlds[1][1](0, 0) = std::numeric_limits<double>::quiet_NaN();
    RigSkeleton rig{clip.joints, clip.restWorlds, {-1, -1, 1}};
    rig.rest[1](1, 3) = -8.0;
    TargetMap map;
    map.retarget.enabled = true;
    map.retarget.rootScale = 1.0;
    const TargetClip out = retargetClip(clip, map, rig);
    const Eigen::Vector3d hip = out.worlds[0][0].block<3, 1>(0, 3), knee = out.worlds[0][1].block<3, 1>(0, 3),
                          ankle = out.worlds[0][2].block<3, 1>(0, 3);
    CHECK((knee - hip).norm() == doctest::Approx(8.0).epsilon(1e-14));
    CHECK((ankle - knee).norm() == doctest::Approx(12.0).epsilon(1e-14));
    CHECK(orientationAngle(rotation(out.worlds[0][1]), bent.block<3, 3>(0, 0)) < 1e-14);
    // Frame 2: the knee's matrix is not finite: its target and the ankle's placed from it are invalid.
    CHECK(out.worlds[1][0].allFinite());
    CHECK(!out.worlds[1][1].allFinite());
    CHECK(!out.worlds[1][2].allFinite());
}

TEST_CASE("first maps compare joint names without case, namespace, a shared prefix, separators and side spelling")
{
    for (const char* name : {"LeftUpLeg", "L_UpLeg", "upLeg_l", "l_up_leg", "UpLeg.L", "ns:LeftUpLeg", "UpLegLeft"})
        CHECK(jointKey(name) == "l:upleg");
    CHECK(jointKey("RThumb") == "r:thumb");
    CHECK(jointKey("LowerBack") == "lowerback");  // an L before a small letter is no side
    CHECK(jointKey("Root") == "root");
    CHECK(jointKey("mocap_LeftArm", "mocap_") == "l:arm");
    CHECK(jointKey("Bip01 R Forearm", "Bip01 ") == "r:forearm");
}

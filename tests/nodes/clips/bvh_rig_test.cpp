// A BVH skeleton as a rig, in the library: joints, rotate orders, helpers for a repeated axis, End Sites,
// the bvhClip wiring, and the rig's world matrices equal to the BVH reference forward kinematics.
#include <doctest/doctest.h>

#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh_rig.h"
#include "test_support.h"

using namespace rig;

namespace {

// A root with position channels, a child whose rotation channels repeat an axis (Z X Z: a helper joint),
// and an End Site.
constexpr const char* skeleton = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 90 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Zrotation
    End Site
    {
      OFFSET 0 20 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0333333
0 90 0 0 0 0 0 0 0
5 91 -2 30 -20 10 45 15 -60
)";

}  // namespace

TEST_CASE("bvh rig: joints, rotate orders, a helper for a repeated axis, End Sites, and the clip's wiring")
{
    // The bvhClip node reads the file itself.
    const auto file = rig::test::scratchDir("bvh-rig") / "two.bvh";
    rig::test::writeFile(file, skeleton);
    const BvhClip clip = readBvhFile(file);
    const BvhRig rig = bvhRig(clip, file.string(), {"mocap:", true});
    CHECK(rig.joints == 4);  // Hips, Spine's helper, Spine, Spine_end
    CHECK(rig.endSites == 1);
    CHECK(rig.helpers == 1);
    CHECK(rig.clipNode == "mocap:clip");
    const auto graph = loadGraphText(rig.text, (file.parent_path() / "two_rig.yaml").string(), makeBuiltinRegistry());
    CHECK(std::get<int>(graph->getValue(graph->plug("mocap:Hips.rotateOrder"))) == 4);  // Z X Y channels: yxz
    CHECK(graph->findNode("mocap:Spine_rot1") >= 0);
    CHECK(graph->findNode("mocap:Spine_end") >= 0);
    CHECK(graph->incomingConnection(graph->plug("mocap:Hips.translateX")) != nullptr);

    // Driven by the clip, the rig's joints are the BVH reference's at every frame.
    for (int frame = 1; frame <= 2; ++frame) {
        graph->setTime(frame);
        const auto reference = bvhWorldMatrices(clip, frame - 1);
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            const auto world = std::get<Eigen::Matrix4d>(
                graph->getValue(graph->plug("mocap:" + clip.joints[j].name + ".worldMatrix")));
            CHECK((world - reference[j]).norm() < 1e-9);
        }
    }
}

TEST_CASE("bvh rig: a prefix no node name can take is refused")
{
    const BvhClip clip = parseBvh(skeleton, "two.bvh");
    CHECK_THROWS_WITH_AS(bvhRig(clip, "two.bvh", {"9x", false}), "--prefix '9x': a node name cannot start with a digit",
                         Error);
    CHECK_THROWS_WITH_AS(bvhRig(clip, "two.bvh", {"a b", false}),
                         "--prefix 'a b': use letters, digits, '_' and ':' (e.g. --prefix mocap:)", Error);
}

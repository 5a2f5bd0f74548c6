// A Maya scene whose arm hangs under a joint mirrored by a scale of -1 on all three axes (maya-usd's
// UsdExportSkeleton.ma keys its right shoulder so, its scale drifting by 1e-7 between the axes): every joint under
// it has a world matrix with a reflection. Its orientation is that of the negated matrix, continuous, for the clip's
// targets and the approximation alike, and the mirrored scale is learned on its side of 0: the scene's own
// animation, inverted with --params auto, reaches every frame (docs/rig-invert.md).
#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "test_support.h"

namespace fs = std::filesystem;
using namespace rig;

namespace {

// shldr's scale is keyed at -1 (drifting by 1e-7, as a scene exported by a DCC does) over frames 1 to 3, its arm's
// and elbow's rotations keyed to move; the joints do not compensate their parent's scale.
const std::string mirroredArmScene = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode joint -n "chest";
	setAttr ".ssc" no;
createNode joint -n "shldr" -p "chest";
	setAttr ".ssc" no;
	setAttr ".t" -type "double3" -2 5 0 ;
createNode joint -n "arm" -p "shldr";
	setAttr ".ssc" no;
	setAttr ".t" -type "double3" 0 0 17 ;
createNode joint -n "elbow" -p "arm";
	setAttr ".ssc" no;
	setAttr ".t" -type "double3" 0 0 30 ;
createNode joint -n "hand" -p "elbow";
	setAttr ".ssc" no;
	setAttr ".t" -type "double3" 0 0 25 ;
createNode animCurveTU -n "shldr_scaleX";
	setAttr -s 3 ".ktv[0:2]"  1 -1.000000081324149 2 -1.000000081324149 3 -1.000000081324149;
createNode animCurveTU -n "shldr_scaleY";
	setAttr -s 3 ".ktv[0:2]"  1 -1 2 -1 3 -1;
createNode animCurveTU -n "shldr_scaleZ";
	setAttr -s 3 ".ktv[0:2]"  1 -0.99999996211485942 2 -0.99999996211485942 3 -0.99999996211485942;
createNode animCurveTA -n "shldr_rotateY";
	setAttr -s 3 ".ktv[0:2]"  1 -80.5 2 -80.5 3 -80.5;
createNode animCurveTA -n "shldr_rotateZ";
	setAttr -s 3 ".ktv[0:2]"  1 -180 2 -180 3 -180;
createNode animCurveTA -n "arm_rotateX";
	setAttr -s 3 ".ktv[0:2]"  1 6.5 2 7.0 3 6.5;
createNode animCurveTA -n "arm_rotateY";
	setAttr -s 3 ".ktv[0:2]"  1 66.9 2 66.95 3 66.9;
createNode animCurveTA -n "arm_rotateZ";
	setAttr -s 3 ".ktv[0:2]"  1 29.0 2 29.1 3 29.0;
createNode animCurveTA -n "elbow_rotateX";
	setAttr -s 3 ".ktv[0:2]"  1 82.1 2 81.0 3 82.1;
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 6 -ast 1 -aet 6 ";
	setAttr ".st" 6;
connectAttr "shldr_scaleX.o" "shldr.sx";
connectAttr "shldr_scaleY.o" "shldr.sy";
connectAttr "shldr_scaleZ.o" "shldr.sz";
connectAttr "shldr_rotateY.o" "shldr.ry";
connectAttr "shldr_rotateZ.o" "shldr.rz";
connectAttr "arm_rotateX.o" "arm.rx";
connectAttr "arm_rotateY.o" "arm.ry";
connectAttr "arm_rotateZ.o" "arm.rz";
connectAttr "elbow_rotateX.o" "elbow.rx";
)";

// rig-learn --params auto on `scene`, then rig-invert of the scene's own animation: the report.
YAML::Node learnAndInvert(const fs::path& dir, const fs::path& scene)
{
    const auto learned = test::run(fmt::format("{} '{}' --params auto -o '{}'", test::tool("rig-learn"), scene.string(),
                                               (dir / "a.yaml").string()));
    INFO(learned.err);
    REQUIRE(learned.exitCode == 0);
    const auto inverted = test::run(fmt::format("{} '{}' --rig '{}' --clip '{}' -o '{}' --report-json '{}'",
                                                test::tool("rig-invert"), (dir / "a.yaml").string(), scene.string(),
                                                scene.string(), (dir / "c.json").string(), (dir / "r.json").string()));
    INFO(inverted.err);
    CHECK(inverted.exitCode == 0);
    return YAML::LoadFile((dir / "r.json").string());
}

}  // namespace

TEST_CASE("mirrored scene: an arm under a joint scaled by -1 inverts its own animation, every frame reached")
{
    const auto dir = test::scratchDir("mirrored_scene");
    const fs::path scene = test::writeFile(dir / "mirrored_arm.ma", mirroredArmScene);
    const YAML::Node report = learnAndInvert(dir, scene);
    CHECK(report["status_frames"]["reached"].as<int>() == 6);
    // The mirrored scale's range is learned below 0 (-2 to -0.5), where the shoulder's matrix has an inverse.
    const YAML::Node learned = YAML::LoadFile((dir / "a.yaml").string());
    for (const auto& p : learned["parameters"])
        if (p["name"].as<std::string>().starts_with("shldr.scale")) {
            CAPTURE(p["name"].as<std::string>());
            CHECK(p["max"].as<double>() < 0.0);
        }
}

TEST_CASE("mirrored scene: maya-usd's UsdExportSkeleton.ma reaches every frame of its own animation, where present")
{
    const fs::path scene = test::sourceDir() /
                           "../shared/maya/Autodesk__maya-usd/test/lib/usd/translators/UsdExportSkeletonTest/"
                           "UsdExportSkeleton.ma";
    if (!fs::exists(scene)) {
        MESSAGE("[skipped] ../shared/maya's UsdExportSkeleton.ma is absent");
        return;
    }
    const YAML::Node report = learnAndInvert(test::scratchDir("mirrored_scene_usd"), scene);
    CHECK(report["status_frames"]["reached"].as<int>() == 120);
}

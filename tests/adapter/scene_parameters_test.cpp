// A Maya scene's custom control attributes as parameters named by glob (docs/rig-learn.md, Ranges): keyable where the
// scene made them keyable (`setAttr -k on` on an added attribute, as --params auto reads them, so that rig-invert loads
// an approximation learned with auto parameters), and learned over the span of the set-driven keys they drive.
#include <doctest/doctest.h>

#include <unistd.h>

#include <numbers>
#include <string>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "test_support.h"

namespace rig {
namespace {

// foot_ctrl.roll drives a set-driven key (an animCurveUA keyed from -10 to 10, kinked at 0) into ankle.rotateZ;
// foot_ctrl.spare is keyable and drives nothing; foot_ctrl.hidden was added without -k.
const std::string footScene = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "foot_ctrl";
	addAttr -ci true -sn "roll" -ln "roll" -at "double";
	addAttr -ci true -sn "spare" -ln "spare" -at "double";
	addAttr -ci true -sn "hidden" -ln "hidden" -at "double";
	setAttr -k on ".roll";
	setAttr -k on ".spare";
createNode joint -n "hip";
createNode joint -n "ankle" -p "hip";
	setAttr ".t" -type "double3" 0 -10 0 ;
createNode animCurveUA -n "ankle_rotateZ";
	setAttr -s 3 ".ktv[0:2]"  -10 -90 0 0 10 180;
connectAttr "foot_ctrl.roll" "ankle_rotateZ.i";
connectAttr "ankle_rotateZ.o" "ankle.rz";
)";

// An arm whose shoulder control an animation keys from -20 to 150 degrees over frames 1 to 10 (and its elbow, keyed
// within the default range, and its translateX, keyed up to 2 cm), the playback range 1 to 5: a clip of the scene plays
// frames 1 to 5, where the shoulder reaches 78 degrees (linear keys); the saved time is frame 0 (no time node), where
// the curves give their first keys' values.
const std::string keyedArmScene = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "shoulder_ctrl";
createNode joint -n "shoulder";
createNode joint -n "elbow" -p "shoulder";
	setAttr ".t" -type "double3" 10 0 0 ;
createNode joint -n "wrist" -p "elbow";
	setAttr ".t" -type "double3" 10 0 0 ;
createNode animCurveTA -n "shoulder_ctrl_rotateZ";
	setAttr ".tan" 2;
	setAttr -s 3 ".ktv[0:2]"  1 -20 5 78 10 150;
createNode animCurveTL -n "shoulder_ctrl_translateX";
	setAttr ".tan" 2;
	setAttr -s 2 ".ktv[0:1]"  1 0 5 2;
createNode script -n "sceneConfigurationScriptNode";
	setAttr ".b" -type "string" "playbackOptions -min 1 -max 5 -ast 1 -aet 10 ";
	setAttr ".st" 6;
connectAttr "shoulder_ctrl_rotateZ.o" "shoulder_ctrl.rz";
connectAttr "shoulder_ctrl_translateX.o" "shoulder_ctrl.tx";
connectAttr "shoulder_ctrl.r" "shoulder.r";
connectAttr "shoulder_ctrl.t" "shoulder.t";
)";

}  // namespace

TEST_CASE(
    "scene parameters: a channel the scene's animation keys past its default range is learned over what a clip "
    "of the scene reaches")
{
    const auto file =
        test::writeFile(test::scratchDir(fmt::format("scene-keyed.{}", ::getpid())) / "arm.ma", keyedArmScene);
    GraphRigOptions options{{"shoulder_ctrl.rotateZ", "shoulder_ctrl.translateX", "shoulder_ctrl.rotateY"},
                            {"shoulder", "elbow", "wrist"},
                            {},
                            {}};
    options.cutTimeCurves = true;
    GraphRigFunction rig(file, options);
    REQUIRE(rig.parameters().size() == 3);
    constexpr double degree = std::numbers::pi / 180.0;
    // The default range is +-90 degrees about the value at the saved time (-20: -110 to 70); the playback range
    // (frames 1 to 5) reaches 78 degrees, past it.
    const RigParameter& rotate = rig.parameters()[0];
    CHECK(rotate.defaultValue == doctest::Approx(-20 * degree));
    CHECK(rotate.min == doctest::Approx(-110 * degree));
    CHECK(rotate.max == doctest::Approx(78 * degree));
    // The translate reaches 2 cm, within its default range: the range stays.
    const RigParameter& translate = rig.parameters()[1];
    CHECK(translate.min == doctest::Approx(-50));
    CHECK(translate.max == doctest::Approx(50));
    // An unkeyed channel keeps its default range; the curve is cut, the value it gave at the saved time kept.
    CHECK(rig.parameters()[2].max == doctest::Approx(90 * degree));

    // Played to frame 10 (the keys' whole span, no playback range): up to 150 degrees.
    std::string unbounded = keyedArmScene;
    unbounded.erase(unbounded.find("createNode script"),
                    unbounded.find("connectAttr") - unbounded.find("createNode script"));
    const auto wide = test::writeFile(file.parent_path() / "arm_keys.ma", unbounded);
    GraphRigFunction keyed(wide, options);
    CHECK(keyed.parameters()[0].min == doctest::Approx(-110 * degree));
    CHECK(keyed.parameters()[0].max == doctest::Approx(150 * degree));
    // A range the spec gives comes first.
    options.ranges = {{"shoulder_ctrl.rotateZ", -10.0, 20.0}};
    GraphRigFunction ranged(wide, options);
    CHECK(ranged.parameters()[0].min == doctest::Approx(-10 * degree));
    CHECK(ranged.parameters()[0].max == doctest::Approx(20 * degree));
}

TEST_CASE("scene parameters: an added attribute the scene made keyable is a parameter by name, over its keys' span")
{
    const auto file =
        test::writeFile(test::scratchDir(fmt::format("scene-parameters.{}", ::getpid())) / "foot.ma", footScene);
    GraphRigFunction rig(file, GraphRigOptions{{"foot_ctrl.roll", "foot_ctrl.spare"}, {"hip", "ankle"}, {}, {}});
    REQUIRE(rig.parameters().size() == 2);
    const RigParameter& roll = rig.parameters()[0];
    CHECK(roll.name == "foot_ctrl.roll");
    CHECK_FALSE(roll.limited);
    // The set-driven key's span, not the default +-1 (past which a learned curve would be extrapolated).
    CHECK(roll.min == -10.0);
    CHECK(roll.max == 10.0);
    const RigParameter& spare = rig.parameters()[1];
    CHECK(spare.min == -1.0);
    CHECK(spare.max == 1.0);
    // The key at 10 turns the ankle by 180 degrees: the curve is read through the parameter.
    std::vector<Eigen::Matrix4d> worlds;
    rig.evaluate(std::vector<double>{10.0, 0.0}, worlds);
    CHECK((worlds[1].block<3, 1>(0, 0) - Eigen::Vector3d(-1, 0, 0)).norm() < 1e-9);
    // A glob's range still comes first.
    GraphRigOptions ranged{{"foot_ctrl.roll"}, {"hip", "ankle"}, {}, {}};
    ranged.ranges = {{"foot_ctrl.roll", -2.0, 3.0}};
    GraphRigFunction narrow(file, ranged);
    CHECK(narrow.parameters()[0].min == -2.0);
    CHECK(narrow.parameters()[0].max == 3.0);
    // Neither the attribute nor the scene made it keyable: refused by name, in one line.
    try {
        GraphRigFunction hidden(file, GraphRigOptions{{"foot_ctrl.hidden"}, {"hip", "ankle"}, {}, {}});
        FAIL("foot_ctrl.hidden was taken as a parameter");
    }
    catch (const RigSelectionError& e) {
        CHECK(e.reason() == "it is not keyable (not an animator control)");
    }
}

}  // namespace rig

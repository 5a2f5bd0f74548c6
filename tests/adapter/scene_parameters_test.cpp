// A Maya scene's custom control attributes as parameters named by glob (docs/rig-learn.md, Ranges): keyable where the
// scene made them keyable (`setAttr -k on` on an added attribute, as --params auto reads them, so that rig-invert loads
// an approximation learned with auto parameters), and learned over the span of the set-driven keys they drive.
#include <doctest/doctest.h>

#include <unistd.h>

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

}  // namespace

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

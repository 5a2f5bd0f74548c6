// Maya IK chains whose controls have channels a planar chain cannot carry, and the learner's order of fitting (#46):
//
// - a chain at the scene's root whose ikHandle is its own control (keyed by time curves), its pole given by the
//   handle's poleVector channels, no pole-vector constraint (maya-usd's UsdExportEulerFilterTest.ma): the start joint's
//   operators failed validation only after its children had been fitted against it as their anchor, so that every
//   mover of theirs moved "the anchor" and no helper was left to be their goal; and the handle's pole vector and twist,
//   composed after the chain as the start joint's own operators, turn it about the chain's line at rest, not about
//   the line to the goal (0.19 cm per unit). The children are fitted again once the start joint has its chain, and the
//   channels that do not compose with it are held at rest, each with why;
// - a toe under a foot that is only point-constrained to its control: it left the foot while the world control's
//   turns, which carry the foot along arcs without turning it, were still modelled (the spider's right toes, 0.07 to
//   0.23 cm per unit off), and goes back relative to the foot once those are discarded and the foot validates;
// - a chain under a body joint that a control scales, its start joint not compensating the body's scale: a scale
//   channel shears the chain (a spider's legs under its body control's scale channels, 0.076 to 0.155 cm per unit
//   off), which no rigid base carries: the chain is fitted without it, and it is held at rest.
//
// Then the public scenes, where ../shared/maya is present.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>
#include <string>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "inversion/learn/learner.h"
#include "inversion/learn/maya_chain_scene.h"
#include "inversion/model/approximation.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

namespace fs = std::filesystem;

// j1 -> j2 -> j3 bent about y at rest, its ikHandle at the scene's root on j3's rest place, keyed on its translate;
// its poleVector set, nothing connected to it.
const std::string handlePoleChain = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode joint -n "j1";
	setAttr ".t" -type "double3" 0 2 0 ;
createNode joint -n "j2" -p "j1";
	setAttr ".t" -type "double3" 5 0 0 ;
	setAttr ".r" -type "double3" 0 -30 0 ;
createNode joint -n "j3" -p "j2";
	setAttr ".t" -type "double3" 4 0 0 ;
createNode ikEffector -n "effector1" -p "j2";
createNode ikHandle -n "ikHandle1";
	setAttr ".pv" -type "double3" 0 0.2 1 ;
	setAttr ".roc" yes;
createNode ikRPsolver -n "ikRPsolver";
createNode animCurveTL -n "ikHandle1_translateX";
	setAttr -s 2 ".ktv[0:1]"  1 8.4641 3 8.0;
createNode animCurveTL -n "ikHandle1_translateY";
	setAttr -s 2 ".ktv[0:1]"  1 2 3 1.5;
createNode animCurveTL -n "ikHandle1_translateZ";
	setAttr -s 2 ".ktv[0:1]"  1 2 3 2;
select -ne :time1;
	setAttr ".o" 1;
)" + test::mayaIkWiring + R"(connectAttr "ikHandle1_translateX.o" "ikHandle1.tx";
connectAttr "ikHandle1_translateY.o" "ikHandle1.ty";
connectAttr "ikHandle1_translateZ.o" "ikHandle1.tz";
)";

// j1 -> j2 -> j3 under root_jnt, which body_ctrl moves and scales; j1 does not compensate its parent's scale, so that
// a scale channel of body_ctrl scales and shears the chain. Its ikHandle hangs under hand_ctrl.
const std::string scaledBodyChain = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "body_ctrl";
createNode transform -n "hand_ctrl";
createNode joint -n "root_jnt";
createNode joint -n "j1" -p "root_jnt";
	setAttr ".t" -type "double3" 0 10 0 ;
	setAttr ".r" -type "double3" 20 0 0 ;
	setAttr ".ssc" no;
createNode joint -n "j2" -p "j1";
	setAttr ".t" -type "double3" 5 0 0 ;
	setAttr ".r" -type "double3" 0 0 90 ;
createNode joint -n "j3" -p "j2";
	setAttr ".t" -type "double3" 4 0 0 ;
createNode ikEffector -n "effector1" -p "j2";
createNode ikHandle -n "ikHandle1" -p "hand_ctrl";
	setAttr ".t" -type "double3" 5 13.7588 1.3681 ;
	setAttr ".pv" -type "double3" 0 0 1 ;
	setAttr ".roc" yes;
createNode ikRPsolver -n "ikRPsolver";
connectAttr "body_ctrl.t" "root_jnt.t";
connectAttr "body_ctrl.s" "root_jnt.s";
connectAttr "root_jnt.s" "j1.is";
)" + test::mayaIkWiring;

// A foot joint point-constrained to foot_ctrl, which hangs under world_ctrl, and a toe under the foot curled by the
// control's `curl` attribute: the world control's turns carry the foot along arcs without turning it, so that they
// have no order against the foot control's translations there, and the toe fails relative to the foot while they are
// still modelled.
const std::string pointConstrainedFoot = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "world_ctrl";
createNode transform -n "foot_ctrl" -p "world_ctrl";
	setAttr ".t" -type "double3" 4 1 2 ;
	addAttr -ci true -sn "curl" -ln "curl" -min -90 -max 90 -at "double";
	setAttr -k on ".curl";
createNode joint -n "foot_jnt";
	setAttr ".jo" -type "double3" 0 30 0 ;
createNode joint -n "toe_jnt" -p "foot_jnt";
	setAttr ".t" -type "double3" 2 -0.5 0.3 ;
	setAttr ".jo" -type "double3" 10 0 -20 ;
createNode unitConversion -n "unitConversion1";
	setAttr ".cf" 0.017453292519943295;
createNode pointConstraint -n "pc1" -p "foot_jnt";
	addAttr -ci true -k true -sn "w0" -ln "foot_ctrlW0" -dv 1 -min 0 -at "double";
	setAttr -k on ".w0";
connectAttr "foot_jnt.s" "toe_jnt.is";
connectAttr "foot_ctrl.curl" "unitConversion1.i";
connectAttr "unitConversion1.o" "toe_jnt.rz";
connectAttr "pc1.ctx" "foot_jnt.tx";
connectAttr "pc1.cty" "foot_jnt.ty";
connectAttr "pc1.ctz" "foot_jnt.tz";
connectAttr "foot_jnt.pim" "pc1.cpim";
connectAttr "foot_jnt.rp" "pc1.crp";
connectAttr "foot_jnt.rpt" "pc1.crt";
connectAttr "foot_ctrl.t" "pc1.tg[0].tt";
connectAttr "foot_ctrl.rp" "pc1.tg[0].trp";
connectAttr "foot_ctrl.rpt" "pc1.tg[0].trt";
connectAttr "foot_ctrl.pm" "pc1.tg[0].tpm";
connectAttr "pc1.w0" "pc1.tg[0].tw";
)";

GraphRigOptions autoOptions()
{
    GraphRigOptions options;
    options.autoParameters = true;
    options.autoOutputs = true;
    options.autoHelpers = true;
    options.cutTimeCurves = true;
    return options;
}

fs::path written(const std::string& name, const std::string& scene)
{
    return test::writeFile(test::scratchDir(fmt::format("held-chain.{}", ::getpid())) / name, scene);
}

void checkModelled(const Approximation& a)
{
    for (const ApproximationOutput& o : a.outputs)
        if (!o.modelled) MESSAGE(o.name << " is not modelled");
    CHECK_FALSE(a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
}

// The reason `parameter` was discarded, or "" when it was not.
std::string discardReason(const Approximation& a, const std::string& parameter)
{
    for (const DiscardedParameter& d : a.discarded)
        if (d.parameter.name == parameter) return d.reason;
    return "";
}

bool chainOutput(const Approximation& a, const std::string& joint)
{
    const ApproximationOutput& o = a.outputs[static_cast<std::size_t>(test::outputIndex(a, joint))];
    return o.constraint >= 0 &&
           a.constraints[static_cast<std::size_t>(o.constraint)].kind == ConstraintKind::planarChain;
}

TEST_CASE("held chain inputs: a chain whose handle is its own control, its pole the handle's poleVector channels")
{
    const fs::path file = written("handle_pole.ma", handlePoleChain);
    GraphRigFunction rig(file, autoOptions());
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    checkModelled(a);
    // Each joint is a planar chain read from the handle, the children included (fitted again once j1 had its chain).
    for (const char* joint : {"j1", "j2", "j3"}) {
        CAPTURE(joint);
        CHECK(chainOutput(a, joint));
    }
    CHECK(a.validation.maxRelativeError < 1e-6);
    for (const char* channel : {"ikHandle1.poleVectorX", "ikHandle1.poleVectorY", "ikHandle1.poleVectorZ"}) {
        CAPTURE(channel);
        CHECK(discardReason(a, channel).find("held at its rest value") != std::string::npos);
    }
}

TEST_CASE("held chain inputs: a body control's scale channels that shear the chain under it are held at rest")
{
    const fs::path file = written("scaled_body.ma", scaledBodyChain);
    GraphRigOptions options{
        {"body_ctrl.translate?", "body_ctrl.scale?", "hand_ctrl.translate?"}, {"root_jnt", "j1", "j2", "j3"}, {}, {}};
    options.autoHelpers = true;
    GraphRigFunction rig(file, options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    checkModelled(a);
    CHECK(chainOutput(a, "j1"));
    CHECK(chainOutput(a, "j2"));
    // The scale that shears the chain is held (it has no order with the body's translation on the chain's joints);
    // the body's translation, which carries the chain rigidly, is modelled.
    CHECK(discardReason(a, "body_ctrl.scaleY").starts_with("a scale channel that cannot be ordered with"));
    CHECK(discardReason(a, "body_ctrl.scaleY").ends_with("it is held at its rest value"));
    CHECK(discardReason(a, "body_ctrl.translateX").empty());
}

TEST_CASE("held chain inputs: a toe that left its foot while the foot was mispredicted goes back once it validates")
{
    const fs::path file = written("foot.ma", pointConstrainedFoot);
    const GraphRigOptions options{
        {"world_ctrl.rotate?", "foot_ctrl.translate?", "foot_ctrl.curl"}, {"foot_jnt", "toe_jnt"}, {}, {}};
    GraphRigFunction rig(file, options);
    const Approximation a = learnApproximation(rig, LearnOptions{}, file.string());
    checkModelled(a);
    // The world's turns are discarded (no order on the foot), and the toe is back relative to the foot.
    CHECK(discardReason(a, "world_ctrl.rotateY").find("cannot be ordered") != std::string::npos);
    const ApproximationOutput& toe = a.outputs[static_cast<std::size_t>(test::outputIndex(a, "toe_jnt"))];
    CHECK(toe.parent == test::outputIndex(a, "foot_jnt"));
}

TEST_CASE("held chain inputs: the public scenes' spider legs and maya-usd's root chain are modelled, where present")
{
    const fs::path folder = test::sourceDir() / "../shared/maya";
    const fs::path spider = folder / "Squamashii__UVUFall2008/Rigging/SpiderBot/Spencer_SpiderBot_Anim_001.ma";
    const fs::path euler =
        folder / "Autodesk__maya-usd/test/lib/usd/translators/UsdExportEulerFilterTest/UsdExportEulerFilterTest.ma";
    if (!fs::exists(spider) || !fs::exists(euler)) {
        MESSAGE("[skipped] ../shared/maya's Spencer_SpiderBot_Anim_001.ma or UsdExportEulerFilterTest.ma is absent");
        return;
    }
    for (const fs::path& scene : {euler, spider}) {
        CAPTURE(scene.filename().string());
        GraphRigFunction rig(scene, autoOptions());
        const Approximation a = learnApproximation(rig, LearnOptions{}, scene.string());
        checkModelled(a);
    }
}

}  // namespace
}  // namespace rig

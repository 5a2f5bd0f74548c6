// Curves written as a Maya scene that references the rig (nodes/curves/maya_anim_writer.h), read back with the Maya
// reader: on a rig of the test's own, in millimetres and radians, with two controls of the same leaf name and a time
// curve of its own on one of them, the scene's joints at each frame are the rig's with its controls at the curves'
// values (its own curve disconnected, a held plug set). And the namespaces' matching of a scene clip's joints.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/maya_clip.h"
#include "nodes/curves/maya_anim_writer.h"
#include "test_support.h"

namespace fs = std::filesystem;
using namespace rig;

namespace {

constexpr const char* rigScene = R"(//Maya ASCII 2018 scene
requires maya "2018";
currentUnit -l millimeter -a radian -t film;
createNode transform -n "rig";
createNode transform -n "root_ctrl" -p "rig";
createNode joint -n "shoulder_jnt" -p "root_ctrl";
	setAttr ".t" -type "double3" 0 1500 0 ;
createNode joint -n "elbow_jnt" -p "shoulder_jnt";
	setAttr ".t" -type "double3" 300 0 0 ;
createNode joint -n "wrist_jnt" -p "elbow_jnt";
	setAttr ".t" -type "double3" 250 0 0 ;
createNode transform -n "ctrl" -p "rig";
createNode transform -n "elbow_grp" -p "rig";
createNode transform -n "ctrl" -p "elbow_grp";
createNode animCurveTA -n "elbow_keys";
	setAttr -s 2 ".ktv[0:1]"  1 0 10 0.5;
connectAttr "|rig|ctrl.r" "shoulder_jnt.r";
connectAttr "elbow_grp|ctrl.rz" "elbow_jnt.rz";
connectAttr "elbow_keys.o" "elbow_grp|ctrl.rz";
)";

AnimFileCurve curve(const std::string& node, const std::string& leaf, AnimQuantity output, std::vector<AnimKey> keys)
{
    AnimFileCurve c;
    c.node = node;
    c.leaf = leaf;
    c.attribute = leaf;
    c.output = output;
    c.keys = std::move(keys);
    return c;
}

}  // namespace

TEST_CASE("maya anim writer: the scene read back plays the rig's joints under the curves")
{
    const auto dir = test::scratchDir("maya_anim_writer");
    const fs::path rigFile = test::writeFile(dir / "rig.ma", rigScene);
    MayaAnimScene scene;
    scene.fileName = "anim.ma";
    scene.rigPath = "rig.ma";
    scene.nameSpace = "ns";
    scene.referenceNode = "nsRN";
    auto rig = loadRigFile(rigFile, makeBuiltinRegistry(), nullptr, &scene.rig);
    scene.timeUnit = "ntsc";
    scene.curves = {
        curve("rig|ctrl", "rotateX", AnimQuantity::angular,
              {{1, 0, TangentType::auto_, TangentType::auto_},
               {5, 30, TangentType::auto_, TangentType::auto_},
               {10, -20, TangentType::auto_, TangentType::auto_}}),
        curve("elbow_grp|ctrl", "rotateZ", AnimQuantity::angular,
              {{1, 10, TangentType::linear, TangentType::linear}, {10, 80, TangentType::linear, TangentType::linear}}),
        curve("root_ctrl", "translateX", AnimQuantity::linear,
              {{2, 0, TangentType::spline, TangentType::spline}, {8, 25, TangentType::clamped, TangentType::step}}),
    };
    scene.held = {{"root_ctrl", "translateZ", AnimQuantity::linear, 7.0}};
    const std::string text = formatMayaAnimScene(scene);
    CHECK(text.find("\ncurrentUnit -l millimeter -a radian -t ntsc;\n") != std::string::npos);
    CHECK(text.find("\n\t\t4 \"ns:elbow_keys.o\" \"|ns:rig|ns:elbow_grp|ns:ctrl.rz\" \"\"\n") != std::string::npos);
    CHECK(text.find("\n\t\t2 \"ns:root_ctrl\" \"translateZ\" \" 70\"\n") != std::string::npos);
    CHECK(text.find("\n\t\t5 4 \"nsRN\" \"ns:rig|ns:ctrl.rotateX\" \"nsRN.placeHolderList[1]\" \"\"\n") !=
          std::string::npos);
    CHECK(text.find(
              "createNode animCurveTL -n \"root_ctrl_translateX\";\n\tsetAttr \".wgt\" no;\n\tsetAttr -s 2 "
              "\".ktv[0:1]\" 2 0 8 250;\n\tsetAttr -s 2 \".kit[0:1]\" 9 10;\n\tsetAttr -s 2 \".kot[0:1]\" 9 5;\n") !=
          std::string::npos);
    CHECK(text.find("playbackOptions -min 1 -max 10 ") != std::string::npos);
    const fs::path written = test::writeFile(dir / "anim.ma", text);

    MayaSceneInfo info;
    auto anim = loadRigFile(written, makeBuiltinRegistry(), nullptr, &info);
    CHECK(info.timeUnit == "ntsc");
    CHECK(info.playbackRange == std::pair{1.0, 10.0});
    // The expected rig: its own curve disconnected, the controls set to the curves' values, the held plug set.
    const Plug elbow = rig->plug("elbow_grp|ctrl.rotateZ");
    rig->disconnect(rig->incomingConnection(elbow)->source, elbow);
    rig->setValue(rig->plug("root_ctrl.translateZ"), 7.0);
    std::vector<AnimCurve> curves;
    for (const auto& c : scene.curves) curves.push_back(AnimCurve::build(c.keys));
    for (double frame = 1; frame <= 10; ++frame) {
        INFO("frame " << frame);
        for (std::size_t c = 0; c < curves.size(); ++c) {
            const double value = curves[c].evaluate(frame);
            rig->setValue(rig->plug(scene.curves[c].plugName()),
                          scene.curves[c].output == AnimQuantity::angular ? value * std::numbers::pi / 180.0 : value);
        }
        anim->setTime(frame);
        for (const char* joint : {"shoulder_jnt", "elbow_jnt", "wrist_jnt"}) {
            const auto expected =
                std::get<Eigen::Matrix4d>(rig->getValue(rig->plug(std::string(joint) + ".worldMatrix")));
            const auto got =
                std::get<Eigen::Matrix4d>(anim->getValue(anim->plug("ns:" + std::string(joint) + ".worldMatrix")));
            CHECK((got - expected).cwiseAbs().maxCoeff() < 1e-9);
        }
    }
}

TEST_CASE("maya clip: joints are matched to the rig's with or without namespaces")
{
    CHECK(withoutNamespaces("hero:grp|hero:hips") == "grp|hips");
    CHECK(withoutNamespaces("a:b:ctrl.rotateX") == "ctrl.rotateX");
    CHECK(withoutNamespaces("hips") == "hips");
    TargetClip clip;
    clip.joints = {"hero:hips", "hero:spine", "hips_extra", "x:arm", "y:arm", "other:head"};
    const std::vector<std::string> rig{"hips", "rig:spine", "arm", "head", "rig:head"};
    CHECK(matchNamespaces(clip, rig) == 2);
    // "x:arm" and "y:arm" would both be "arm", and two rig joints are "head" without their namespaces: kept.
    CHECK(clip.joints == std::vector<std::string>{"hips", "rig:spine", "hips_extra", "x:arm", "y:arm", "other:head"});
}

// The Maya ASCII reader on small scenes written here (docs/maya.md): the MEL Maya writes, names as Maya shows them,
// units, DAG parenting, IK chains solved as Maya's solver does, references with namespaces and edits, and every
// malformed input refused in one line with file:line:col.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Geometry>

#include "graph/maya/ma_parser.h"
#include "graph/maya/maya_loader.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

using namespace rig;
constexpr double pi = std::numbers::pi;

const std::string header =
    "//Maya ASCII 2023 scene\nrequires maya \"2023\";\ncurrentUnit -l centimeter -a degree -t film;\n";

std::unique_ptr<Graph> load(const std::string& text, MayaSceneInfo* info = nullptr)
{
    return loadMayaText(text, "scene.ma", makeBuiltinRegistry(), info);
}

Eigen::Vector3d vec(Graph& g, const std::string& plug) { return std::get<Eigen::Vector3d>(g.getValue(g.plug(plug))); }
Eigen::Matrix4d mat(Graph& g, const std::string& plug) { return std::get<Eigen::Matrix4d>(g.getValue(g.plug(plug))); }

}  // namespace

TEST_CASE("maya parser: statements, strings with escapes, joined strings, comments")
{
    const auto s = maya::parseStatements(
        "//Maya ASCII\n/* a block\n comment */ setAttr \".b\" -type \"string\" \"a \\\"q\\\"\"\n + \"b\";\n"
        "createNode joint -n \"j1\"; // trailing\n",
        "x.ma");
    REQUIRE(s.size() == 2);
    CHECK(s[0].command() == "setAttr");
    CHECK(s[0].words.back().text == "a \"q\"b");
    CHECK(s[0].line() == 3);
    CHECK(s[1].words[3].text == "j1");
    CHECK(s[1].words[3].quoted);
}

TEST_CASE("maya parser: truncated files and unterminated strings are one line with file:line:col")
{
    CHECK(test::errorOf([] { maya::parseStatements("createNode joint -n \"j1", "t.ma"); }) ==
          "t.ma:1:21: a string begun here is never closed (no closing '\"'): the scene is truncated");
    CHECK(test::errorOf([] { maya::parseStatements("createNode joint;\nsetAttr \".t\" 1 2", "t.ma"); }) ==
          "t.ma:2:1: the file ends inside the statement 'setAttr' begun here (no ';'): the scene is truncated; save "
          "it again from Maya");
    CHECK(test::errorOf([] { maya::parseStatements("/* open", "t.ma"); }) ==
          "t.ma:1:1: a comment begun here is never closed ('*/')");
}

TEST_CASE("maya scene: joints with orients, DAG parenting, short and long names, saved time")
{
    MayaSceneInfo info;
    auto g = load(header +
                      "createNode transform -n \"grp\";\n"
                      "\tsetAttr \".t\" -type \"double3\" 0 10 0 ;\n"
                      "\tsetAttr \".ry\" 90;\n"
                      "createNode joint -n \"hip\" -p \"grp\";\n"
                      "\tsetAttr \".t\" -type \"double3\" 1 0 0 ;\n"
                      "\tsetAttr \".jo\" -type \"double3\" 0 0 90 ;\n"
                      "\tsetAttr \".radi\" 0.5;\n"
                      "createNode joint -n \"knee\" -p \"hip\";\n"
                      "\tsetAttr \".translateX\" 5;\n"
                      "\tsetAttr -k on \".rz\" -45;\n"
                      "select -ne :time1;\n\tsetAttr \".o\" 12;\n"
                      "connectAttr \"hip.s\" \"knee.is\";\n",
                  &info);
    CHECK(info.savedTime == 12.0);
    CHECK(g->time() == 12.0);
    // grp: T(0,10,0) Ry(90); hip at grp * (1,0,0) = (0, 10, -1); hip's X axis along grp's Y (jo Z 90).
    const Eigen::Matrix4d knee = mat(*g, "knee.worldMatrix");
    const Eigen::Vector3d expected = Eigen::Vector3d(0, 10, -1) + 5 * Eigen::Vector3d(0, 1, 0);
    CHECK((knee.block<3, 1>(0, 3) - expected).norm() < 1e-12);
    CHECK(vec(*g, "knee.rotate").z() == doctest::Approx(-pi / 4));
    CHECK(info.notEvaluatedAttributes.at("joint.radi") == 1);
}

TEST_CASE("maya scene: a leaf name used twice becomes its shortest unique DAG path")
{
    auto g = load(header +
                  "createNode transform -n \"L\";\ncreateNode transform -n \"ctrl\" -p \"L\";\n"
                  "createNode transform -n \"R\";\ncreateNode transform -n \"ctrl\" -p \"R\";\n"
                  "\tsetAttr \".tx\" 3;\n");
    CHECK(g->findNode("L|ctrl") >= 0);
    CHECK(g->findNode("R|ctrl") >= 0);
    CHECK(g->findNode("ctrl") < 0);
    CHECK(vec(*g, "R|ctrl.translate").x() == 3.0);
}

TEST_CASE("maya scene: currentUnit meter and radian become cm and radians")
{
    auto g = load(
        "//Maya ASCII 2023 scene\ncurrentUnit -l meter -a radian -t ntsc;\n"
        "createNode transform -n \"a\";\n\tsetAttr \".t\" -type \"double3\" 1 2 3 ;\n\tsetAttr \".rx\" 0.5;\n");
    CHECK((vec(*g, "a.translate") - Eigen::Vector3d(100, 200, 300)).norm() < 1e-12);
    CHECK(vec(*g, "a.rotate").x() == doctest::Approx(0.5));
}

TEST_CASE("maya scene: dynamic attributes, a constraint's weight alias, nodes that move no joint are counted")
{
    MayaSceneInfo info;
    auto g = load(header +
                      "createNode transform -n \"ctrl\";\n"
                      "\taddAttr -ci true -k true -sn \"fk\" -ln \"ikFk\" -min 0 -max 1 -at \"double\";\n"
                      "\taddAttr -ci true -sn \"mode\" -ln \"mode\" -min 0 -max 2 -en \"a:b:c\" -at \"enum\";\n"
                      "\tsetAttr \".fk\" 0.25;\n"
                      "\tsetAttr \".mode\" 2;\n"
                      "\tsetAttr -l on \".tx\";\n"
                      "\tsetAttr -k off -cb on \".ry\";\n"
                      "createNode nurbsCurve -n \"ctrlShape\" -p \"ctrl\";\n"
                      "createNode lookAt -n \"cameraAim\";\n"
                      "createNode lambert -n \"mat\";\n",
                  &info);
    CHECK(std::get<double>(g->getValue(g->plug("ctrl.ikFk"))) == 0.25);
    CHECK(std::get<int>(g->getValue(g->plug("ctrl.mode"))) == 2);
    CHECK(g->spec(g->plug("ctrl.ikFk")).keyable);
    CHECK(info.plugStates.at("ctrl.translateX").locked == true);
    CHECK(info.plugStates.at("ctrl.rotateY").keyable == false);
    CHECK(info.plugStates.at("ctrl.rotateY").channelBox == true);
    CHECK(info.notEvaluatedTypes.at("nurbsCurve") == 1);
    CHECK(info.notEvaluatedTypes.at("lambert") == 1);
    // Maya's lookAt (a camera's aim) is not this project's lookAt.
    CHECK(info.notEvaluatedTypes.at("lookAt") == 1);
    CHECK(g->findNode("cameraAim") < 0);
}

TEST_CASE("maya scene: a node this library does not evaluate that drives a joint is refused in one line")
{
    const std::string text = header +
                             "createNode joint -n \"arm\";\n"
                             "createNode HIKSolverNode -n \"L_arm_HIK\";\n"
                             "connectAttr \"L_arm_HIK.ot\" \"arm.t\";\n";
    CHECK(test::errorOf([&] { load(text); }) ==
          "scene.ma:6:13: node 'L_arm_HIK' (HIKSolverNode) drives joint 'arm'; this reader does not evaluate "
          "HIKSolverNode");
    // The same node driving nothing that reaches a joint is only counted.
    MayaSceneInfo info;
    load(header +
             "createNode transform -n \"loc\";\ncreateNode HIKSolverNode -n \"hik\";\n"
             "connectAttr \"hik.ot\" \"loc.t\";\n",
         &info);
    CHECK(info.notEvaluatedTypes.at("HIKSolverNode") == 1);
}

TEST_CASE("maya scene: bad input is one line with file:line:col")
{
    CHECK(test::errorOf([] { load(header + "connectAttr \"nobody.t\" \"other.t\";\n"); }) ==
          "scene.ma:4:13: connectAttr names 'nobody', which is no node of the scene");
    CHECK(test::errorOf([] { load(header + "createNode joint -n \"a\" -p \"missing\";\n"); }) ==
          "scene.ma:4:28: no node named 'missing' in the scene so far");
    CHECK(test::errorOf([] { load(header + "createNode transform -n \"a\";\n\tsetAttr \".tx\" 1e400;\n"); }) ==
          "scene.ma:5:10: a.tx: 1e400 is not a finite number a double holds");
    CHECK(test::errorOf([] { load(header + "createNode transform -n \"a\";\n\tsetAttr \".tx\" nan;\n"); }) ==
          "scene.ma:5:10: a.tx: nan is not a finite number a double holds");
    CHECK(test::errorOf([] {
              load(header +
                   "createNode transform -n \"a\";\ncreateNode transform -n \"b\";\n"
                   "connectAttr \"a.wm\" \"b.pm\";\nconnectAttr \"b.wm\" \"a.pm\";\n");
          }).find("scene.ma:7:13: cannot connect b.worldMatrix -> a.parentMatrix: it would close a cycle") !=
          std::string::npos);
    CHECK(test::errorOf([] { loadMayaText("createNode joint;", "x.ma", makeBuiltinRegistry()); }) ==
          "x.ma:1:1: not a Maya ASCII scene (its first line is not '//Maya ASCII ...')");
    const auto mb = test::writeFile(test::scratchDir("maya_mb") / "rig.mb", std::string("FOR4\0\0\0\x20", 8));
    CHECK(test::errorOf([&] { loadRigFile(mb, makeBuiltinRegistry()); }) ==
          mb.string() + ": a Maya binary scene (.mb) is not read; save it as Maya ASCII (.ma)");
}

namespace {

// A two-bone ikRPsolver chain j1 -> j2 -> j3 (5 and 3 cm along x), j2's extra attribute lines `j2Lines`, its
// handle at `handleAt` with its pole vector along +y.
std::string ikChainScene(const std::string& j2Lines, const std::string& handleAt)
{
    return header +
           "createNode joint -n \"j1\";\n"
           "createNode joint -n \"j2\" -p \"j1\";\n\tsetAttr \".t\" -type \"double3\" 5 0 0 ;\n" +
           j2Lines +
           "createNode joint -n \"j3\" -p \"j2\";\n\tsetAttr \".t\" -type \"double3\" 3 0 0 ;\n"
           "createNode ikEffector -n \"effector1\" -p \"j2\";\n"
           "createNode ikHandle -n \"ikHandle1\";\n"
           "\tsetAttr \".t\" -type \"double3\" " +
           handleAt +
           " ;\n"
           "\tsetAttr \".pv\" -type \"double3\" 0 1 0 ;\n"
           "createNode ikRPsolver -n \"ikRPsolver\";\n"
           "connectAttr \"j1.s\" \"j2.is\";\nconnectAttr \"j2.s\" \"j3.is\";\n"
           "connectAttr \"j3.tx\" \"effector1.tx\";\nconnectAttr \"j3.ty\" \"effector1.ty\";\n"
           "connectAttr \"j3.tz\" \"effector1.tz\";\n"
           "connectAttr \"j1.msg\" \"ikHandle1.hsj\";\nconnectAttr \"effector1.hp\" \"ikHandle1.hee\";\n"
           "connectAttr \"ikRPsolver.msg\" \"ikHandle1.hsv\";\n";
}

// That chain with its handle at (20, 0, 0), past its reach: straight along x, and a pole vector a quarter turn about
// x (+y to +z) turns it a quarter turn.
void checkStraightChainTurnsWithPole(Graph& g)
{
    const Eigen::Matrix3d up = mat(g, "j1.worldMatrix").block<3, 3>(0, 0);
    CHECK((mat(g, "j3.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(8, 0, 0)).norm() < 1e-9);
    g.setValue(g.plug("ikHandle1.poleVector"), Eigen::Vector3d(0, 0, 1));
    const Eigen::Matrix3d quarter = Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
    CHECK((mat(g, "j1.worldMatrix").block<3, 3>(0, 0) - quarter * up).norm() < 1e-9);
}

}  // namespace

TEST_CASE("maya scene: a two-bone ikRPsolver chain reaches its handle and keeps its saved pose as a fixed point")
{
    // A chain bent in its XY plane; the handle saved at the effector (the end joint at (4, 3, 0): the rest pose is
    // Maya's answer), then moved: the end joint follows it.
    const std::string scene = ikChainScene("\tsetAttr \".r\" -type \"double3\" 0 0 90 ;\n", "5 3 0");
    MayaSceneInfo info;
    auto g = load(scene, &info);
    CHECK(info.savedIkRotate.count("j2") == 1);
    CHECK((mat(*g, "j3.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(5, 3, 0)).norm() < 1e-9);
    CHECK((vec(*g, "j2.rotate") - Eigen::Vector3d(0, 0, pi / 2)).norm() < 1e-9);
    g->setValue(g->plug("ikHandle1.translate"), Eigen::Vector3d(4, 4, 1));
    CHECK((mat(*g, "j3.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(4, 4, 1)).norm() < 1e-9);
    // Past its reach the chain is straight, and still turns with its pole vector about the line to the goal: the
    // plane keeps the reference pose's normal (a pole a quarter turn about x turns the chain a quarter turn).
    g->setValue(g->plug("ikHandle1.translate"), Eigen::Vector3d(20, 0, 0));
    checkStraightChainTurnsWithPole(*g);
}

TEST_CASE("maya scene: a joint orient-constrained to an IK chain's joint follows the solve, not its saved rotate")
{
    // A bound joint `bind` whose orientConstraint reads j1's rotate, as Maya writes it (`j1.r` into `.tg[0].tr`): the
    // solver's answer, not the rotation the scene saved on j1 (Grunt_Rig.ma's legs: their bound joints stayed at the
    // rest pose while the control chain bent).
    const std::string scene =
        ikChainScene("\tsetAttr \".r\" -type \"double3\" 0 0 90 ;\n", "5 3 0") +
        "createNode joint -n \"bind\";\n"
        "createNode orientConstraint -n \"bind_OC\" -p \"bind\";\n"
        "connectAttr \"j1.r\" \"bind_OC.tg[0].tr\";\nconnectAttr \"j1.ro\" \"bind_OC.tg[0].tro\";\n"
        "connectAttr \"j1.pm\" \"bind_OC.tg[0].tpm\";\nconnectAttr \"j1.jo\" \"bind_OC.tg[0].tjo\";\n"
        "connectAttr \"bind.pim\" \"bind_OC.cpim\";\nconnectAttr \"bind.jo\" \"bind_OC.cjo\";\n"
        "connectAttr \"bind_OC.crx\" \"bind.rx\";\nconnectAttr \"bind_OC.cry\" \"bind.ry\";\n"
        "connectAttr \"bind_OC.crz\" \"bind.rz\";\n";
    auto g = load(scene);
    const auto turnApart = [&] {
        return (mat(*g, "bind.worldMatrix").block<3, 3>(0, 0) - mat(*g, "j1.worldMatrix").block<3, 3>(0, 0)).norm();
    };
    CHECK(turnApart() < 1e-12);
    g->setValue(g->plug("ikHandle1.translate"), Eigen::Vector3d(4, 4, 1));
    CHECK((mat(*g, "j3.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(4, 4, 1)).norm() < 1e-9);
    CHECK(turnApart() < 1e-12);
}

TEST_CASE("maya scene: an ikSCsolver turns its chain toward the handle's orientation, whatever the saved pose")
{
    // One bone j1 -> j2 along x, its handle at the end; j1 saved twisted 45 degrees about the bone. Maya's ikSCsolver
    // is history independent: with the effector on the line to the handle, the start joint turns about that line so
    // that the effector's orientation comes as close as it can to the handle's (its Nodes reference, ikSCsolver).
    const auto scene = [](const std::string& handleLines) {
        return header +
               "createNode joint -n \"j1\";\n\tsetAttr \".r\" -type \"double3\" 45 0 0 ;\n"
               "createNode joint -n \"j2\" -p \"j1\";\n\tsetAttr \".t\" -type \"double3\" 5 0 0 ;\n"
               "createNode ikEffector -n \"effector1\" -p \"j1\";\n"
               "createNode ikHandle -n \"ikHandle1\";\n" +
               handleLines +
               "createNode ikSCsolver -n \"ikSCsolver\";\n"
               "connectAttr \"j2.tx\" \"effector1.tx\";\nconnectAttr \"j2.ty\" \"effector1.ty\";\n"
               "connectAttr \"j2.tz\" \"effector1.tz\";\n"
               "connectAttr \"j1.msg\" \"ikHandle1.hsj\";\nconnectAttr \"effector1.hp\" \"ikHandle1.hee\";\n"
               "connectAttr \"ikSCsolver.msg\" \"ikHandle1.hsv\";\n";
    };
    const auto turnOf = [](Graph& g) { return Eigen::Matrix3d(mat(g, "j1.worldMatrix").block<3, 3>(0, 0)); };
    // The handle unturned at the end: the saved twist is undone.
    auto g = load(scene("\tsetAttr \".t\" -type \"double3\" 5 0 0 ;\n"));
    CHECK((turnOf(*g) - Eigen::Matrix3d::Identity()).norm() < 1e-12);
    // The handle turned 30 degrees about the bone: the bone turns with it.
    g->setValue(g->plug("ikHandle1.rotate"), Eigen::Vector3d(pi / 6, 0, 0));
    CHECK((turnOf(*g) - Eigen::AngleAxisd(pi / 6, Eigen::Vector3d::UnitX()).toRotationMatrix()).norm() < 1e-12);
    // Moved to +y and turned a quarter about z: the effector's orientation can match it exactly.
    g->setValue(g->plug("ikHandle1.translate"), Eigen::Vector3d(0, 5, 0));
    g->setValue(g->plug("ikHandle1.rotate"), Eigen::Vector3d(0, 0, pi / 2));
    CHECK((turnOf(*g) - Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix()).norm() < 1e-12);
    CHECK((mat(*g, "j2.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(0, 5, 0)).norm() < 1e-12);
}

TEST_CASE("maya scene: a chain straight at rest turns with its pole vector in its preferred angles' plane")
{
    // Straight along x; j2's preferred angle bends it toward +y. The goal past the reach keeps it straight: the pole
    // a quarter turn about x turns the chain a quarter turn, as the plane its preferred angles give is turned.
    const std::string scene = ikChainScene("\tsetAttr \".pa\" -type \"double3\" 0 0 90 ;\n", "20 0 0");
    auto g = load(scene);
    checkStraightChainTurnsWithPole(*g);
}

TEST_CASE("maya references: namespaces, placeholder edits, setAttr edits, a missing one, a loop")
{
    const auto dir = test::scratchDir("maya_references");
    std::filesystem::create_directories(dir / "rigs");
    std::filesystem::create_directories(dir / "shots");
    test::writeFile(dir / "rigs" / "arm.ma",
                    header +
                        "createNode transform -n \"ctrl\";\ncreateNode joint -n \"bone\" -p \"ctrl\";\n"
                        "\tsetAttr \".tx\" 2;\n");
    // The animation scene names its reference by an absolute path from another machine: found by its suffix.
    const auto anim =
        test::writeFile(dir / "shots" / "shot.ma",
                        "//Maya ASCII 2023 scene\nfile -r -ns \"hero\" -rfn \"heroRN\" \"C:/work/rigs/arm.ma\";\n"
                        "requires maya \"2023\";\ncurrentUnit -l centimeter -a degree -t film;\n"
                        "createNode reference -n \"heroRN\";\n"
                        "\tsetAttr \".ed\" -type \"dataReferenceEdits\" \"heroRN\" \"heroRN\" 2\n"
                        "\t\t2 \"|hero:ctrl|hero:bone\" \"translateY\" \" 7\"\n"
                        "\t\t5 4 \"heroRN\" \"|hero:ctrl.translateZ\" \"heroRN.placeHolderList[1]\" \"\";\n"
                        "createNode transform -n \"driver\";\n\tsetAttr \".tz\" 4;\n"
                        "connectAttr \"driver.tz\" \"heroRN.phl[1]\";\n");
    std::vector<std::filesystem::path> read;
    auto g = loadRigFile(anim, makeBuiltinRegistry(), &read);
    CHECK(read.size() == 2);
    CHECK((mat(*g, "hero:bone.worldMatrix").block<3, 1>(0, 3) - Eigen::Vector3d(2, 7, 4)).norm() < 1e-12);

    MayaSceneInfo info;
    const auto lonely = test::writeFile(dir / "lonely.ma",
                                        "//Maya ASCII 2023 scene\nfile -r -ns \"x\" \"gone.ma\";\n"
                                        "createNode transform -n \"a\";\n");
    loadRigFile(lonely, makeBuiltinRegistry(), nullptr, &info);
    REQUIRE(info.warnings.size() == 1);
    CHECK(info.warnings[0].find("lonely.ma:2:1: reference 'gone.ma' not found") != std::string::npos);

    // A joint of the scene driven from the missing reference: one error line.
    const auto driven = test::writeFile(dir / "driven.ma",
                                        "//Maya ASCII 2023 scene\nfile -r -ns \"x\" \"gone.ma\";\n"
                                        "createNode joint -n \"j\";\n"
                                        "connectAttr \"x:ctrl.tx\" \"j.tx\";\n");
    CHECK(test::errorOf([&] {
              loadRigFile(driven, makeBuiltinRegistry());
          }).find("driven.ma:4:13: a node drives joint 'j' but it is in a reference that was not found (x:ctrl)") !=
          std::string::npos);

    const auto loop = test::writeFile(dir / "loop.ma", "//Maya ASCII 2023 scene\nfile -r -ns \"x\" \"loop.ma\";\n");
    CHECK(test::errorOf([&] {
              loadRigFile(loop, makeBuiltinRegistry());
          }).find("loop.ma:2:1: the reference 'loop.ma' loops back to a scene that references it") !=
          std::string::npos);
}

TEST_CASE(
    "maya scene: a parent constraint reading the joint it drives, its weight alias, and its offset from the "
    "target's pivot")
{
    // The control's pivot is at (0, 5, 0) and it sits at (2, 0, 0): its pivot is at (2, 5, 0) in the world. The joint
    // keeps an offset of (0, 1, 0) from that pivot: it lands at (2, 6, 0), and turns with the control.
    const std::string scene =
        header +
        "createNode transform -n \"ctrl\";\n\tsetAttr \".t\" -type \"double3\" 2 0 0 ;\n"
        "\tsetAttr \".rp\" -type \"double3\" 0 5 0 ;\n\tsetAttr \".ry\" 90;\n"
        "createNode joint -n \"hip\";\n"
        "createNode parentConstraint -n \"hip_pc\" -p \"hip\";\n"
        "\taddAttr -dcb 0 -ci true -k true -sn \"w0\" -ln \"ctrlW0\" -dv 1 -min 0 -at \"double\";\n"
        "\tsetAttr \".erp\" yes;\n"
        "\tsetAttr \".tg[0].tot\" -type \"double3\" 0 1 0 ;\n"
        "connectAttr \"hip_pc.ctx\" \"hip.tx\";\nconnectAttr \"hip_pc.cty\" \"hip.ty\";\n"
        "connectAttr \"hip_pc.ctz\" \"hip.tz\";\nconnectAttr \"hip_pc.crx\" \"hip.rx\";\n"
        "connectAttr \"hip_pc.cry\" \"hip.ry\";\nconnectAttr \"hip_pc.crz\" \"hip.rz\";\n"
        "connectAttr \"hip.ro\" \"hip_pc.cro\";\nconnectAttr \"hip.pim\" \"hip_pc.cpim\";\n"
        "connectAttr \"hip.rp\" \"hip_pc.crp\";\nconnectAttr \"hip.rpt\" \"hip_pc.crt\";\n"
        "connectAttr \"hip.jo\" \"hip_pc.cjo\";\n"
        "connectAttr \"ctrl.t\" \"hip_pc.tg[0].tt\";\nconnectAttr \"ctrl.rp\" \"hip_pc.tg[0].trp\";\n"
        "connectAttr \"ctrl.rpt\" \"hip_pc.tg[0].trt\";\nconnectAttr \"ctrl.r\" \"hip_pc.tg[0].tr\";\n"
        "connectAttr \"ctrl.ro\" \"hip_pc.tg[0].tro\";\nconnectAttr \"ctrl.s\" \"hip_pc.tg[0].ts\";\n"
        "connectAttr \"ctrl.pm\" \"hip_pc.tg[0].tpm\";\n"
        "connectAttr \"hip_pc.w0\" \"hip_pc.tg[0].tw\";\n";
    auto g = load(scene);
    const Eigen::Matrix4d hip = mat(*g, "hip.worldMatrix");
    CHECK((hip.topRightCorner<3, 1>() - Eigen::Vector3d(2, 6, 0)).norm() < 1e-12);
    CHECK((hip.topLeftCorner<3, 3>() - Eigen::AngleAxisd(pi / 2, Eigen::Vector3d::UnitY()).toRotationMatrix()).norm() <
          1e-12);
    // The weight is the constraint's targetWeight[0] under Maya's name for it.
    g->setValue(g->plug("hip_pc.targetWeight[0]"), 0.0);
    CHECK(mat(*g, "hip.worldMatrix").topRightCorner<3, 1>().norm() < 1e-12);
}

TEST_CASE("maya scene: time curves at the saved time, set-driven keys through unitConversion, vectors converted")
{
    // ctrl.rx keyed 0 -> 90 degrees over frames 0 -> 10 (linear); a set-driven key turns the joint's rz by the same
    // angle through Maya's unitConversion nodes (radians to degrees, and back); a unitConversion between vectors
    // halves the control's translate into the joint's.
    const std::string scene =
        header +
        "createNode transform -n \"ctrl\";\n"
        "createNode animCurveTA -n \"ctrl_rotateX\";\n\tsetAttr \".tan\" 2;\n\tsetAttr \".wgt\" no;\n"
        "\tsetAttr -s 2 \".ktv[0:1]\"  0 0 10 90;\n"
        "createNode joint -n \"j\";\n"
        "createNode animCurveUA -n \"j_rotateZ\";\n\tsetAttr \".tan\" 2;\n\tsetAttr -s 2 \".ktv[0:1]\"  0 0 90 90;\n"
        "createNode unitConversion -n \"uc1\";\n\tsetAttr \".cf\" 57.295779513082323;\n"
        "createNode unitConversion -n \"uc2\";\n\tsetAttr \".cf\" 0.5;\n"
        "select -ne :time1;\n\tsetAttr \".o\" 5;\n"
        "connectAttr \"ctrl_rotateX.o\" \"ctrl.rx\";\nconnectAttr \":time1.o\" \"ctrl_rotateX.i\";\n"
        "connectAttr \"ctrl.rx\" \"uc1.i\";\nconnectAttr \"uc1.o\" \"j_rotateZ.i\";\nconnectAttr \"j_rotateZ.o\" "
        "\"j.rz\";\n"
        "connectAttr \"ctrl.t\" \"uc2.i\";\nconnectAttr \"uc2.o\" \"j.t\";\n";
    MayaSceneInfo info;
    auto g = load(scene, &info);
    CHECK(info.vectorConversions == 1);
    CHECK(vec(*g, "ctrl.rotate").x() == doctest::Approx(pi / 4));
    CHECK(vec(*g, "j.rotate").z() == doctest::Approx(pi / 4));
    g->setValue(g->plug("ctrl.translate"), Eigen::Vector3d(2, 4, 6));
    CHECK((vec(*g, "j.translate") - Eigen::Vector3d(1, 2, 3)).norm() < 1e-12);
    g->setTime(10);
    CHECK(vec(*g, "j.rotate").z() == doctest::Approx(pi / 2));
}

TEST_CASE("maya scene: a character set passes its elements through, and an expression it cannot read is refused")
{
    const std::string scene = header +
                              "createNode transform -n \"ctrl\";\ncreateNode joint -n \"j\" -p \"ctrl\";\n"
                              "createNode character -n \"hero\";\n\tsetAttr \".lv[3]\" 7;\n"
                              "createNode animCurveTL -n \"hero_ty\";\n\tsetAttr -s 2 \".ktv[0:1]\"  0 1 10 11;\n"
                              "connectAttr \"hero_ty.o\" \"hero.lv[4]\";\n"
                              "connectAttr \"hero.lv[3]\" \"ctrl.tx\";\nconnectAttr \"hero.lv[4]\" \"ctrl.ty\";\n";
    auto g = load(scene);
    g->setTime(5);
    CHECK((vec(*g, "ctrl.translate") - Eigen::Vector3d(7, 6, 0)).norm() < 1e-12);

    const std::string expression = header +
                                   "createNode joint -n \"j\";\n"
                                   "createNode expression -n \"wobble\";\n"
                                   "\tsetAttr -k on \".nds\";\n\tsetAttr -s 2 \".out\";\n"
                                   "\tsetAttr \".ixp\" -type \"string\" \".O[0] = `getAttr ball.tx`;\";\n"
                                   "connectAttr \"wobble.out[0]\" \"j.tx\";\n";
    const std::string message = test::errorOf([&] { load(expression); });
    CHECK(message.find("scene.ma:5:1: node 'wobble' (expression) drives joint 'j'; expression:") == 0);
}

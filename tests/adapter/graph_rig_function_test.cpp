// GraphRigFunction: parameters from plug globs, joints as outputs, helper frames after them (named or found),
// counted evaluations, the rig files' fingerprint, and one-line errors for globs that match nothing usable.
#include <doctest/doctest.h>

#include <numbers>

#include <yaml-cpp/yaml.h>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "adapter/inversion_spec.h"
#include "core/error.h"
#include "inversion/model/approximation.h"
#include "test_support.h"

using namespace rig;

namespace {

const std::string arm = (test::sourceDir() / "rigs/examples/arm.yaml").string();

std::vector<std::string> names(const std::vector<RigParameter>& parameters)
{
    std::vector<std::string> out;
    for (const auto& p : parameters) out.push_back(p.name);
    return out;
}

std::string errorOf(const std::string& rig, const GraphRigOptions& options)
{
    try {
        GraphRigFunction f(rig, options);
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

// FNV-1a 64 written out again, independently of the library's.
std::uint64_t fnv(const std::string& bytes, std::uint64_t h = 14695981039346656037ull)
{
    for (unsigned char c : bytes) h = (h ^ c) * 1099511628211ull;
    return h;
}

}  // namespace

TEST_CASE("GraphRigFunction: parameters are free keyable numbers, vectors stand for their components")
{
    // shoulder.rotateY is driven by an animation curve: not a parameter, and the glob passes it by.
    GraphRigFunction f(arm, {{"shoulder.rotate?", "arm_ctrl.translate", "arm_ctrl.rotateX"}, {}, {}});
    CHECK(names(f.parameters()) == std::vector<std::string>{"shoulder.rotateX", "shoulder.rotateZ",
                                                            "arm_ctrl.translateX", "arm_ctrl.translateY",
                                                            "arm_ctrl.translateZ", "arm_ctrl.rotateX"});
    const RigParameter& angle = f.parameters()[0];
    CHECK(angle.angular);
    CHECK(!angle.limited);  // no declared limits: +-90 degrees is only where learning samples
    CHECK(angle.min == -std::numbers::pi / 2);
    CHECK(angle.max == std::numbers::pi / 2);
    const RigParameter& y = f.parameters()[3];
    CHECK(!y.angular);
    CHECK(y.defaultValue == 150.0);  // the current value
    CHECK(y.min == 100.0);           // +-50 cm around it
    CHECK(y.max == 200.0);
    // Every joint, in rig order, when no output glob is given.
    CHECK(f.outputs() == std::vector<std::string>{"shoulder", "elbow", "wrist"});

    // A declared min/max is the range, and it binds; a glob matching a plug twice lists it once.
    GraphRigFunction biped((test::sourceDir() / "rigs/biped.yaml").string(),
                           {{"L_hand_ctrl.fist", "L_hand_ctrl.f*", "spine_ctrl.squash"}, {"Left*Hand", "Hips"}, {}});
    REQUIRE(biped.parameters().size() == 2);
    CHECK(biped.parameters()[0].min == 0.0);
    CHECK(biped.parameters()[0].max == 10.0);
    CHECK(biped.parameters()[0].limited);
    CHECK(biped.parameters()[1].defaultValue == 1.0);
    CHECK(biped.parameters()[1].min == 0.5);
    CHECK(biped.outputs() == std::vector<std::string>{"Hips", "LeftHand"});
}

TEST_CASE("GraphRigFunction: evaluate sets the plugs, reads world matrices and counts")
{
    GraphRigFunction f(arm, {{"shoulder.rotateZ", "wrist.rotateX"}, {"wrist", "elbow"}, {}});
    std::vector<Eigen::Matrix4d> worlds;
    f.evaluate(std::vector<double>{0.5, 0.25}, worlds);
    CHECK(f.evaluationCount() == 1);
    REQUIRE(worlds.size() == 2);
    Graph& g = f.graph();
    CHECK(std::get<double>(g.getValue(g.plug("shoulder.rotateZ"))) == 0.5);
    CHECK(worlds[0] == std::get<Eigen::Matrix4d>(g.getValue(g.plug("elbow.worldMatrix"))));
    CHECK(worlds[1] == std::get<Eigen::Matrix4d>(g.getValue(g.plug("wrist.worldMatrix"))));
    // Back at rest: the rest pose again, bit for bit.
    std::vector<Eigen::Matrix4d> rest, again;
    f.evaluate(std::vector<double>{0.0, 0.0}, rest);
    f.evaluate(std::vector<double>{1.0, -1.0}, worlds);
    f.evaluate(std::vector<double>{0.0, 0.0}, again);
    CHECK(rest == again);
    CHECK(f.evaluationCount() == 4);
    try {
        f.evaluate(std::vector<double>{0.0}, worlds);
        FAIL("a wrong number of values must throw");
    }
    catch (const Error& e) {
        CHECK(e.kind() == ErrorKind::internal);
    }
}

TEST_CASE("GraphRigFunction: only joints computed since the last read are read again, however they were computed")
{
    GraphRigFunction f(arm, {{"shoulder.rotateZ", "wrist.rotateX"}, {"wrist", "elbow"}, {}});
    Graph& g = f.graph();
    const NodeId elbow = g.node("elbow"), wrist = g.node("wrist");
    std::vector<Eigen::Matrix4d> worlds;
    f.evaluate(std::vector<double>{0.5, 0.0}, worlds);
    // Moving the wrist computes the wrist and not the elbow, whose world is the one read before.
    const std::uint64_t elbowComputes = g.computeCount(elbow);
    const Eigen::Matrix4d elbowBefore = worlds[0];
    f.evaluate(std::vector<double>{0.5, 0.75}, worlds);
    CHECK(g.computeCount(elbow) == elbowComputes);
    CHECK(worlds[0] == elbowBefore);
    CHECK(worlds[1] == std::get<Eigen::Matrix4d>(g.getValue(g.plug("wrist.worldMatrix"))));
    // A plug set and pulled through graph() behind the function's back: the same values again must still
    // return what the graph now holds, not the joints as last read.
    g.setValue(g.plug("shoulder.rotateZ"), 1.25);
    const auto elbowNow = std::get<Eigen::Matrix4d>(g.getValue(g.plug("elbow.worldMatrix")));
    const auto wristNow = std::get<Eigen::Matrix4d>(g.getValue(g.plug("wrist.worldMatrix")));
    CHECK(elbowNow != elbowBefore);
    f.evaluate(std::vector<double>{0.5, 0.75}, worlds);
    CHECK(worlds[0] == elbowNow);
    CHECK(worlds[1] == wristNow);
    CHECK(g.computeCount(wrist) > 0);
}

TEST_CASE("GraphRigFunction: the fingerprint covers the rig file and every file it includes")
{
    const auto dir = test::scratchDir("graph-rig-fingerprint");
    const std::string part = "nodes:\n  - {name: j, type: joint}\n";
    const std::string main = "include:\n  - {file: part.yaml, namespace: a}\n";
    test::writeFile(dir / "part.yaml", part);
    test::writeFile(dir / "main.yaml", main);
    const GraphRigOptions options{{"a:j.rotateX"}, {}, {}};
    const std::string before = GraphRigFunction(dir / "main.yaml", options).fingerprint();
    CHECK(before == fmt::format("{:016x}", fnv(part, fnv(main))));
    CHECK(GraphRigFunction(dir / "main.yaml", options).fingerprint() == before);
    test::writeFile(dir / "part.yaml", part + "  - {name: k, type: joint}\n");
    CHECK(GraphRigFunction(dir / "main.yaml", options).fingerprint() != before);
}

TEST_CASE("GraphRigFunction: globs that match nothing usable are one-line errors with a suggestion")
{
    CHECK(errorOf(arm, {{"shoulder.rotatq?"}, {}, {}}) ==
          arm +
              ": parameter glob 'shoulder.rotatq?' matches no plug: node 'shoulder' has no keyable attribute matching "
              "'rotatq?'; did you mean 'shoulder.rotateX'?");
    CHECK(errorOf(arm, {{"sholder*.rotateX"}, {}, {}}) == arm +
                                                              ": parameter glob 'sholder*.rotateX' matches no plug: no "
                                                              "node matches 'sholder*'; did you mean 'shoulder'?");
    CHECK(errorOf(arm, {{"elbo.rotateZ"}, {}, {}}) ==
          arm + ": parameter 'elbo.rotateZ': no node named 'elbo'; did you mean 'elbow'?");
    CHECK(errorOf(arm, {{"elbow.rotateZ"}, {}, {}}) ==
          arm +
              ": parameter 'elbow.rotateZ' is driven by elbow_bend_sdk.output; parameters are animator controls that "
              "nothing drives");
    CHECK(errorOf(arm, {{"*.worldMatrix"}, {}, {}}) ==
          arm +
              ": parameter glob '*.worldMatrix' matches no free keyable number (arm_ctrl.worldMatrix is an output, "
              "computed by its node); parameters are animator controls that nothing drives");
    CHECK(errorOf(arm, {{}, {}, {}}) ==
          arm + ": no parameters given; name them with plug globs such as 'L_arm_*.rotate?'");
    CHECK(errorOf(arm, {{"wrist.rotateX"}, {"wrsit"}, {}}) ==
          arm + ": output glob 'wrsit' matches no joint; did you mean 'wrist'?");
    CHECK(errorOf(arm, {{"wrist.rotateX"}, {"arm_ctrl"}, {}}) ==
          arm + ": output 'arm_ctrl' is a transform, not a joint; outputs are joints");
    CHECK(errorOf(arm, {{"wrist.rotateX"}, {"x*"}, {}}) == arm + ": output glob 'x*' matches no joint");
    CHECK(errorOf("no/such/rig.yaml", {{"a.b"}, {}, {}}) == "no/such/rig.yaml: no such rig file");
}

namespace {

// A rig with settings of every numeric kind: `bend` (an angle, limited) turns the tip, `space` (an enum)
// picks its parent, `mode` is driven.
const std::string settingsRig = R"(nodes:
  - name: ctrl
    type: transform
    addAttr:
      - {name: bend, unit: angle, min: -30, max: 45}
      - {name: steps, type: int, min: 0, max: 10}
      - {name: flag, type: bool}
      - {name: space, type: enum, enum: [parent, world]}
      - {name: label, type: string}
      - {name: mode, min: 0}
  - {name: root, type: joint}
  - {name: tip, type: joint, parent: root, translate: [10, 0, 0]}
  - {name: driver, type: transform, addAttr: [{name: out}]}
  - {name: blend, type: blendTwoAttr}
connections:
  - ctrl.bend -> tip.rotateZ
  - driver.out -> ctrl.mode
)";

}  // namespace

TEST_CASE("GraphRigFunction: held plugs are set once, in the rig file's units, on every instance and after a reset")
{
    const auto file = test::writeFile(test::scratchDir("graph-rig-held") / "rig.yaml", settingsRig);
    const GraphRigOptions options{
        {"root.rotateZ"},
        {},
        {},
        {{"ctrl.steps", 3}, {"ctrl.bend", 30}, {"ctrl.space", 1}, {"ctrl.flag", 1}, {"ctrl.bend", 30}}};
    GraphRigFunction f(file, options);
    // Each once, as the rig names it, sorted.
    REQUIRE(f.held().size() == 4);
    CHECK(f.held()[0].plug == "ctrl.bend");
    CHECK(f.held()[0].value == 30.0);  // degrees, as given
    CHECK(f.held()[1].plug == "ctrl.flag");
    CHECK(f.held()[2].plug == "ctrl.space");
    CHECK(f.held()[3].plug == "ctrl.steps");
    Graph& g = f.graph();
    CHECK(std::get<double>(g.getValue(g.plug("ctrl.bend"))) == 30.0 * (std::numbers::pi / 180.0));
    CHECK(std::get<int>(g.getValue(g.plug("ctrl.steps"))) == 3);
    CHECK(std::get<bool>(g.getValue(g.plug("ctrl.flag"))));
    CHECK(std::get<int>(g.getValue(g.plug("ctrl.space"))) == 1);

    // The rig evaluates in the held state: the tip turned by the held bend, on instances and after a reset.
    const auto tipZ = [](RigFunction& rig) {
        std::vector<Eigen::Matrix4d> worlds;
        rig.evaluate(std::vector<double>{0.0}, worlds);
        return std::atan2(worlds[1](1, 0), worlds[1](0, 0)) * 180.0 / std::numbers::pi;
    };
    CHECK(tipZ(f) == doctest::Approx(30.0));
    const auto copy = f.instance();
    CHECK(tipZ(*copy) == doctest::Approx(30.0));
    f.resetState();
    CHECK(tipZ(f) == doctest::Approx(30.0));
    GraphRigFunction free(file, {{"root.rotateZ"}, {}, {}});
    CHECK(tipZ(free) == doctest::Approx(0.0));
    CHECK(free.held().empty());
}

TEST_CASE("GraphRigFunction: the fingerprint covers the held plugs, and is the rig files' alone without them")
{
    const auto file = test::writeFile(test::scratchDir("graph-rig-held-fingerprint") / "rig.yaml", settingsRig);
    const auto fingerprint = [&](std::vector<HeldPlug> held) {
        return GraphRigFunction(file, {{"root.rotateZ"}, {}, {}, std::move(held)}).fingerprint();
    };
    const std::uint64_t files = fnv(settingsRig);
    CHECK(fingerprint({}) == fmt::format("{:016x}", files));
    // Then each held plug, by name, in the rig file's units.
    CHECK(fingerprint({{"ctrl.space", 1}, {"ctrl.bend", 30}}) ==
          fmt::format("{:016x}", fnv("\nheld ctrl.space=1", fnv("\nheld ctrl.bend=30", files))));
    CHECK(fingerprint({{"ctrl.bend", 30}, {"ctrl.space", 1}}) == fingerprint({{"ctrl.space", 1}, {"ctrl.bend", 30}}));
    CHECK(fingerprint({{"ctrl.bend", 30}}) != fingerprint({{"ctrl.bend", 29.5}}));
    CHECK(fingerprint({{"ctrl.bend", 0}}) != fingerprint({}));
    CHECK(fingerprint({{"ctrl.bend", -0.0}}) == fingerprint({{"ctrl.bend", 0}}));
}

TEST_CASE("GraphRigFunction: a plug that cannot be held is one line naming it and what to do")
{
    const auto file = test::writeFile(test::scratchDir("graph-rig-held-errors") / "rig.yaml", settingsRig);
    const std::string rig = file.string();
    const auto heldError = [&](const std::string& plug, double value) {
        return errorOf(rig, {{"root.rotate?"}, {}, {}, {{plug, value}}});
    };
    CHECK(heldError("ctlr.bend", 1) == rig + ": held plug 'ctlr.bend': no node named 'ctlr'; did you mean 'ctrl'?");
    CHECK(heldError("ctrl.bnd", 1) ==
          rig + ": held plug 'ctrl.bnd': node 'ctrl' (transform) has no attribute 'bnd'; did you mean 'bend'?");
    CHECK(heldError("ctrl.*", 1) == rig + ": held plug 'ctrl.*': it is a glob; name each held plug in full");
    CHECK(heldError("tip.worldMatrix", 1) ==
          rig +
              ": held plug 'tip.worldMatrix': it is an output, computed by its node; a held plug is an input that "
              "nothing drives");
    CHECK(heldError("ctrl.mode", 1) ==
          rig +
              ": held plug 'ctrl.mode': it is driven by driver.out; a held plug is an input that nothing drives "
              "(hold what drives it instead)");
    CHECK(heldError("tip.rotateZ", 1) ==
          rig +
              ": held plug 'tip.rotateZ': it is driven by ctrl.bend; a held plug is an input that nothing drives "
              "(hold what drives it instead)");
    CHECK(heldError("blend.input", 1) ==
          rig + ": held plug 'blend.input': it is an array attribute; hold one element, e.g. blend.input[0]");
    CHECK(heldError("root.translate", 1) ==
          rig +
              ": held plug 'root.translate': it is a vector3 value, not a number; hold its components one by one "
              "(root.translateX, ...)");
    CHECK(heldError("ctrl.label", 1) ==
          rig +
              ": held plug 'ctrl.label': it is a string value, not a number; a held plug is one number (a switch "
              "or a setting)");
    CHECK(heldError("root.rotateY", 1) ==
          rig +
              ": held plug 'root.rotateY': it is also a parameter (glob 'root.rotate?'); a plug is inverted or "
              "held, not both: take it out of one");
    CHECK(heldError("ctrl.bend", 50) ==
          rig + ": held plug 'ctrl.bend': 50 is above its maximum 45; give a value from -30 to 45");
    CHECK(heldError("ctrl.bend", -31) ==
          rig + ": held plug 'ctrl.bend': -31 is below its minimum -30; give a value from -30 to 45");
    CHECK(heldError("ctrl.steps", 2.5) ==
          rig +
              ": held plug 'ctrl.steps': 2.5 is not a whole number from -2e9 to 2e9 (an int attribute); give a "
              "whole number");
    CHECK(heldError("ctrl.flag", 2) ==
          rig + ": held plug 'ctrl.flag': 2 is not 0 or 1 (a bool attribute); give 0 (false) or 1 (true)");
    CHECK(heldError("ctrl.space", 2) == rig +
                                            ": held plug 'ctrl.space': 2 is not one of its enum values; give the index "
                                            "of one of its names: 0 (parent), 1 (world)");
    CHECK(heldError("ctrl.bend", std::nan("")) ==
          rig +
              ": held plug 'ctrl.bend': nan is not a finite number; give a number in the rig file's units (degrees "
              "for angles)");
    CHECK(errorOf(rig, {{"root.rotate?"}, {}, {}, {{"ctrl.bend", 10}, {"ctrl.bend", 20}}}) ==
          rig + ": held plug 'ctrl.bend': it is held at 10 and at 20; give one value");

    // What rig-invert turns into its own line about the approximation.
    try {
        GraphRigFunction f(rig, {{"root.rotate?"}, {}, {}, {{"ctrl.bend", 50}}});
        FAIL("no error");
    }
    catch (const RigSelectionError& e) {
        CHECK(e.kind() == "held plug");
        CHECK(e.name() == "ctrl.bend");
        CHECK(e.reason() == "50 is above its maximum 45");
    }
}

namespace {

const std::string biped = (test::sourceDir() / "rigs/biped.yaml").string();

// The biped's options from one of its spec files, helpers as given.
GraphRigOptions bipedOptions(const std::string& spec, std::vector<std::string> helperGlobs, bool autoHelpers)
{
    const InversionSpec s = readInversionSpec(test::sourceDir() / spec);
    return GraphRigOptions{s.params, s.outputs, {}, s.set, s.ranges, std::move(helperGlobs), autoHelpers};
}

std::vector<std::string> helpersOf(const RigFunction& rig)
{
    std::vector<std::string> out;
    for (std::size_t k = 0; k < rig.outputs().size(); ++k)
        if (rig.helperOutputs()[k]) out.push_back(rig.outputs()[k]);
    return out;
}

}  // namespace

TEST_CASE("GraphRigFunction: helpers come after the joints, flagged, in world space, read as graph-eval reads them")
{
    const GraphRigOptions plain = bipedOptions("rigs/biped_inversion_ik.yaml", {}, false);
    const GraphRigFunction joints(biped, plain);
    // world_ctrl, a parent of Hips that nothing moves, may be named; L_leg_*_ctrl matches two transforms.
    GraphRigFunction f(biped, bipedOptions("rigs/biped_inversion_ik.yaml", {"world_ctrl", "L_leg_*_ctrl"}, false));
    const std::size_t n = joints.outputs().size();
    REQUIRE(f.outputs().size() == n + 3);
    CHECK(std::equal(joints.outputs().begin(), joints.outputs().end(), f.outputs().begin()));
    CHECK(std::vector<std::string>(f.outputs().begin() + static_cast<std::ptrdiff_t>(n), f.outputs().end()) ==
          std::vector<std::string>{"L_leg_ik_ctrl", "L_leg_pole_ctrl", "world_ctrl"});  // in name order
    std::vector<char> flags(n, 0);
    flags.insert(flags.end(), 3, 1);
    CHECK(f.helperOutputs() == flags);
    CHECK(f.instance()->helperOutputs() == flags);
    CHECK(joints.helperOutputs() == std::vector<char>(n, 0));
    // A helper is in world space, and no joint's parent walk stops at one: Hips, below world_ctrl, has none.
    std::vector<int> parents = joints.outputParents();
    parents.insert(parents.end(), 3, -1);
    CHECK(f.outputParents() == parents);
    CHECK(f.outputParents()[0] == -1);
    // Helpers change neither the parameters nor the fingerprint.
    CHECK(names(f.parameters()) == names(joints.parameters()));
    CHECK(f.fingerprint() == joints.fingerprint());

    // Their worlds are the nodes' worldMatrix, on this object, an instance, and graph-eval's output (values as
    // plugs hold them: centimetres, the same in both).
    std::vector<double> values;
    for (const RigParameter& p : f.parameters()) values.push_back(p.defaultValue);
    const std::map<std::string, double> moved{
        {"root_ctrl.translateX", 12.5}, {"L_leg_ik_ctrl.translateY", 4.0}, {"L_leg_pole_ctrl.translateZ", -3.25}};
    std::string sets;
    for (std::size_t i = 0; i < values.size(); ++i)
        if (const auto it = moved.find(f.parameters()[i].name); it != moved.end()) {
            values[i] = it->second;
            sets += fmt::format(" --set {}={}", it->first, it->second);
        }
    std::vector<Eigen::Matrix4d> worlds, again;
    f.evaluate(values, worlds);
    f.instance()->evaluate(values, again);
    CHECK(worlds == again);
    const auto r =
        test::run(fmt::format("{} {} --set L_leg_settings.ikFk=1 --set R_leg_settings.ikFk=1 --set "
                              "L_leg_ik.stretch=true --set R_leg_ik.stretch=true{} --get '*_ctrl.worldMatrix'",
                              test::tool("graph-eval"), biped, sets));
    CAPTURE(r.err);
    REQUIRE(r.exitCode == 0);
    const YAML::Node frame = YAML::Load(r.out)[0];
    for (std::size_t k = n; k < f.outputs().size(); ++k) {
        CAPTURE(f.outputs()[k]);
        Graph& g = f.graph();
        CHECK(worlds[k] == std::get<Eigen::Matrix4d>(g.getValue(g.plug(f.outputs()[k] + ".worldMatrix"))));
        const YAML::Node rows = frame[f.outputs()[k] + ".worldMatrix"];
        REQUIRE(rows.size() == 4);
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) CHECK(worlds[k](i, j) == rows[i][j].as<double>());
    }
    CHECK(worlds[n](1, 3) == 4.0);  // the IK goal moved, in world space
}

TEST_CASE(
    "GraphRigFunction: helpers found on the biped are the frames its outputs read that a parameter moves, or "
    "that a constraint or a solver reads")
{
    // FK legs: the pole objects hang below root_ctrl, which moves them; the IK goals, which no parameter moves, feed
    // the ikHandles (fixed targets); eyes_ctrl feeds the eyes' aims, which no output reads.
    const GraphRigFunction fk(biped, bipedOptions("rigs/biped_inversion.yaml", {}, true));
    CHECK(helpersOf(fk) == std::vector<std::string>{"L_leg_ik_ctrl", "L_leg_pole_ctrl", "R_leg_ik_ctrl",
                                                    "R_leg_pole_ctrl", "root_ctrl"});
    // IK legs: their goals and pole objects are parameters.
    const GraphRigFunction ik(biped, bipedOptions("rigs/biped_inversion_ik.yaml", {}, true));
    CHECK(helpersOf(ik) == std::vector<std::string>{"L_leg_ik_ctrl", "L_leg_pole_ctrl", "R_leg_ik_ctrl",
                                                    "R_leg_pole_ctrl", "root_ctrl"});
    // eyes_ctrl is found once a parameter moves it and an output reads it (the eyes, among every joint), and not
    // while no output reads it.
    GraphRigOptions eyes = bipedOptions("rigs/biped_inversion.yaml", {}, true);
    eyes.parameterGlobs.push_back("eyes_ctrl.translate?");
    CHECK(helpersOf(GraphRigFunction(biped, eyes)) == helpersOf(fk));
    eyes.outputGlobs.clear();
    const std::vector<std::string> all = helpersOf(GraphRigFunction(biped, eyes));
    CHECK(std::find(all.begin(), all.end(), "eyes_ctrl") != all.end());
    // Named helpers join the ones found, each once, in name order.
    CHECK(
        helpersOf(GraphRigFunction(biped, bipedOptions("rigs/biped_inversion.yaml", {"world_ctrl", "root_*"}, true))) ==
        std::vector<std::string>{"L_leg_ik_ctrl", "L_leg_pole_ctrl", "R_leg_ik_ctrl", "R_leg_pole_ctrl", "root_ctrl",
                                 "world_ctrl"});
    // An FK arm has none.
    GraphRigOptions armOptions{{"shoulder.rotate?", "arm_ctrl.translate?"}, {}, {}};
    armOptions.autoHelpers = true;
    CHECK(helpersOf(GraphRigFunction(arm, armOptions)).empty());
}

TEST_CASE("GraphRigFunction: a helper glob that matches nothing usable is one line with a suggestion")
{
    const auto helperError = [](const std::string& glob) {
        return errorOf(biped, bipedOptions("rigs/biped_inversion.yaml", {glob}, false));
    };
    CHECK(helperError("L_leg_pole_ctl") ==
          biped + ": helper 'L_leg_pole_ctl' matches no transform or joint; did you mean 'L_leg_pole_ctrl'?");
    CHECK(helperError("*_goal") ==
          biped +
              ": helper glob '*_goal' matches no transform or joint; helpers are transforms or joints (nodes with "
              "a worldMatrix)");
    CHECK(helperError("L_leg_ik") == biped +
                                         ": helper 'L_leg_ik' is a ikHandle, not a transform or joint; helpers are "
                                         "transforms or joints (nodes with a worldMatrix)");
    CHECK(helperError("Hips") ==
          biped + ": helper 'Hips' is an output; a helper is a transform or joint that is not an output");
    CHECK(helperError("Left*Leg") == biped +
                                         ": helper glob 'Left*Leg' matches only outputs, such as LeftUpLeg; a helper "
                                         "is a transform or joint that is not an output");
    try {
        GraphRigFunction f(biped, bipedOptions("rigs/biped_inversion.yaml", {"*_goal"}, false));
        FAIL("no error");
    }
    catch (const RigSelectionError& e) {
        CHECK(e.kind() == "helper");
        CHECK(e.name() == "*_goal");
        CHECK(e.reason() == "matches no transform or joint");
    }
}

TEST_CASE("GraphRigFunction: rigOptionsFor loads an approximation's joints and helpers again, in the same order")
{
    const GraphRigFunction learned(biped, bipedOptions("rigs/biped_inversion_ik.yaml", {}, true));
    Approximation a;
    for (const RigParameter& p : learned.parameters()) {
        ModelledParameter m;
        m.parameter = p;
        a.parameters.push_back(m);
    }
    for (std::size_t k = 0; k < learned.outputs().size(); ++k) {
        ApproximationOutput o;
        o.name = learned.outputs()[k];
        o.helper = learned.helperOutputs()[k] != 0;
        a.outputs.push_back(o);
    }
    a.held = learned.held();
    const GraphRigOptions options = rigOptionsFor(a);
    CHECK(options.helperGlobs == std::vector<std::string>{"L_leg_ik_ctrl", "L_leg_pole_ctrl", "R_leg_ik_ctrl",
                                                          "R_leg_pole_ctrl", "root_ctrl"});
    CHECK(!options.autoHelpers);
    CHECK(options.outputGlobs.size() + options.helperGlobs.size() == learned.outputs().size());
    const GraphRigFunction loaded(biped, options);
    CHECK(loaded.outputs() == learned.outputs());
    CHECK(loaded.helperOutputs() == learned.helperOutputs());
    CHECK(loaded.outputParents() == learned.outputParents());
    CHECK(loaded.fingerprint() == learned.fingerprint());
    CHECK(loaded.fingerprint() ==
          GraphRigFunction(biped, bipedOptions("rigs/biped_inversion_ik.yaml", {}, false)).fingerprint());
}

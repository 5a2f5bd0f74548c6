// GraphRigFunction: parameters from plug globs, joints as outputs, counted evaluations, the rig files'
// fingerprint, and one-line errors for globs that match nothing usable.
#include <doctest/doctest.h>

#include <numbers>

#include <fmt/format.h>

#include "core/error.h"
#include "nodes/graph_rig_function.h"
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

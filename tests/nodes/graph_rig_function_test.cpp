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

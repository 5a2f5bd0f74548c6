// Rig files: what loads, and the exact one-line error for each kind of mistake.
#include <doctest/doctest.h>

#include <numbers>

#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

using namespace rig;

namespace {

std::unique_ptr<Graph> load(const std::string& text) { return loadGraphText(text, "rig.yaml", makeBuiltinRegistry()); }

std::string errorOf(const std::string& text)
{
    try {
        load(text);
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

TEST_CASE("a rig file loads nodes, values in file units, parent sugar, driven keys and connections")
{
    auto g = load(R"(
nodes:
  - {name: ctrl, type: transform, addAttr: [{name: bend, min: 0, max: 10, default: 5}]}
  - {name: root, type: joint, translate: [0, 100, 0], rotateOrder: zyx, scale: [2, 2, 2]}
  - {name: tip, type: joint, parent: root, translate: [10, 0, 0]}
  - {name: sdk, type: animCurveUA, keys: [[0, 0], [10, 90]], tangents: linear}
  - name: mm
    type: multMatrix
    matrixIn: {1: [[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}
connections:
  - ctrl.bend -> sdk.input
  - sdk.output -> root.rotateZ
)");
    CHECK(g->nodeCount() == 5);
    CHECK(std::get<int>(g->getValue(g->plug("root.rotateOrder"))) == 5);
    // bend 5 -> 45 degrees, stored in radians.
    CHECK(std::get<Eigen::Vector3d>(g->getValue(g->plug("root.rotate")))[2] == doctest::Approx(std::numbers::pi / 4));
    // parent: connects worldMatrix -> parentMatrix and, between joints, scale -> inverseScale.
    CHECK(g->incomingConnection(g->plug("tip.parentMatrix")) != nullptr);
    CHECK(g->incomingConnection(g->plug("tip.inverseScale")) != nullptr);
    const auto tip = std::get<Eigen::Matrix4d>(g->getValue(g->plug("tip.worldMatrix")));
    // root scale 2 does not reach tip's orientation, but does place it: 10 * 2 along root's rotated x.
    CHECK(tip(0, 3) == doctest::Approx(20 * std::cos(std::numbers::pi / 4)));
    CHECK(tip(1, 3) == doctest::Approx(100 + 20 * std::sin(std::numbers::pi / 4)));
    CHECK(tip.block<3, 1>(0, 0).norm() == doctest::Approx(1.0));
    CHECK(g->elementIndices(g->node("mm"), g->plug("mm.matrixIn[1]").attr) == std::vector<int>{1});
}

TEST_CASE("rig file errors name file:line:col, the node and attribute, and a fix")
{
    CHECK(errorOf("") == "rig.yaml: the file is empty; a rig file has a 'nodes:' list");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint\n  - {name: b}\n") ==
          "rig.yaml:3:5: YAML syntax error: end of map flow not found");
    CHECK(errorOf("nodez: []") == "rig.yaml:1:1: unknown key 'nodez' at top level; did you mean 'nodes'?");
    CHECK(errorOf("nodes:\n  - {name: a, type: jiont}") ==
          "rig.yaml:2:21: unknown node type 'jiont'; did you mean 'joint'?");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, rotat: [0, 0, 0]}") ==
          "rig.yaml:2:28: node 'a' (joint) has no attribute 'rotat'; did you mean 'rotate'?");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint}\n  - {name: a, type: transform}") ==
          "rig.yaml:3:12: duplicate node name 'a' (already a joint); node names must be unique");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, translate: [1, 2]}") ==
          "rig.yaml:2:39: a.translate: expected [x, y, z], got a list of 2");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, translateX: abc}") ==
          "rig.yaml:2:40: a.translateX: expected a number, got 'abc'");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, translateX: .nan}") ==
          "rig.yaml:2:40: a.translateX: .nan is not a finite number");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, rotateOrder: xzz}") ==
          "rig.yaml:2:41: a.rotateOrder: 'xzz' is not one of xyz, yzx, zxy, xzy, yxz, zyx; did you mean 'xyz'?");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, parent: b}") == "rig.yaml:2:36: no node named 'b'");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint}\nconnections:\n  - a.worldMatrix -> a.parentMatrix")
              .starts_with("rig.yaml:4:5: cannot connect a.worldMatrix -> a.parentMatrix: it would close a cycle"));
    CHECK(errorOf("nodes:\n  - {name: a, type: joint}\n  - {name: b, type: joint}\nconnections:\n  - a.worldMatrix -> "
                  "b.rotateX") ==
          "rig.yaml:5:5: cannot connect a.worldMatrix (matrix4) -> b.rotateX (double): the types do not match");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint}\nconnections:\n  - a.worldMatrix b.parentMatrix") ==
          "rig.yaml:4:5: a connection is written 'node.attr -> node.attr', got 'a.worldMatrix b.parentMatrix'");
    CHECK(errorOf("nodes:\n  - {name: c, type: transform, addAttr: [{name: bend, max: 10}], bend: 12}") ==
          "rig.yaml:2:72: cannot set c.bend: 12 is above its maximum 10");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint}\n  - {name: b, type: joint, parent: a, parentMatrix: "
                  "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}") ==
          "rig.yaml:3:36: b.parentMatrix is given a value at rig.yaml:3:53 and a connection; remove one of them");
    CHECK(errorOf("nodes:\n  - {name: s, type: animCurveUU, keys: [[0, 0], [0, 1]]}") ==
          "rig.yaml:2:50: node 's' (animCurveUU): key x 0 is not greater than the previous key's x 0 (keys must be "
          "strictly increasing)");
    CHECK(errorOf("nodes:\n  - {name: s, type: animCurveUU, keys: [[0, 0, bouncy]]}") ==
          "rig.yaml:2:48: node 's' (animCurveUU): unknown tangent type 'bouncy'; use one of linear, flat, step, "
          "stepnext, spline, clamped, plateau, auto");
    CHECK(errorOf("nodes:\n  - {name: a, type: joint, name: b}") ==
          "rig.yaml:2:28: node 'a' (joint): 'name' appears twice");
    CHECK(errorOf("nodes:\n  - {type: joint}") == "rig.yaml:2:5: node without 'name:'");
    CHECK(errorOf("nodes:\n  - {name: c, type: animCurveUU, keys: [[0, 0]], keyTime: [1]}") ==
          "rig.yaml:2:59: c.keyTime is given a value twice (first at rig.yaml:2:40); keep one");
    CHECK(errorOf("plugins: [noSuchPlugin]\nnodes: []").starts_with("rig.yaml:1:11: plugin 'noSuchPlugin' not found"));
}

TEST_CASE("a missing rig file is a clear error")
{
    try {
        loadGraphFile("no/such/rig.yaml", makeBuiltinRegistry());
        FAIL("expected an error");
    }
    catch (const Error& e) {
        CHECK(std::string(e.what()) == "no/such/rig.yaml: no such rig file");
    }
}

TEST_CASE("included rig files bring their nodes under a namespace, as Maya references do")
{
    const auto dir = rig::test::scratchDir("include");
    rig::test::writeFile(dir / "limb.yaml", R"(
nodes:
  - {name: upper, type: joint, translate: [0, 10, 0]}
  - {name: lower, type: joint, parent: upper, translate: [5, 0, 0]}
  - {name: bend, type: animCurveUA, keys: [[0, 0], [1, 90]], tangents: linear}
connections:
  - bend.output -> lower.rotateZ
)");
    std::filesystem::create_directories(dir / "crowd");
    rig::test::writeFile(dir / "crowd" / "two.yaml", R"(
include:
  - {file: ../limb.yaml, namespace: left}
  - {file: ../limb.yaml, namespace: right}
nodes:
  - {name: driver, type: transform, addAttr: [{name: amount, default: 1}]}
connections:
  - driver.amount -> left:bend.input
)");
    auto g = loadGraphFile(dir / "crowd" / "two.yaml", makeBuiltinRegistry());
    CHECK(g->nodeCount() == 7);
    CHECK(g->findNode("right:lower") >= 0);
    const auto left = std::get<Eigen::Vector3d>(g->getValue(g->plug("left:lower.rotate")));
    const auto right = std::get<Eigen::Vector3d>(g->getValue(g->plug("right:lower.rotate")));
    CHECK(left[2] == doctest::Approx(std::numbers::pi / 2));
    CHECK(right[2] == 0.0);

    rig::test::writeFile(dir / "loop.yaml", "include:\n  - {file: loop.yaml}\n");
    try {
        loadGraphFile(dir / "loop.yaml", makeBuiltinRegistry());
        FAIL("expected an error");
    }
    catch (const Error& e) {
        const std::string path = (dir / "loop.yaml").string();
        CHECK(std::string(e.what()) ==
              fmt::format("{}:2:12: include cycle: {} is already being loaded; remove this include", path, path));
    }
    rig::test::writeFile(dir / "missing.yaml", "include:\n  - {file: nowhere.yaml, namespace: x}\n");
    try {
        loadGraphFile(dir / "missing.yaml", makeBuiltinRegistry());
        FAIL("expected an error");
    }
    catch (const Error& e) {
        CHECK(std::string(e.what()) == fmt::format("{}:2:12: {}: no such included rig file",
                                                   (dir / "missing.yaml").string(), (dir / "nowhere.yaml").string()));
    }
}

namespace {

enum LinkAttr : AttrId { linkInput, linkOutput };

class LinkNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(linkOutput, c.getDouble(linkInput)); }
};

// A type whose `linkTo: NODE` field connects its output to NODE.input once the whole file is loaded.
std::shared_ptr<NodeRegistry> registryWithLinks()
{
    auto registry = makeBuiltinRegistry();
    NodeTypeBuilder b("testLink");
    b.input(linkInput, "input", ValueType::Double);
    b.output(linkOutput, "output", ValueType::Double);
    b.affects(linkInput, {linkOutput});
    b.yamlConnector("linkTo", [](Graph& graph, NodeId node, const YAML::Node& value, const YamlFieldContext& context) {
        if (graph.findNode(value.Scalar()) < 0)
            throw Error(fmt::format("{}: no node '{}' to link to", context.where(value), value.Scalar()));
        graph.connect(graph.plug(graph.nodeName(node) + ".output"), graph.plug(value.Scalar() + ".input"));
    });
    registry->add(b.factory<LinkNode>().build());
    return registry;
}

}  // namespace

TEST_CASE("a connector field wires its node once the whole file is loaded, and its errors name the place")
{
    // `b` is declared after `a` links to it, and `a`'s input is only set later in the file.
    const auto graph = loadGraphText(
        "nodes:\n"
        "  - {name: a, type: testLink, linkTo: b}\n"
        "  - {name: b, type: testLink}\n"
        "  - {name: c, type: testLink}\n"
        "connections:\n"
        "  - c.output -> a.input\n",
        "rig.yaml", registryWithLinks());
    REQUIRE(graph->connections().size() == 2);
    graph->setValue(graph->plug("c.input"), 2.5);
    CHECK(std::get<double>(graph->getValue(graph->plug("b.output"))) == 2.5);

    std::string error;
    try {
        loadGraphText("nodes:\n  - {name: a, type: testLink, linkTo: nobody}\n", "rig.yaml", registryWithLinks());
    }
    catch (const Error& e) {
        error = e.what();
    }
    CHECK(error == "rig.yaml:2:39: node 'a' (testLink): no node 'nobody' to link to");

    // A misspelt connector is suggested like an attribute.
    try {
        loadGraphText("nodes:\n  - {name: a, type: testLink, linkToo: b}\n", "rig.yaml", registryWithLinks());
    }
    catch (const Error& e) {
        error = e.what();
    }
    CHECK(error == "rig.yaml:2:31: node 'a' (testLink) has no attribute 'linkToo'; did you mean 'linkTo'?");
}

TEST_CASE("rig files: an added number without a default starts at 0, or at the nearest limit when 0 is outside them")
{
    auto g = load(R"(
nodes:
  - name: c
    type: transform
    addAttr:
      - {name: free, type: double}
      - {name: steps, type: int, min: 5, max: 10}
      - {name: below, type: double, min: -10, max: -5}
)");
    CHECK(std::get<double>(g->getValue(g->plug("c.free"))) == 0.0);
    CHECK(std::get<int>(g->getValue(g->plug("c.steps"))) == 5);
    CHECK(std::get<double>(g->getValue(g->plug("c.below"))) == -5.0);
}

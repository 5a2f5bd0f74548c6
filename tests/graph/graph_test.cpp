// The engine: plugs, connections, dirty propagation, pull evaluation, serial vs parallel, checked mode.
#include <doctest/doctest.h>

#include <memory>
#include <numbers>

#include <fmt/format.h>
#include <random>
#include <thread>

#include "core/error.h"
#include "graph/graph.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

using namespace rig;

namespace {

// sum = a + b; `broken` declares no affects entry from b (the bug checked mode must catch).
enum AddAttr : AttrId { addA, addB, addSum };

class AddNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(addSum, c.getDouble(addA) + c.getDouble(addB)); }
};

std::shared_ptr<const NodeType> makeAdd(const char* name, bool broken)
{
    NodeTypeBuilder b(name);
    b.input(addA, "a", ValueType::Double).keyable();
    b.input(addB, "b", ValueType::Double).keyable().range(-100, 100);
    b.output(addSum, "sum", ValueType::Double);
    b.affects(addA, {addSum});
    if (!broken) b.affects(addB, {addSum});
    return b.factory<AddNode>().build();
}

// count = number of computes so far: a history-dependent node.
enum CounterAttr : AttrId { counterIn, counterOut };

class CounterNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(counterOut, c.getDouble(counterIn) + ++count_); }

private:
    int count_ = 0;
};

std::shared_ptr<NodeRegistry> testRegistry()
{
    auto registry = makeBuiltinRegistry();
    registry->add(makeAdd("add", false));
    registry->add(makeAdd("brokenAdd", true));
    NodeTypeBuilder b("counter");
    b.input(counterIn, "input", ValueType::Double);
    b.output(counterOut, "output", ValueType::Double);
    b.affects(counterIn, {counterOut});
    registry->add(b.stateful().factory<CounterNode>().build());
    return registry;
}

using rig::test::errorOf;

}  // namespace

TEST_CASE("plugs parse node.attribute, components, array elements, and name what is wrong")
{
    Graph g(testRegistry());
    g.addNode("joint", "elbow");
    g.addNode("multMatrix", "mm");
    const Plug rz = g.plug("elbow.rotateZ");
    CHECK(g.plugName(rz) == "elbow.rotateZ");
    CHECK(rz.child == 2);
    CHECK(g.plugType(rz) == ValueType::Double);
    CHECK(g.plugName(g.plug("mm.matrixIn[3]")) == "mm.matrixIn[3]");
    CHECK(errorOf([&] { g.plug("elbow.rotat"); }) ==
          "node 'elbow' (joint) has no attribute 'rotat'; did you mean 'rotate'?");
    CHECK(errorOf([&] { g.plug("elbo.rotate"); }) == "no node named 'elbo'; did you mean 'elbow'?");
    CHECK(errorOf([&] { g.plug("elbow"); }) == "'elbow' is not a plug: expected node.attribute, e.g. elbow.rotateZ");
    CHECK(errorOf([&] { g.plug("elbow.rotate[2]"); }) ==
          "'elbow.rotate[2]': rotate is not an array attribute; drop the [index]");
    CHECK(errorOf([&] { g.plug("mm.matrixIn[x]"); }) ==
          "'mm.matrixIn[x]': bad array index; expected attribute[N] with N = 0, 1, ...");
    CHECK(errorOf([&] { g.getValue(g.plug("mm.matrixIn")); }) ==
          "mm.matrixIn is an array attribute: name an element, e.g. mm.matrixIn[0]");
}

TEST_CASE("nodes: unknown types, bad and duplicate names")
{
    Graph g(testRegistry());
    g.addNode("joint", "hips");
    CHECK(errorOf([&] { g.addNode("jiont", "x"); }) == "unknown node type 'jiont'; did you mean 'joint'?");
    CHECK(errorOf([&] { g.addNode("joint", "hips"); }) ==
          "duplicate node name 'hips' (already a joint); node names must be unique");
    CHECK(errorOf([&] { g.addNode("joint", "a.b"); }) ==
          "invalid node name 'a.b': use letters, digits, '_', ':' and '|', not starting with a digit");
    CHECK(g.addNode("joint", "mixamorig:Hips") == 1);
}

TEST_CASE("connections are type-checked, single-source and acyclic, with the whole cycle in the message")
{
    Graph g(testRegistry());
    for (const char* n : {"a", "b", "c"}) g.addNode("add", n);
    g.addNode("joint", "j");
    g.connect(g.plug("a.sum"), g.plug("b.a"));
    g.connect(g.plug("b.sum"), g.plug("c.a"));
    CHECK(errorOf([&] { g.connect(g.plug("c.sum"), g.plug("a.a")); }) ==
          "cannot connect c.sum -> a.a: it would close a cycle (a.sum -> b.a, b.sum -> c.a, c.sum -> a.a); the graph "
          "must stay acyclic at node level, so feed a from nodes that do not depend on a");
    CHECK(errorOf([&] {
              g.connect(g.plug("a.sum"), g.plug("a.b"));
          }).starts_with("cannot connect a.sum -> a.b: it would close a cycle"));
    CHECK(errorOf([&] { g.connect(g.plug("j.worldMatrix"), g.plug("c.b")); }) ==
          "cannot connect j.worldMatrix (matrix4) -> c.b (double): the types do not match");
    CHECK(
        errorOf([&] { g.connect(g.plug("a.sum"), g.plug("c.a")); }) ==
        "cannot connect a.sum -> c.a: c.a is already driven by b.sum; an input takes one source, disconnect it first");
    CHECK(errorOf([&] { g.connect(g.plug("a.a"), g.plug("c.sum")); }) ==
          "cannot connect a.a -> c.sum: c.sum is an output, written by its node's compute; connect into an input");
    CHECK(errorOf([&] { g.setValue(g.plug("b.a"), 1.0); }) ==
          "cannot set b.a: it is driven by a.sum; disconnect it first");
    // A component and its parent are one input.
    g.connect(g.plug("a.sum"), g.plug("j.rotateX"));
    CHECK(errorOf([&] { g.connect(g.plug("j.translate"), g.plug("j.rotate")); }).find("already driven by a.sum") !=
          std::string::npos);
    g.disconnect(g.plug("b.sum"), g.plug("c.a"));
    g.connect(g.plug("c.sum"), g.plug("a.a"));  // no longer a cycle
    CHECK(errorOf([&] { g.disconnect(g.plug("b.sum"), g.plug("c.a")); }) ==
          "cannot disconnect b.sum -> c.a: they are not connected");
}

TEST_CASE("values are checked: type, finiteness, limits in user units")
{
    Graph g(testRegistry());
    g.addNode("add", "n");
    g.addNode("joint", "j");
    CHECK(errorOf([&] { g.setValue(g.plug("n.b"), 101.0); }) == "cannot set n.b: 101 is above its maximum 100");
    CHECK(errorOf([&] { g.setValue(g.plug("n.b"), std::nan("")); }) == "cannot set n.b: value is not a finite number");
    CHECK(errorOf([&] { g.setValue(g.plug("n.b"), std::string("x")); }) == "cannot set n.b: expected a double value");
    CHECK(errorOf([&] { g.setValue(g.plug("j.rotateOrder"), 6); }) ==
          "cannot set j.rotateOrder: enum index 6 out of range 0..5");
    CHECK(errorOf([&] { g.setValue(g.plug("n.sum"), 1.0); }) ==
          "cannot set n.sum: it is an output, computed by its node");
}

TEST_CASE("pull evaluation computes on demand and caches: setting one input recomputes only its downstream")
{
    Graph g(testRegistry());
    // Two independent chains x0 -> x1 -> x2 and y0 -> y1 -> y2.
    for (const char* n : {"x0", "x1", "x2", "y0", "y1", "y2"}) g.addNode("add", n);
    g.connect(g.plug("x0.sum"), g.plug("x1.a"));
    g.connect(g.plug("x1.sum"), g.plug("x2.a"));
    g.connect(g.plug("y0.sum"), g.plug("y1.a"));
    g.connect(g.plug("y1.sum"), g.plug("y2.a"));
    g.setValue(g.plug("x0.a"), 1.0);
    g.setValue(g.plug("x1.b"), 2.0);
    CHECK(g.computeCount() == 0);  // nothing is computed until read
    CHECK(std::get<double>(g.getValue(g.plug("x2.sum"))) == 3.0);
    CHECK(g.computeCount() == 3);
    CHECK(std::get<double>(g.getValue(g.plug("x2.sum"))) == 3.0);
    CHECK(g.computeCount() == 3);  // cached
    g.evaluateAll();
    CHECK(g.computeCount() == 6);

    g.setValue(g.plug("x1.b"), 5.0);
    g.evaluateAll();
    CHECK(g.computeCount() == 8);  // x1 and x2 only
    CHECK(g.computeCount(g.node("x0")) == 1);
    CHECK(g.computeCount(g.node("y2")) == 1);
    CHECK(std::get<double>(g.getValue(g.plug("x2.sum"))) == 6.0);
}

TEST_CASE("angle plugs convert across connections as Maya's unitConversion does")
{
    Graph g(testRegistry());
    g.addNode("add", "n");
    g.addNode("joint", "j");
    g.addNode("add", "m");
    g.setValue(g.plug("n.a"), 90.0);
    g.connect(g.plug("n.sum"), g.plug("j.rotateZ"));  // unitless -> angle: degrees to radians
    g.connect(g.plug("j.rotateZ"), g.plug("m.a"));    // angle -> unitless: radians to degrees
    CHECK(std::get<Eigen::Vector3d>(g.getValue(g.plug("j.rotate")))[2] == doctest::Approx(std::numbers::pi / 2));
    CHECK(std::get<double>(g.getValue(g.plug("m.sum"))) == doctest::Approx(90.0));
    const auto world = std::get<Eigen::Matrix4d>(g.getValue(g.plug("j.worldMatrix")));
    CHECK(world(1, 0) == doctest::Approx(1.0));
}

TEST_CASE("dynamic attributes can be set, connected from and connected into")
{
    Graph g(testRegistry());
    const NodeId ctrl = g.addNode("transform", "ctrl");
    AttributeSpec bend;
    bend.name = "bend";
    bend.min = 0;
    bend.max = 10;
    g.addAttribute(ctrl, bend);
    g.addNode("add", "n");
    g.connect(g.plug("ctrl.bend"), g.plug("n.a"));
    g.setValue(g.plug("ctrl.bend"), 4.0);
    CHECK(std::get<double>(g.getValue(g.plug("n.sum"))) == 4.0);
    g.setValue(g.plug("ctrl.bend"), 7.0);
    CHECK(std::get<double>(g.getValue(g.plug("n.sum"))) == 7.0);
    CHECK(errorOf([&] { g.setValue(g.plug("ctrl.bend"), 11.0); }) ==
          "cannot set ctrl.bend: 11 is above its maximum 10");
    CHECK(errorOf([&] { g.addAttribute(ctrl, bend); }) == "node 'ctrl' (transform) already has an attribute 'bend'");
}

TEST_CASE("dynamic attributes: nodes of a type that add the same ones share one list, each keeps its own values")
{
    Graph g(testRegistry());
    AttributeSpec bend;
    bend.name = "bend";
    bend.max = 10;
    AttributeSpec roll = bend;
    roll.name = "roll";
    // A crowd's members each add the same attributes to their copy of a control.
    std::vector<NodeId> members;
    for (const char* name : {"c1:ctrl", "c2:ctrl", "c3:ctrl"}) {
        members.push_back(g.addNode("transform", name));
        g.addAttribute(members.back(), bend);
        g.addAttribute(members.back(), roll);
    }
    CHECK(&g.attributes(members[0]) == &g.attributes(members[1]));
    CHECK(&g.attributes(members[0]) == &g.attributes(members[2]));
    g.setValue(g.plug("c2:ctrl.roll"), 3.0);
    CHECK(std::get<double>(g.getValue(g.plug("c1:ctrl.roll"))) == 0.0);
    CHECK(std::get<double>(g.getValue(g.plug("c2:ctrl.roll"))) == 3.0);
    // Another attribute, or the same ones with another limit or in another order, is another list.
    const NodeId other = g.addNode("transform", "other");
    g.addAttribute(other, bend);
    AttributeSpec wider = roll;
    wider.max = 20;
    g.addAttribute(other, wider);
    CHECK(&g.attributes(other) != &g.attributes(members[0]));
    CHECK(errorOf([&] { g.setValue(g.plug("c1:ctrl.roll"), 15.0); }) ==
          "cannot set c1:ctrl.roll: 15 is above its maximum 10");
    g.setValue(g.plug("other.roll"), 15.0);
    const NodeId swapped = g.addNode("transform", "swapped");
    g.addAttribute(swapped, roll);
    g.addAttribute(swapped, bend);
    CHECK(&g.attributes(swapped) != &g.attributes(members[0]));
    CHECK(g.attributes(swapped)[g.attributes(swapped).size() - 1].name == "bend");
}

TEST_CASE("scene time drives unconnected time inputs")
{
    Graph g(testRegistry());
    g.addNode("time", "time1");
    g.setTime(12.5);
    CHECK(std::get<double>(g.getValue(g.plug("time1.outTime"))) == 12.5);
    // The list of time inputs follows the topology: a node added later, an input connected and disconnected.
    g.addNode("time", "time2");
    g.addNode("time", "offset");
    g.setValue(g.plug("offset.time"), 3.0);
    g.setTime(14.0);
    CHECK(std::get<double>(g.getValue(g.plug("time2.outTime"))) == 14.0);
    g.connect(g.plug("offset.outTime"), g.plug("time2.time"));
    g.setTime(15.0);
    CHECK(std::get<double>(g.getValue(g.plug("time1.outTime"))) == 15.0);
    CHECK(std::get<double>(g.getValue(g.plug("time2.outTime"))) == 15.0);  // offset's time follows the scene's too
    g.disconnect(g.plug("offset.outTime"), g.plug("time2.time"));
    g.setTime(16.0);
    CHECK(std::get<double>(g.getValue(g.plug("time2.outTime"))) == 16.0);
}

TEST_CASE("scene time dirties its whole downstream, as the graph is when the time is set")
{
    // setTime marks the downstream of the time inputs from a list made at the first frame after an edit: a node
    // connected later must follow the time from the next frame, and a node off the time's path never recomputes.
    Graph g(testRegistry());
    g.addNode("time", "time1");
    g.addNode("add", "first");
    g.addNode("add", "second");
    g.addNode("add", "still");
    g.connect(g.plug("time1.outTime"), g.plug("first.a"));
    g.connect(g.plug("first.sum"), g.plug("second.a"));
    g.setValue(g.plug("still.a"), 2.0);
    g.setTime(1.0);
    CHECK(std::get<double>(g.getValue(g.plug("second.sum"))) == 1.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 2.0);
    g.setTime(2.0);
    CHECK(std::get<double>(g.getValue(g.plug("second.sum"))) == 2.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 2.0);
    CHECK(g.computeCount(g.node("second")) == 2);
    CHECK(g.computeCount(g.node("still")) == 1);
    // Edited after a frame: the path through `still` now starts at the time.
    g.connect(g.plug("second.sum"), g.plug("still.b"));
    g.setTime(3.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 5.0);
    g.setTime(4.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 6.0);
    // An instance plays the same model with its own flags.
    const auto other = g.instance();
    other->setTime(7.0);
    CHECK(std::get<double>(other->getValue(other->plug("still.sum"))) == 9.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 6.0);
    g.disconnect(g.plug("second.sum"), g.plug("still.b"));
    g.setTime(5.0);
    CHECK(std::get<double>(g.getValue(g.plug("still.sum"))) == 6.0);  // the input keeps its last value, as in Maya
    const auto computed = g.computeCount(g.node("still"));
    g.setTime(6.0);
    CHECK(std::get<double>(g.getValue(g.plug("second.sum"))) == 6.0);
    CHECK(g.computeCount(g.node("still")) == computed);
}

namespace {

// time1.outTime -> moving.a, moving.sum -> sum.a, on `threads` threads.
std::unique_ptr<Graph> timeChain(int threads)
{
    auto g = std::make_unique<Graph>(testRegistry());
    g->setThreads(threads);
    g->addNode("time", "time1");
    g->addNode("add", "moving");
    g->addNode("add", "sum");
    g->connect(g->plug("time1.outTime"), g->plug("moving.a"));
    g->connect(g->plug("moving.sum"), g->plug("sum.a"));
    return g;
}

}  // namespace

TEST_CASE("a player's frames reuse what the last one needed, and see any other change")
{
    // Between two evaluations of the same plugs where only the scene time moved, the graph keeps what they needed
    // (Graph::evaluateNodes); a value set or an edit in between, upstream of those plugs but off the time's path,
    // must make it look again.
    for (const int threads : {1, 2}) {
        CAPTURE(threads);
        const std::unique_ptr<Graph> chain = timeChain(threads);
        Graph& g = *chain;
        g.addNode("add", "held");
        g.connect(g.plug("held.sum"), g.plug("sum.b"));
        const std::vector<Plug> plugs{g.plug("sum.sum")};
        std::vector<Value> values;
        const auto play = [&](double frame) {
            g.setTime(frame);
            g.evaluate(plugs, values);
            REQUIRE(values.size() == 1);
            return std::get<double>(values[0]);
        };
        for (int frame = 1; frame <= 4; ++frame) CHECK(play(frame) == frame);
        CHECK(g.computeCount(g.node("held")) == 1);
        g.setValue(g.plug("held.a"), 10.0);
        CHECK(play(5.0) == 15.0);
        CHECK(play(6.0) == 16.0);
        CHECK(play(7.0) == 17.0);
        g.addNode("add", "late");
        g.connect(g.plug("late.sum"), g.plug("held.b"));
        g.setValue(g.plug("late.a"), 100.0);
        CHECK(play(8.0) == 118.0);
        CHECK(play(9.0) == 119.0);
        CHECK(g.computeCount(g.node("held")) == 3);
    }
}

TEST_CASE("evaluating plugs with their values gives what getValue gives each, inputs and outputs")
{
    for (const int threads : {1, 2}) {
        CAPTURE(threads);
        const std::unique_ptr<Graph> chain = timeChain(threads);
        Graph& g = *chain;
        g.setValue(g.plug("sum.b"), 0.25);
        const std::vector<Plug> plugs{g.plug("sum.sum"), g.plug("moving.a"), g.plug("sum.b"), g.plug("moving.sum"),
                                      g.plug("sum.sum")};
        std::vector<Value> values{Value(1.0)};  // replaced, not appended to
        g.setTime(3.0);
        g.evaluate(plugs, values);
        REQUIRE(values.size() == plugs.size());
        for (std::size_t i = 0; i < plugs.size(); ++i) CHECK(values[i] == g.getValue(plugs[i]));
        CHECK(std::get<double>(values[0]) == 3.25);
        g.setTime(4.0);
        g.evaluate(plugs, values);
        CHECK(std::get<double>(values[0]) == 4.25);
        CHECK(std::get<double>(values[1]) == 4.0);
    }
}

TEST_CASE("scene time leaves a connected time input to its connection")
{
    Graph g(testRegistry());
    g.addNode("time", "time1");
    g.addNode("add", "frame");
    g.connect(g.plug("frame.sum"), g.plug("time1.time"));
    g.setValue(g.plug("frame.a"), 7.0);
    g.setTime(12.5);
    CHECK(std::get<double>(g.getValue(g.plug("time1.outTime"))) == 7.0);
}

namespace {

// A rig-like graph of 240+ nodes: eight independent joint chains of 30, each joint driven by a curve
// of its own, so there is real parallel work.
std::unique_ptr<Graph> makeWideGraph(std::mt19937& rng)
{
    auto g = std::make_unique<Graph>(testRegistry());
    std::uniform_real_distribution<double> angle(-1.5, 1.5);
    for (int chain = 0; chain < 8; ++chain) {
        std::string parent;
        for (int i = 0; i < 30; ++i) {
            const std::string name = fmt::format("c{}_j{}", chain, i);
            g->addNode("joint", name);
            g->setValue(g->plug(name + ".translate"), Eigen::Vector3d(1.0 + i, 0.5 * chain, 0.25));
            g->setValue(g->plug(name + ".rotateOrder"), (chain + i) % 6);
            g->setValue(g->plug(name + ".jointOrient"), Eigen::Vector3d(angle(rng), angle(rng), angle(rng)));
            if (!parent.empty()) {
                g->connect(g->plug(parent + ".worldMatrix"), g->plug(name + ".parentMatrix"));
                g->connect(g->plug(parent + ".scale"), g->plug(name + ".inverseScale"));
            }
            const std::string curve = name + "_drv";
            g->addNode("add", curve);
            g->connect(g->plug(curve + ".sum"), g->plug(name + ".rotateY"));
            parent = name;
        }
    }
    return g;
}

}  // namespace

TEST_CASE("serial and parallel evaluation are bit-identical on a 480-node graph")
{
    std::mt19937 rngSerial(7), rngParallel(7);
    auto serial = makeWideGraph(rngSerial);
    auto parallel = makeWideGraph(rngParallel);
    CHECK(serial->nodeCount() == 480);
    parallel->setThreads(4);
    std::mt19937 values(11);
    std::uniform_real_distribution<double> x(-90, 90);
    for (int round = 0; round < 5; ++round) {
        // Change a few drivers (some chains stay clean), then read every world matrix.
        for (int k = 0; k < 6; ++k) {
            const std::string plug = fmt::format("c{}_j{}_drv.a", values() % 8, values() % 30);
            const double v = x(values);
            serial->setValue(serial->plug(plug), v);
            parallel->setValue(parallel->plug(plug), v);
        }
        std::vector<Plug> plugs;
        for (NodeId n = 0; n < serial->nodeCount(); ++n)
            if (serial->nodeType(n).name() == "joint")
                plugs.push_back(serial->plug(serial->nodeName(n) + ".worldMatrix"));
        serial->evaluate(plugs);
        parallel->evaluate(plugs);
        CHECK(serial->computeCount() == parallel->computeCount());
        for (const Plug& p : plugs) REQUIRE(bitEqual(serial->getValue(p), parallel->getValue(p)));
    }
}

TEST_CASE("an exception in a compute on the flow graph reaches the caller")
{
    Graph g(testRegistry());
    g.addNode("animCurveUU", "a");
    g.addNode("animCurveUU", "b");
    g.setValue(g.plug("a.keyTime"), std::vector<double>{0, 1});
    g.setValue(g.plug("b.keyTime"), std::vector<double>{0, 1});
    g.setThreads(2);
    CHECK(errorOf([&] { g.evaluateAll(); }) ==
          "node 'a': keyTime has 2 values but keyValue has 0; give one value per key");
}

TEST_CASE("a small part of a large graph is evaluated level by level on threads: bit-identical, the serial error")
{
    // One driver changed and one chain's tip read: 26 of 480 nodes, under the quarter that goes level by level
    // (FlowExecutor::runActive) rather than through the whole flow graph.
    std::mt19937 rngSerial(7), rngParallel(7);
    auto serial = makeWideGraph(rngSerial);
    auto parallel = makeWideGraph(rngParallel);
    parallel->setThreads(2);
    const std::vector<Plug> tips{serial->plug("c3_j29.worldMatrix"), serial->plug("c5_j29.worldMatrix")};
    serial->evaluate(tips);
    parallel->evaluate(tips);
    for (const double v : {12.5, -40.0}) {
        serial->setValue(serial->plug("c3_j4_drv.a"), v);
        parallel->setValue(parallel->plug("c3_j4_drv.a"), v);
        const auto before = serial->computeCount();
        serial->evaluate(tips);
        parallel->evaluate(tips);
        CHECK(serial->computeCount() - before == 27);  // the driver and c3_j4 .. c3_j29
        CHECK(parallel->computeCount() == serial->computeCount());
        for (const Plug& p : tips) REQUIRE(bitEqual(serial->getValue(p), parallel->getValue(p)));
    }

    // Two failing nodes on one level: the error is the one the serial order meets first.
    Graph g(testRegistry());
    for (int i = 0; i < 20; ++i) g.addNode("add", fmt::format("other{}", i));
    g.addNode("animCurveUU", "a");
    g.addNode("animCurveUU", "b");
    g.setValue(g.plug("a.keyTime"), std::vector<double>{0, 1});
    g.setValue(g.plug("b.keyTime"), std::vector<double>{0, 1});
    g.setThreads(2);
    const std::vector<Plug> outputs{g.plug("b.output"), g.plug("a.output")};
    CHECK(errorOf([&] { g.evaluate(outputs); }) ==
          "node 'a': keyTime has 2 values but keyValue has 0; give one value per key");
}

TEST_CASE("checked mode catches a missing affects entry and ignores stateful nodes")
{
    Graph g(testRegistry());
    g.addNode("brokenAdd", "bad");
    g.addNode("add", "good");
    g.addNode("counter", "count");
    g.addNode("add", "afterCount");
    g.connect(g.plug("count.output"), g.plug("afterCount.a"));
    CHECK(g.checkEvaluation().empty());
    g.setValue(g.plug("bad.b"), 3.0);  // does not dirty bad.sum: the cached 0 is stale
    g.setValue(g.plug("good.b"), 3.0);
    const auto mismatches = g.checkEvaluation();
    REQUIRE(mismatches.size() == 1);
    CHECK(mismatches[0] == "bad.sum");
}

TEST_CASE("plugins register node types through initializePlugin")
{
    auto registry = makeBuiltinRegistry();
    const auto folder = std::filesystem::path(RIG_BINARY_DIR) / "test-plugins";
    const auto file = registry->loadPlugin("test_plugin", {folder});
    CHECK(file.filename() == "test_plugin.so");
    CHECK(registry->loadPlugin("test_plugin", {folder}) == file);  // loading twice is harmless
    Graph g(registry);
    g.addNode("testDoubler", "d");
    g.setValue(g.plug("d.input"), 21.0);
    CHECK(std::get<double>(g.getValue(g.plug("d.output"))) == 42.0);
    CHECK(errorOf([&] {
              registry->loadPlugin("noSuchPlugin", {folder});
          }).starts_with("plugin 'noSuchPlugin' not found (looked for " + (folder / "noSuchPlugin.so").string()));
}

TEST_CASE("instances share one model, keep their own values and caches, and evaluate at the same time")
{
    std::mt19937 rng(7);
    auto original = makeWideGraph(rng);
    original->setValue(original->plug("c0_j0_drv.a"), 12.5);
    std::vector<Plug> plugs;
    for (NodeId n = 0; n < original->nodeCount(); ++n)
        if (original->nodeType(n).name() == "joint")
            plugs.push_back(original->plug(original->nodeName(n) + ".worldMatrix"));

    std::vector<std::unique_ptr<Graph>> instances;
    for (int i = 0; i < 3; ++i) instances.push_back(original->instance());
    CHECK(&instances[0]->model() == &original->model());
    CHECK(std::get<double>(instances[0]->getValue(instances[0]->plug("c0_j0_drv.a"))) == 12.5);
    CHECK(instances[0]->computeCount() == 0);

    // Each instance its own pose, evaluated on its own thread (one of them in parallel inside), against the
    // same poses evaluated one after the other on the original.
    auto pose = [](Graph& g, int i) {
        for (int k = 0; k < 8; ++k) g.setValue(g.plug(fmt::format("c{}_j{}_drv.a", k, (k * 7 + i) % 30)), 10.0 * i - k);
    };
    instances[2]->setThreads(2);
    std::vector<std::thread> threads;
    for (int i = 0; i < 3; ++i)
        threads.emplace_back([&, i] {
            pose(*instances[static_cast<std::size_t>(i)], i);
            instances[static_cast<std::size_t>(i)]->evaluate(plugs);
        });
    for (auto& t : threads) t.join();
    for (int i = 0; i < 3; ++i) {
        auto reference = original->instance();
        pose(*reference, i);
        for (const Plug& p : plugs)
            REQUIRE(bitEqual(reference->getValue(p), instances[static_cast<std::size_t>(i)]->getValue(p)));
    }
    // A value set on one instance is not seen by the others.
    CHECK(std::get<double>(original->getValue(original->plug("c0_j0_drv.a"))) == 12.5);
}

TEST_CASE("editing an instance's topology copies the model: the other instances keep theirs")
{
    Graph graph(testRegistry());
    graph.addNode("add", "first");
    auto other = graph.instance();
    const NodeId second = other->addNode("add", "second");
    other->connect(other->plug("first.sum"), other->plug("second.a"));
    CHECK(&other->model() != &graph.model());
    CHECK(graph.nodeCount() == 1);
    CHECK(graph.findNode("second") == -1);
    CHECK(other->nodeCount() == 2);
    other->setValue(other->plug("first.a"), 2.0);
    CHECK(std::get<double>(other->getValue(other->plug("second.sum"))) == 2.0);
    CHECK(other->nodeName(second) == "second");
}

TEST_CASE("resetState starts stateful nodes again, as a fresh instance would")
{
    Graph graph(testRegistry());
    graph.addNode("counter", "count");
    const Plug out = graph.plug("count.output");
    CHECK(std::get<double>(graph.getValue(out)) == 1.0);
    graph.dirtyAll();
    CHECK(std::get<double>(graph.getValue(out)) == 2.0);
    graph.resetState();
    CHECK(std::get<double>(graph.getValue(out)) == 1.0);
    CHECK(std::get<double>(graph.instance()->getValue(out)) == 1.0);
}

// The instance's values in slots of their own type (graph/value_store.h), and what a node's compute may read and
// write through them.
#include <doctest/doctest.h>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/value_store.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

using namespace rig;
using rig::test::errorOf;

TEST_CASE("value store: a slot per value in its type's pool, arrays apart, copies deep, another type refused")
{
    ValueStore store;
    const Eigen::Matrix4d m = (Eigen::Matrix4d() << 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 0, 0, 0, 1).finished();
    const ValueStore::Slot d0 = store.add(ValueType::Double, 1.5);
    const ValueStore::Slot d1 = store.add(ValueType::Double, -2.0);
    const ValueStore::Slot e = store.add(ValueType::Enum, 3);
    const ValueStore::Slot i = store.add(ValueType::Int, 7);
    const ValueStore::Slot b = store.add(ValueType::Bool, true);
    const ValueStore::Slot s = store.add(ValueType::String, std::string("clip.bvh"));
    const ValueStore::Slot v = store.add(ValueType::Vector3, Eigen::Vector3d(1, 2, 3));
    const ValueStore::Slot x = store.add(ValueType::Matrix4, m);
    const ValueStore::Slot da = store.add(ValueType::DoubleArray, std::vector<double>{1, 2});
    const ValueStore::Slot ma = store.add(ValueType::Matrix4Array, Matrix4Array{m, m});
    // Numbers, ints and enums are numbered in their own pools: a double does not take a matrix's room.
    CHECK(d0 == 0);
    CHECK(d1 == 1);
    CHECK(e == 0);
    CHECK(i == 1);
    CHECK(store.get<double>(d1) == -2.0);
    CHECK(store.get<int>(e) == 3);
    CHECK(store.get<int>(i) == 7);
    CHECK(store.get<bool>(b));
    CHECK(store.get<std::string>(s) == "clip.bvh");
    CHECK(store.get<Eigen::Vector3d>(v) == Eigen::Vector3d(1, 2, 3));
    CHECK(store.get<Eigen::Matrix4d>(x) == m);
    CHECK(store.get<std::vector<double>>(da).size() == 2);
    CHECK(store.get<Matrix4Array>(ma).size() == 2);
    CHECK(std::get<Eigen::Matrix4d>(store.value(ValueType::Matrix4, x)) == m);
    CHECK(std::get<int>(store.value(ValueType::Enum, e)) == 3);

    CHECK(store.assign(ValueType::Double, d0, 4.0));
    CHECK(store.get<double>(d0) == 4.0);
    CHECK_FALSE(store.assign(ValueType::Double, d0, 5));  // an int is not a double's value
    CHECK(store.get<double>(d0) == 4.0);
    CHECK_FALSE(store.assign(ValueType::Matrix4, x, Eigen::Vector3d::Zero().eval()));

    const ValueStore::Slot a = store.addArray();
    CHECK(store.array(a) == nullptr);  // no elements until the first
    ArrayData& doubles = store.elements(a, ValueType::Double);
    doubles.make(2, 0.5);  // index 2 made: 0 and 1 absent, held at the fallback
    doubles.get<double>(2) = 2.5;
    CHECK(doubles.size() == 3);
    CHECK_FALSE(doubles.has(0));
    CHECK(doubles.has(2));
    CHECK(std::get<double>(doubles.value(2)) == 2.5);
    ValueStore copy = store;
    copy.elements(a, ValueType::Double).get<double>(2) = 9.0;
    copy.get<double>(d0) = 8.0;
    CHECK(store.array(a)->get<double>(2) == 2.5);
    CHECK(store.get<double>(d0) == 4.0);
    CHECK(copy.array(a)->get<double>(2) == 9.0);
    CHECK_FALSE(copy.array(a)->sameAs(*store.array(a)));
    copy.elements(a, ValueType::Double).get<double>(2) = 2.5;
    CHECK(copy.array(a)->sameAs(*store.array(a)));

    // Elements are held as their type: bools as cells, matrices as matrices; assign replaces them all.
    const ValueStore::Slot bools = store.addArray();
    ArrayData& flags = store.elements(bools, ValueType::Bool);
    flags.assign<bool>(3, [](BoolCell& cell, std::size_t k) { cell.value = k == 1; });
    CHECK(flags.size() == 3);
    CHECK(flags.get<bool>(1));
    CHECK_FALSE(flags.get<bool>(2));
    CHECK(std::get<bool>(flags.value(1)));
    const ValueStore::Slot mats = store.addArray();
    ArrayData& matrices = store.elements(mats, ValueType::Matrix4);
    matrices.assign<Eigen::Matrix4d>(2,
                                     [&](Eigen::Matrix4d& cell, std::size_t k) { cell = m * static_cast<double>(k); });
    CHECK(matrices.get<Eigen::Matrix4d>(1) == m);
    CHECK(std::get<Eigen::Matrix4d>(matrices.value(0)) == Eigen::Matrix4d::Zero());
}

namespace {

enum ProbeAttr : AttrId { probeIn, probeOut };

// Reads its double input as an int, or writes an int into its double output: defects of a node type, which the
// context names instead of reading another pool's slot.
class WrongReadNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(probeOut, static_cast<double>(c.getInt(probeIn))); }
};
class WrongWriteNode : public Node {
public:
    void compute(ComputeContext& c) override { c.setOutput(probeOut, static_cast<int>(c.getDouble(probeIn))); }
};

template <class N>
std::shared_ptr<const NodeType> makeProbe(const char* name)
{
    NodeTypeBuilder b(name);
    b.input(probeIn, "in", ValueType::Double);
    b.output(probeOut, "out", ValueType::Double);
    b.affects(probeIn, {probeOut});
    return b.factory<N>().build();
}

}  // namespace

TEST_CASE("compute context: reading an input or writing an output as another type is the node type's defect")
{
    auto registry = makeBuiltinRegistry();
    registry->add(makeProbe<WrongReadNode>("wrongRead"));
    registry->add(makeProbe<WrongWriteNode>("wrongWrite"));
    Graph g(registry);
    g.addNode("wrongRead", "r");
    g.addNode("wrongWrite", "w");
    CHECK(errorOf([&] { g.getValue(g.plug("r.out")); }) ==
          "node 'r': compute read attribute 0 as another type than its double");
    CHECK(errorOf([&] { g.getValue(g.plug("w.out")); }) ==
          "node 'w': compute wrote attribute 1 which is not a plain output of that type");
}

TEST_CASE("connections out of one attribute: the push reaches each destination, before and after a disconnect")
{
    Graph g(makeBuiltinRegistry());
    g.addNode("transform", "src");
    for (const char* name : {"a", "b", "c"}) {
        g.addNode("transform", name);
        g.connect(g.plug("src.translateX"), g.plug(std::string(name) + ".translateY"));
    }
    g.connect(g.plug("src.translateZ"), g.plug("b.translateZ"));
    g.setValue(g.plug("src.translateX"), 2.0);
    for (const char* name : {"a", "b", "c"})
        CHECK(std::get<Eigen::Matrix4d>(g.getValue(g.plug(std::string(name) + ".matrix")))(1, 3) == 2.0);
    g.disconnect(g.plug("src.translateX"), g.plug("b.translateY"));
    g.setValue(g.plug("src.translateX"), 5.0);
    g.setValue(g.plug("src.translateZ"), 0.5);
    CHECK(std::get<Eigen::Matrix4d>(g.getValue(g.plug("a.matrix")))(1, 3) == 5.0);
    CHECK(std::get<Eigen::Matrix4d>(g.getValue(g.plug("c.matrix")))(1, 3) == 5.0);
    // b keeps its last value (Maya's rule), and still follows src.translateZ.
    const Eigen::Matrix4d b = std::get<Eigen::Matrix4d>(g.getValue(g.plug("b.matrix")));
    CHECK(b(1, 3) == 2.0);
    CHECK(b(2, 3) == 0.5);
}

#pragma once
// A dependency graph instance (Maya's DG): nodes with typed attributes, connections, stored values
// and caches. Setting a plug marks what it affects dirty (push); reading a plug computes what is
// dirty upstream of it (pull). One instance is not thread-safe to use from several threads; inside
// one evaluation, independent nodes may compute in parallel on a tbb::flow::graph (setThreads).

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "graph/node_registry.h"
#include "graph/plug.h"
#include "graph/schedule.h"

namespace rig {

class Graph {
public:
    // Array elements are stored densely: a typo like matrixIn[100000000] must not eat the memory.
    static constexpr int maxArrayIndex = 1 << 16;
    // Limits that keep a damaged or hostile rig from eating the memory (docs/robustness.md), checked
    // before allocating: array elements of inputs over the whole graph (stored densely up to the highest
    // index, about 150 bytes each: 150 MB at most), nodes (a joint holds about 6 KB: 1.3 GB at most,
    // room for crowds of 500 bipeds), and the length of node and attribute names.
    static constexpr std::size_t maxArrayElements = std::size_t{1} << 20;
    static constexpr int maxNodes = 200'000;
    static constexpr std::size_t maxNameLength = 1000;

    explicit Graph(std::shared_ptr<NodeRegistry> registry);
    ~Graph();
    Graph(const Graph&) = delete;
    Graph& operator=(const Graph&) = delete;

    NodeRegistry& registry() { return *registry_; }
    std::shared_ptr<NodeRegistry> sharedRegistry() const { return registry_; }

    // --- nodes -----------------------------------------------------------------------------------
    // Throws rig::Error for an unknown type, an invalid name or a name already used.
    NodeId addNode(std::string_view typeName, std::string_view name);
    // A dynamic attribute on one node (Maya's addAttr): an input that affects nothing on its node
    // and can be set, connected into, and connected from.
    AttrId addAttribute(NodeId node, AttributeSpec spec);
    int nodeCount() const { return static_cast<int>(nodes_.size()); }
    // -1 when there is no such node.
    NodeId findNode(std::string_view name) const;
    // Throws rig::Error naming the closest node when there is no such node.
    NodeId node(std::string_view name) const;
    const std::string& nodeName(NodeId node) const;
    const NodeType& nodeType(NodeId node) const;
    const std::vector<AttributeSpec>& attributes(NodeId node) const;

    // --- plugs -----------------------------------------------------------------------------------
    // Parses "node.attr", "node.attr[3]", "node.attrX", "node.attr[3].attrX"; throws rig::Error with a
    // suggestion when the node or attribute does not exist.
    Plug plug(std::string_view path) const;
    std::string plugName(const Plug& plug) const;
    const AttributeSpec& spec(const Plug& plug) const;
    // The plug's own data type: Double for a vector3 component.
    ValueType plugType(const Plug& plug) const;
    // Existing elements of an array attribute (inputs: set or connected; outputs: last computed).
    std::vector<int> elementIndices(NodeId node, AttrId attr) const;

    // --- connections -----------------------------------------------------------------------------
    // Type-checked; refuses a second source for an input, outputs as destinations, and any
    // connection that would close a cycle (the message lists the whole cycle).
    void connect(const Plug& source, const Plug& destination);
    void disconnect(const Plug& source, const Plug& destination);
    const std::vector<Connection>& connections() const { return connections_; }
    // The connection driving `destination` (or a component or parent of it), if any.
    const Connection* incomingConnection(const Plug& destination) const;

    // --- values (internal units: radians for angles) ----------------------------------------------
    // Sets an unconnected input; checks type, finiteness and the attribute's min/max.
    void setValue(const Plug& plug, const Value& value);
    // Computes what is needed and returns the plug's value.
    Value getValue(const Plug& plug);
    // Brings all these plugs up to date in one evaluation (parallel when threads() > 1).
    void evaluate(std::span<const Plug> plugs);
    // Brings every plug of the graph up to date.
    void evaluateAll();

    // Scene time in frames: sets every unconnected scene-time input (time nodes, animCurveT* inputs).
    void setTime(double frame);
    double time() const { return time_; }

    // 1: the serial reference evaluator; n > 1: a tbb::flow::graph on n threads; 0: all cores.
    // Results are bit-identical whatever the count.
    void setThreads(int threads);
    int threads() const { return threads_; }

    // Node computations since the graph was made (tests and --stats use it).
    std::uint64_t computeCount() const;
    std::uint64_t computeCount(NodeId node) const;

    // Marks every output and every connected input dirty, as if nothing had been computed.
    void dirtyAll();
    // Gaffer-style checked mode: evaluates everything, recomputes everything from scratch, and returns
    // the plugs whose cached value differed (a node type whose affects table misses an entry). Nodes of
    // stateful types, and what they feed, are not compared.
    std::vector<std::string> checkEvaluation();

private:
    struct NodeRecord;

    NodeRecord& record(NodeId node);
    const NodeRecord& record(NodeId node) const;
    AttrData& data(const Plug& plug);
    Value readStored(const Plug& plug) const;
    Value pulledValue(const Connection& connection) const;
    void writeStored(const Plug& plug, const Value& value);
    void checkPlug(const Plug& plug) const;

    void dirtyInput(NodeId node, AttrId attr);
    void dirtyOutput(NodeId node, AttrId attr);
    void dirtyConnectionsFrom(NodeId node, AttrId attr);
    void dirtyAffectedBy(NodeId node, AttrId attr);

    Schedule& schedule();
    void evaluateNodes(std::vector<char>& needed, std::vector<NodeId> roots);
    void processNode(NodeId node);
    void topologyChanged();
    std::vector<NodeId> cyclePath(NodeId from, NodeId to) const;

    std::shared_ptr<NodeRegistry> registry_;
    std::vector<std::unique_ptr<NodeRecord>> nodes_;
    std::unordered_map<std::string, NodeId> nodeIndex_;  // name -> node: loading stays linear in size
    std::size_t arrayElements_ = 0;                      // input array elements allocated, all nodes
    std::vector<Connection> connections_;
    std::unique_ptr<Schedule> schedule_;
    double time_ = 0.0;
    int threads_ = 1;
};

}  // namespace rig

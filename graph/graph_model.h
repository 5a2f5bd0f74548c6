#pragma once
// What a rig file describes, shared by every instance that evaluates it (like Pinocchio's Model, or
// Vdf's network): nodes with their types and attributes, connections, and the evaluation schedule.
// Values, dirty bits, caches and node state live in each instance (graph.h). A model is edited only
// through a Graph, which copies it first when other instances share it; once shared it is read-only,
// and any number of threads may read it.

#include <algorithm>
#include <memory>
#include <memory_resource>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "graph/node_registry.h"
#include "graph/plug.h"
#include "graph/schedule.h"

namespace rig {

class GraphModel {
public:
    // Limits that keep a damaged or hostile rig from eating the memory (docs/robustness.md), checked
    // before allocating: nodes (a joint holds about 6 KB: 1.3 GB at most, room for crowds of 500
    // bipeds), and the length of node and attribute names.
    static constexpr int maxNodes = 200'000;
    static constexpr std::size_t maxNameLength = 1000;
    // Array elements are stored densely: a typo like matrixIn[100000000] must not eat the memory.
    static constexpr int maxArrayIndex = 1 << 16;

    // Two cache lines: what a frame's marking and computing read (type, specs, incoming) in the first, the name and
    // the outgoing list (messages, pushes) in the second.
    struct alignas(64) NodeTopology {
        std::shared_ptr<const NodeType> type;
        // The type's attributes and the node's dynamic ones; null while it has none of its own.
        std::shared_ptr<const std::vector<AttributeSpec>> ownSpecs;
        // A connection out of this node: from its attribute `from` into `attr` of `node`, connections()[connection].
        struct Edge {
            AttrId from;
            NodeId node;
            AttrId attr;
            int connection;
        };
        // The connections into this node, copies of connections()' entries, in their order: a frame pulls each,
        // node by node, and the list stays with its node instead of reaching across the whole graph's.
        std::pmr::vector<Connection> incoming;
        std::string name;
        // Sorted by `from`, the destinations inline, in one list: the push walks them over the whole downstream of
        // the scene time every frame.
        std::pmr::vector<Edge> outgoing;

        const std::vector<AttributeSpec>& specs() const { return ownSpecs ? *ownSpecs : type->attributes(); }
        const AttributeSpec& spec(AttrId a) const { return specs()[static_cast<std::size_t>(a)]; }
        // What attribute a affects on this node: its type's table (a dynamic attribute affects nothing).
        const std::vector<AttrId>& affects(AttrId a) const
        {
            static const std::vector<AttrId> none;
            return static_cast<std::size_t>(a) < type->attributes().size() ? type->affects(a) : none;
        }
        // The connections out of attribute a.
        std::span<const Edge> outgoingFrom(AttrId a) const
        {
            const auto [first, last] = std::equal_range(outgoing.begin(), outgoing.end(), Edge{a, 0, 0, 0},
                                                        [](const Edge& x, const Edge& y) { return x.from < y.from; });
            return {first, last};
        }
    };

    explicit GraphModel(std::shared_ptr<NodeRegistry> registry);
    // A copy to edit (the schedule is rebuilt on first use).
    GraphModel(const GraphModel& other);
    GraphModel& operator=(const GraphModel&) = delete;

    NodeRegistry& registry() const { return *registry_; }
    const std::shared_ptr<NodeRegistry>& sharedRegistry() const { return registry_; }

    // --- editing (through Graph) -------------------------------------------------------------------
    // Throws rig::Error for an unknown type, an invalid name or a name already used.
    NodeId addNode(std::string_view typeName, std::string_view name);
    // A dynamic attribute (Maya's addAttr): an input that affects nothing on its node.
    AttrId addAttribute(NodeId node, AttributeSpec spec);
    // Type-checked; refuses a second source for an input, outputs as destinations, and any connection
    // that would close a cycle (the message lists the whole cycle). convertUnits false: the value crosses as it is
    // stored (radians into a unitless plug), as in a Maya scene, which carries its own unitConversion nodes.
    void connect(const Plug& source, const Plug& destination, bool convertUnits = true);
    void disconnect(Plug source, Plug destination);

    // --- queries -----------------------------------------------------------------------------------
    int nodeCount() const { return static_cast<int>(nodes_.size()); }
    const NodeTopology& topology(NodeId node) const { return nodes_.at(static_cast<std::size_t>(node)); }
    // -1 when there is no such node.
    NodeId findNode(std::string_view name) const;
    // Throws rig::Error naming the closest node when there is no such node.
    NodeId node(std::string_view name) const;
    // Parses "node.attr", "node.attr[3]", "node.attrX", "node.attr[3].attrX"; throws rig::Error with a
    // suggestion when the node or attribute does not exist.
    Plug plug(std::string_view path) const;
    std::string plugName(const Plug& plug) const;
    const AttributeSpec& spec(const Plug& plug) const { return topology(plug.node).spec(plug.attr); }
    // The plug's own data type: Double for a vector3 component.
    ValueType plugType(const Plug& plug) const;
    // Throws rig::Error for an array attribute named without an element; an internal one for a plug that
    // does not exist.
    void checkPlug(const Plug& plug) const;
    const std::vector<Connection>& connections() const { return connections_; }
    // The connection driving `destination` (or a component or parent of it), if any.
    const Connection* incomingConnection(const Plug& destination) const;

    // Every node's lists made again one after the other, in node order, in one block: what a frame walks node by
    // node then lies together, a crowd member's after the one before it, in place of blocks spread over the heap
    // among the loader's (a loader calls it once the graph is built). Not while another thread reads the model.
    void compactLists();

    // The evaluation order, built on first use after the topology changed (thread-safe).
    std::shared_ptr<const Schedule> schedule() const;
    // The plugs that take the scene time (AttributeSpec::sceneTime) and have no incoming connection, built on first
    // use after the topology changed (thread-safe): Graph::setTime sets them without a pass over every attribute.
    std::shared_ptr<const std::vector<Plug>> timePlugs() const;

private:
    std::vector<int> cyclePath(NodeId from, NodeId to) const;
    void topologyChanged();

    std::shared_ptr<NodeRegistry> registry_;
    // Where the nodes' lists are allocated: in order, never freed until compactLists or the model goes (a list that
    // grows leaves its old block behind), so that lists made together lie together. Before nodes_, which uses it.
    std::unique_ptr<std::pmr::monotonic_buffer_resource> lists_ =
        std::make_unique<std::pmr::monotonic_buffer_resource>();
    std::vector<NodeTopology> nodes_;
    std::unordered_map<std::string, NodeId> nodeIndex_;  // name -> node: loading stays linear in size
    std::vector<Connection> connections_;
    // The lists of the nodes with dynamic attributes, per type: nodes that add the same attributes share one.
    struct DynamicSpecs {
        const NodeType* type;
        std::weak_ptr<const std::vector<AttributeSpec>> specs;
    };
    std::vector<DynamicSpecs> dynamicSpecs_;
    std::shared_ptr<const std::vector<AttributeSpec>> sharedSpecs(
        const NodeType& type, std::shared_ptr<const std::vector<AttributeSpec>> specs);
    mutable std::mutex scheduleMutex_;
    mutable std::shared_ptr<const Schedule> schedule_;
    mutable std::shared_ptr<const std::vector<Plug>> timePlugs_;
};

}  // namespace rig

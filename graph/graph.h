#pragma once
// A dependency graph instance (Maya's DG): a shared model (nodes with typed attributes, connections and
// the schedule, graph_model.h) and this instance's state (stored values, dirty bits, caches and the
// nodes' own state). Setting a plug marks what it affects dirty (push); reading a plug computes what is
// dirty upstream of it (pull). One instance is not thread-safe to use from several threads, but any
// number of instances of one model (instance()) evaluate at the same time; inside one evaluation,
// independent nodes may compute in parallel on a tbb::flow::graph (setThreads).

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "graph/graph_model.h"
#include "graph/plug.h"
#include "graph/value_store.h"

namespace rig {

class FlowExecutor;

class Graph {
public:
    // Array elements of inputs over the whole instance (stored densely up to the highest index, about 150
    // bytes each: 150 MB at most), checked before allocating (docs/robustness.md). The model's limits are
    // in graph_model.h.
    static constexpr std::size_t maxArrayElements = std::size_t{1} << 20;

    explicit Graph(std::shared_ptr<NodeRegistry> registry);
    ~Graph();
    Graph(const Graph&) = delete;
    Graph& operator=(const Graph&) = delete;

    // Another instance of this graph: the same model (shared, not copied: a rig file is parsed once), the
    // values set on this one's inputs and its scene time, and its own caches and node state, as if
    // nothing had been computed. Editing either graph's topology afterwards copies its model first.
    std::unique_ptr<Graph> instance() const;
    // Starts stateful nodes again (history-dependent ones forget their past), as in a fresh instance; what
    // they feed computes again, other caches stay (they hold what a fresh instance would compute), and so
    // do set values.
    void resetState();

    const GraphModel& model() const { return *model_; }
    NodeRegistry& registry() { return model_->registry(); }
    std::shared_ptr<NodeRegistry> sharedRegistry() const { return model_->sharedRegistry(); }

    // --- nodes -----------------------------------------------------------------------------------
    // Throws rig::Error for an unknown type, an invalid name or a name already used.
    NodeId addNode(std::string_view typeName, std::string_view name);
    // A dynamic attribute on one node (Maya's addAttr): an input that affects nothing on its node
    // and can be set, connected into, and connected from.
    AttrId addAttribute(NodeId node, AttributeSpec spec);
    int nodeCount() const { return model_->nodeCount(); }
    // -1 when there is no such node.
    NodeId findNode(std::string_view name) const { return model_->findNode(name); }
    // Throws rig::Error naming the closest node when there is no such node.
    NodeId node(std::string_view name) const { return model_->node(name); }
    const std::string& nodeName(NodeId node) const { return model_->topology(node).name; }
    const NodeType& nodeType(NodeId node) const { return *model_->topology(node).type; }
    const std::vector<AttributeSpec>& attributes(NodeId node) const { return model_->topology(node).specs(); }

    // --- plugs -----------------------------------------------------------------------------------
    // Parses "node.attr", "node.attr[3]", "node.attrX", "node.attr[3].attrX"; throws rig::Error with a
    // suggestion when the node or attribute does not exist.
    Plug plug(std::string_view path) const { return model_->plug(path); }
    std::string plugName(const Plug& plug) const { return model_->plugName(plug); }
    const AttributeSpec& spec(const Plug& plug) const { return model_->spec(plug); }
    // The plug's own data type: Double for a vector3 component.
    ValueType plugType(const Plug& plug) const { return model_->plugType(plug); }
    // Existing elements of an array attribute (inputs: set or connected; outputs: last computed).
    std::vector<int> elementIndices(NodeId node, AttrId attr) const;

    // --- connections -----------------------------------------------------------------------------
    // Type-checked; refuses a second source for an input, outputs as destinations, and any
    // connection that would close a cycle (the message lists the whole cycle).
    void connect(const Plug& source, const Plug& destination, bool convertUnits = true);
    void disconnect(Plug source, Plug destination);
    const std::vector<Connection>& connections() const { return model_->connections(); }
    // The connection driving `destination` (or a component or parent of it), if any.
    const Connection* incomingConnection(const Plug& destination) const
    {
        return model_->incomingConnection(destination);
    }

    // --- values (internal units: radians for angles) ----------------------------------------------
    // Sets an unconnected input; checks type, finiteness and the attribute's min/max.
    void setValue(const Plug& plug, const Value& value);
    // Computes what is needed and returns the plug's value.
    Value getValue(const Plug& plug);
    // Brings all these plugs up to date in one evaluation (parallel when threads() > 1).
    void evaluate(std::span<const Plug> plugs);
    // The same, then their values into `values` (resized to one per plug, its storage kept): what getValue gives each,
    // each plug checked and its flag read once (a crowd's player reads a thousand plugs a frame).
    void evaluate(std::span<const Plug> plugs, std::vector<Value>& values);
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

    // Lays the model's lists out in node order (GraphModel::compactLists), a shared model in this instance's own
    // copy, and gives back what this instance's lists hold past their size: the loaders call it once a graph is
    // built, before its frames are played.
    void compact();

    // Marks every output and every connected input dirty, as if nothing had been computed.
    void dirtyAll();
    // Gaffer-style checked mode: evaluates everything, recomputes everything from scratch, and returns
    // the plugs whose cached value differed (a node type whose affects table misses an entry). Nodes of
    // stateful types, and what they feed, are not compared.
    std::vector<std::string> checkEvaluation();

private:
    // The model, copied first when other instances share it.
    GraphModel& editModel();
    void addNodeState(NodeId node);
    char& dirtyFlag(const Plug& plug);
    // Where attribute a of node n is in the flat per-attribute lists.
    std::size_t at(NodeId n, AttrId a) const
    {
        return firstAttr_[static_cast<std::size_t>(n)] + static_cast<std::size_t>(a);
    }
    std::size_t attributeCount(NodeId n) const
    {
        return firstAttr_[static_cast<std::size_t>(n) + 1] - firstAttr_[static_cast<std::size_t>(n)];
    }
    ValueStore::Slot slot(const Plug& plug) const { return slots_[at(plug.node, plug.attr)]; }
    // A plug's stored value as its attribute's type T (an array element: the attribute's default where it does not
    // exist), the plug's component aside; storage() makes the element.
    template <class T>
    const T& stored(const Plug& plug) const;
    template <class T>
    T& storage(const Plug& plug);
    // Makes array element plug.index of the plug's attribute, the default where it is new; returns the attribute's
    // elements.
    ArrayData& element(const Plug& plug);
    Value readStored(const Plug& plug) const;
    Value pulledValue(const Connection& connection) const;
    void writeStored(const Plug& plug, const Value& value);
    // Brings a connection's destination up to date from its source.
    void pull(const Connection& connection);

    // setValue's checks and store, without the push.
    void assignInput(const Plug& plug, const Value& value);
    void dirtyInput(NodeId node, AttrId attr);
    void dirtyAffectedBy(NodeId node, AttrId attr);
    // Sets `flags` (one per attribute, laid out as dirty_) on everything attribute `attr` of `node` affects, here and
    // downstream, stopping at flags already set.
    void markDownstream(std::vector<char>& flags, NodeId node, AttrId attr);
    void buildTimeDownstream();

    // Computes what `roots` need (roots may be roots_).
    void evaluateNodes(std::span<const NodeId> roots);
    // Keeps what `roots` needed, in the schedule's order, for the next evaluation of the same roots.
    void keepPlan(std::span<const NodeId> roots, const std::vector<NodeId>& list, const Schedule& schedule);
    void processNode(NodeId node);
    // A node about to be processed, fetched in two steps (FlowExecutor::recordsAhead and nodesAhead nodes ahead, serial
    // or not): its records (the model's and the instance's), then what they point to (its incoming list, its Node
    // object) once they have arrived.
    void prefetchRecords(NodeId node) const;
    void prefetchNode(NodeId node) const;

    std::shared_ptr<GraphModel> model_;
    // The instance's state per attribute, flat over the nodes in their order (node n's attribute a at
    // firstAttr_[n] + a), so that a crowd member's flags and slots lie together: the push walks the flags over
    // the whole downstream of the scene time every frame, the pull reads them and the slots node by node.
    std::vector<std::uint32_t> firstAttr_{0};  // per node, and one past the last node's
    std::vector<ValueStore::Slot> slots_;      // where each attribute's value is in store_
    std::vector<char> dirty_;                  // outputs: need a compute; inputs: need a pull from their source
    // Per node: its own state, and its computations.
    std::vector<std::unique_ptr<Node>> impls_;
    std::vector<std::uint64_t> computes_;
    ValueStore store_;
    std::size_t arrayElements_ = 0;                      // input array elements allocated, all nodes
    std::vector<std::pair<NodeId, AttrId>> dirtyStack_;  // markDownstream's, kept: it runs per plug set
    // What setting the scene time makes dirty (the downstream of every time plug), as runs of dirty_: a crowd's frame
    // marks them in a few streams instead of walking every member's records again. Built at the first setTime after
    // an edit of the model.
    struct DirtyRun {
        std::uint32_t first, count;
    };
    std::vector<DirtyRun> timeDownstream_;
    bool timeDownstreamBuilt_ = false;
    // evaluate()'s, kept: the nodes of the plugs asked for, the nodes they need, and a flag per node (all 0
    // between evaluations).
    std::vector<NodeId> roots_, list_;
    std::vector<char> needed_;
    // A player's frames change nothing but the scene time between two evaluations of the same plugs: dirty flags then
    // grow only by the time's runs, the same each frame, and evaluations only clear them, so what the last such frame
    // needed is what this one needs, or more (a node found clean computes nothing). Kept from the second evaluation
    // after a change of anything else (epoch_: every other change of flags or topology), so that a frame skips the
    // marking and the sort.
    struct Plan {
        std::vector<NodeId> roots, list;
        std::uint64_t epoch = 0;
    };
    Plan plan_;
    std::uint64_t epoch_ = 1, lastEpoch_ = 0;  // lastEpoch_: epoch_ at the last evaluation
    double time_ = 0.0;
    int threads_ = 1;
    std::shared_ptr<const Schedule> schedule_;  // the model's, taken at the first evaluation after an edit
    std::unique_ptr<FlowExecutor> flow_;        // built on the first parallel evaluation of a schedule
};

}  // namespace rig

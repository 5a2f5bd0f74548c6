#include "graph/graph.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <utility>

#include <fmt/format.h>
#include <tbb/info.h>

#include "core/error.h"
#include "core/prefetch.h"
#include "graph/flow_executor.h"

namespace rig {

namespace {

// Numbers are shown to users in their units (degrees for angles).
double userScale(const AttributeSpec& spec) { return unitFactor(spec.unit, Unit::None); }

// The schedule's order: every node after those it reads.
void sortByRank(std::vector<NodeId>& nodes, const Schedule& s)
{
    std::sort(nodes.begin(), nodes.end(), [&](NodeId a, NodeId b) {
        return s.rank()[static_cast<std::size_t>(a)] < s.rank()[static_cast<std::size_t>(b)];
    });
}

}  // namespace

Graph::Graph(std::shared_ptr<NodeRegistry> registry) : model_(std::make_shared<GraphModel>(std::move(registry))) {}

Graph::~Graph() = default;

std::unique_ptr<Graph> Graph::instance() const
{
    auto other = std::make_unique<Graph>(sharedRegistry());
    other->model_ = model_;
    other->schedule_ = schedule_;
    other->arrayElements_ = arrayElements_;
    other->time_ = time_;
    other->store_ = store_;
    other->firstAttr_ = firstAttr_;
    other->slots_ = slots_;
    other->dirty_.assign(dirty_.size(), 0);
    for (NodeId n = 0; n < nodeCount(); ++n) other->impls_.push_back(nodeType(n).create());
    other->computes_.assign(computes_.size(), 0);
    other->dirtyAll();
    return other;
}

void Graph::resetState()
{
    // Only stateful nodes and what they feed compute again: every other cache holds what a fresh instance
    // would compute (checked mode holds the graph to that).
    for (NodeId n = 0; n < nodeCount(); ++n) {
        if (!model_->topology(n).type->stateful()) continue;
        impls_[static_cast<std::size_t>(n)] = nodeType(n).create();
        for (AttrId a = 0; static_cast<std::size_t>(a) < attributeCount(n); ++a) {
            char& dirty = dirty_[at(n, a)];
            if (model_->topology(n).spec(a).input || dirty) continue;
            dirty = 1;
            dirtyAffectedBy(n, a);
        }
    }
}

void Graph::compact()
{
    // A copy of the model is made in node order; a model this instance alone holds is compacted where it is.
    if (model_.use_count() > 1) editModel();
    else model_->compactLists();
    // A crowd's lists end at up to twice their size (256 bipeds: 33 MB of matrices for 18).
    store_.shrink();
    slots_.shrink_to_fit();
    dirty_.shrink_to_fit();
    firstAttr_.shrink_to_fit();
    impls_.shrink_to_fit();
    computes_.shrink_to_fit();
}

GraphModel& Graph::editModel()
{
    // Shared with other instances: this one takes its own copy, theirs stays as it is.
    if (model_.use_count() > 1) model_ = std::make_shared<GraphModel>(*model_);
    schedule_.reset();  // the topology is about to change
    timeDownstreamBuilt_ = false;
    ++epoch_;
    return *model_;
}

void Graph::addNodeState(NodeId node)
{
    const NodeType& type = nodeType(node);
    for (const AttributeSpec& spec : type.attributes()) {
        slots_.push_back(spec.array       ? store_.addArray()
                         : spec.sceneTime ? store_.add(spec.type, time_)
                                          : store_.add(spec.type, spec.defaultValue));
        dirty_.push_back(spec.input ? 0 : 1);  // never computed yet
    }
    firstAttr_.push_back(static_cast<std::uint32_t>(slots_.size()));
    impls_.push_back(type.create());
    computes_.push_back(0);
}

NodeId Graph::addNode(std::string_view typeName, std::string_view name)
{
    const NodeId node = editModel().addNode(typeName, name);
    addNodeState(node);
    return node;
}

AttrId Graph::addAttribute(NodeId node, AttributeSpec spec)
{
    const ValueStore::Slot slot = spec.array ? store_.addArray() : store_.add(spec.type, spec.defaultValue);
    const AttrId attr = editModel().addAttribute(node, std::move(spec));
    // After the node's last attribute: the nodes after it move up by one (a scene adds attributes to the node it
    // has just made, the last one, mostly).
    const std::size_t end = firstAttr_[static_cast<std::size_t>(node) + 1];
    slots_.insert(slots_.begin() + static_cast<std::ptrdiff_t>(end), slot);
    dirty_.insert(dirty_.begin() + static_cast<std::ptrdiff_t>(end), 0);
    for (std::size_t n = static_cast<std::size_t>(node) + 1; n < firstAttr_.size(); ++n) ++firstAttr_[n];
    return attr;
}

std::vector<int> Graph::elementIndices(NodeId node, AttrId attr) const
{
    if (node < 0 || node >= nodeCount() || attr < 0 || static_cast<std::size_t>(attr) >= attributeCount(node))
        throw internalError(fmt::format("elementIndices: no attribute {} on node {}", attr, node));
    std::vector<int> indices;
    const ArrayData* d = model_->topology(node).spec(attr).array ? store_.array(slot(Plug{node, attr})) : nullptr;
    for (std::size_t i = 0; d && i < d->size(); ++i)
        if (d->has(i)) indices.push_back(static_cast<int>(i));
    return indices;
}

char& Graph::dirtyFlag(const Plug& p) { return dirty_[at(p.node, p.attr)]; }

template <class T>
const T& Graph::stored(const Plug& p) const
{
    const AttributeSpec& s = spec(p);
    if (!s.array) return store_.get<T>(slot(p));
    const ArrayData* array = store_.array(slot(p));
    const auto i = static_cast<std::size_t>(p.index);
    return array && array->has(i) ? array->get<T>(i) : std::get<T>(s.defaultValue);
}

Value Graph::readStored(const Plug& p) const
{
    return visitValueType(spec(p).type, [&]<class T>(std::type_identity<T>) -> Value {
        const T& v = stored<T>(p);
        if constexpr (std::is_same_v<T, Eigen::Vector3d>)
            if (p.child >= 0) return v[p.child];
        return v;
    });
}

template <class T>
T& Graph::storage(const Plug& p)
{
    if (!spec(p).array) return store_.get<T>(slot(p));
    return element(p).get<T>(static_cast<std::size_t>(p.index));
}

ArrayData& Graph::element(const Plug& p)
{
    const AttributeSpec& s = spec(p);
    ArrayData& array = store_.elements(slot(p), s.type);
    const auto i = static_cast<std::size_t>(p.index);
    if (i >= array.size()) {
        const std::size_t growth = i + 1 - array.size();
        if (arrayElements_ + growth > maxArrayElements)
            throw Error(
                fmt::format("{}: the rig's array attributes would hold more than {} elements in all; "
                            "elements are stored up to the highest index, so number them from 0",
                            plugName(p), maxArrayElements));
        arrayElements_ += growth;
    }
    array.make(i, s.defaultValue);
    return array;
}

void Graph::writeStored(const Plug& p, const Value& value)
{
    visitValueType(spec(p).type, [&]<class T>(std::type_identity<T>) {
        T& target = storage<T>(p);
        if constexpr (std::is_same_v<T, Eigen::Vector3d>)
            if (p.child >= 0) {
                target[p.child] = std::get<double>(value);
                return;
            }
        target = std::get<T>(value);
    });
}

// --- connections ------------------------------------------------------------------------------------

void Graph::connect(const Plug& src, const Plug& dst, bool convertUnits)
{
    editModel().connect(src, dst, convertUnits);
    if (spec(dst).array) element(dst);  // the element exists from its connection on
    dirtyInput(dst.node, dst.attr);
}

void Graph::disconnect(const Plug src, const Plug dst)
{
    // By value: the caller's plugs may be the connection's own, which the model's edit removes.
    editModel().disconnect(src, dst);
    // The input keeps its last value, as in Maya; what it affects must see the change of source.
    dirtyAffectedBy(dst.node, dst.attr);
}

// --- dirty propagation (push) --------------------------------------------------------------------------

void Graph::dirtyAffectedBy(NodeId node, AttrId attr)
{
    ++epoch_;  // a change other than the scene time's: evaluations look again at what they need
    markDownstream(dirty_, node, attr);
}

void Graph::markDownstream(std::vector<char>& flags, NodeId node, AttrId attr)
{
    // Iterative: production chains are thousands of nodes deep. A plug already flagged has a flagged
    // downstream (the invariant pull keeps for dirty flags), so the walk stops there.
    std::vector<std::pair<NodeId, AttrId>>& stack = dirtyStack_;
    stack.assign(1, {node, attr});
    while (!stack.empty()) {
        const auto [n, a] = stack.back();
        stack.pop_back();
        const GraphModel::NodeTopology& top = model_->topology(n);
        char* flag = flags.data() + firstAttr_[static_cast<std::size_t>(n)];
        for (AttrId o : top.affects(a)) {
            if (flag[o]) continue;
            flag[o] = 1;
            stack.emplace_back(n, o);
        }
        for (const GraphModel::NodeTopology::Edge& e : top.outgoingFrom(a)) {
            char& f = flags[at(e.node, e.attr)];
            if (f) continue;
            f = 1;
            stack.emplace_back(e.node, e.attr);
        }
    }
}

void Graph::buildTimeDownstream()
{
    std::vector<char> reached(dirty_.size(), 0);
    for (const Plug& p : *model_->timePlugs()) markDownstream(reached, p.node, p.attr);
    timeDownstream_.clear();
    for (std::size_t i = 0; i < reached.size(); ++i) {
        if (!reached[i]) continue;
        if (!timeDownstream_.empty() && timeDownstream_.back().first + timeDownstream_.back().count == i)
            ++timeDownstream_.back().count;
        else timeDownstream_.push_back({static_cast<std::uint32_t>(i), 1});
    }
    timeDownstream_.shrink_to_fit();
    timeDownstreamBuilt_ = true;
}

void Graph::dirtyInput(NodeId node, AttrId attr)
{
    char& d = dirty_[at(node, attr)];
    if (d) return;
    d = 1;
    dirtyAffectedBy(node, attr);
}

void Graph::dirtyAll()
{
    ++epoch_;
    for (NodeId n = 0; n < nodeCount(); ++n) {
        const GraphModel::NodeTopology& top = model_->topology(n);
        char* dirty = dirty_.data() + firstAttr_[static_cast<std::size_t>(n)];
        for (AttrId a : top.type->outputs()) dirty[a] = 1;
        for (const Connection& c : top.incoming) dirty[c.destination.attr] = 1;
    }
}

// --- values -------------------------------------------------------------------------------------------

void Graph::setValue(const Plug& p, const Value& value)
{
    assignInput(p, value);
    dirtyAffectedBy(p.node, p.attr);
}

void Graph::assignInput(const Plug& p, const Value& value)
{
    model_->checkPlug(p);
    const AttributeSpec& s = spec(p);
    // Named only for a message: setTime sets every member of a crowd each frame.
    const auto name = [&] { return plugName(p); };
    if (!s.input) throw Error(fmt::format("cannot set {}: it is an output, computed by its node", name()));
    if (const Connection* c = incomingConnection(p))
        throw Error(fmt::format("cannot set {}: it is driven by {}; disconnect it first", name(), plugName(c->source)));
    const ValueType type = plugType(p);
    if (value.index() != zeroValue(type).index())
        throw Error(fmt::format("cannot set {}: expected a {} value", name(), valueTypeName(type)));
    if (!isFinite(value)) throw Error(fmt::format("cannot set {}: value is not a finite number", name()));
    if (type == ValueType::Enum) {
        const int v = std::get<int>(value);
        if (v < 0 || static_cast<std::size_t>(v) >= s.enumNames.size())
            throw Error(
                fmt::format("cannot set {}: enum index {} out of range 0..{}", name(), v, s.enumNames.size() - 1));
    }
    auto checkRange = [&](double x) {
        const double k = userScale(s);
        if (s.min && x < *s.min)
            throw Error(fmt::format("cannot set {}: {} is below its minimum {}", name(), x * k, *s.min * k));
        if (s.max && x > *s.max)
            throw Error(fmt::format("cannot set {}: {} is above its maximum {}", name(), x * k, *s.max * k));
    };
    if (isNumeric(type)) checkRange(toDouble(value));
    else if (const auto* v = std::get_if<Eigen::Vector3d>(&value))
        for (int i = 0; i < 3; ++i) checkRange((*v)[i]);
    writeStored(p, value);
}

Value Graph::getValue(const Plug& p)
{
    evaluate(std::span<const Plug>(&p, 1));
    return readStored(p);
}

void Graph::setTime(double frame)
{
    time_ = frame;
    const std::shared_ptr<const std::vector<Plug>> plugs = model_->timePlugs();
    for (const Plug& p : *plugs) assignInput(p, frame);
    // What the walks from each time plug would mark (the flags they stop at hold a marked downstream), in runs.
    if (!timeDownstreamBuilt_) buildTimeDownstream();
    for (const DirtyRun& r : timeDownstream_) std::memset(dirty_.data() + r.first, 1, r.count);
}

void Graph::setThreads(int threads)
{
    if (threads < 0) throw Error(fmt::format("thread count {} is negative; use 0 for all cores", threads));
    threads_ = threads == 0 ? tbb::info::default_concurrency() : threads;
}

std::uint64_t Graph::computeCount() const
{
    return std::accumulate(computes_.begin(), computes_.end(), std::uint64_t{0});
}

std::uint64_t Graph::computeCount(NodeId node) const { return computes_.at(static_cast<std::size_t>(node)); }

// --- evaluation (pull) --------------------------------------------------------------------------------

void Graph::evaluate(std::span<const Plug> plugs)
{
    roots_.clear();
    for (const Plug& p : plugs) {
        model_->checkPlug(p);
        if (dirtyFlag(p)) roots_.push_back(p.node);
    }
    // Reading clean plugs must not cost a pass over the whole graph: a rig reads every joint per evaluation.
    if (!roots_.empty()) evaluateNodes(roots_);
}

void Graph::evaluate(std::span<const Plug> plugs, std::vector<Value>& values)
{
    evaluate(plugs);
    values.resize(plugs.size());
    for (std::size_t i = 0; i < plugs.size(); ++i) values[i] = readStored(plugs[i]);
}

void Graph::evaluateAll()
{
    roots_.resize(static_cast<std::size_t>(nodeCount()));
    std::iota(roots_.begin(), roots_.end(), NodeId{0});
    evaluateNodes(roots_);
}

void Graph::evaluateNodes(std::span<const NodeId> roots)
{
    // needed_ is all 0 between evaluations (kept, as list_ is: a crowd's frame allocates nothing); what this one
    // marks, the nodes of list_, is unmarked on the way out, whether a node threw or not.
    needed_.resize(static_cast<std::size_t>(nodeCount()), 0);
    std::vector<NodeId>& list = list_;
    // Only the scene time changed since the last evaluation: what these roots need is what they needed then, or less.
    const bool steady = lastEpoch_ == epoch_;
    lastEpoch_ = epoch_;
    const bool planned = steady && plan_.epoch == epoch_ &&
                         std::equal(roots.begin(), roots.end(), plan_.roots.begin(), plan_.roots.end());
    if (planned) {
        list.assign(plan_.list.begin(), plan_.list.end());  // in the schedule's order
        for (const NodeId n : list) needed_[static_cast<std::size_t>(n)] = 1;
    } else {
        list.clear();
        for (const NodeId n : roots)
            if (!std::exchange(needed_[static_cast<std::size_t>(n)], char{1})) list.push_back(n);
    }
    const struct Unmark {
        std::vector<char>& needed;
        const std::vector<NodeId>& list;
        ~Unmark()
        {
            for (const NodeId n : list) needed[static_cast<std::size_t>(n)] = 0;
        }
    } unmark{needed_, list};
    // A needed node pulls all of its dirty inputs, so the sources of those are needed too.
    for (std::size_t i = 0; !planned && i < list.size(); ++i) {
        for (const Connection& c : model_->topology(list[i]).incoming) {
            const auto src = static_cast<std::size_t>(c.source.node);
            if (needed_[src] || !dirtyFlag(c.destination) || !dirtyFlag(c.source)) continue;
            needed_[src] = 1;
            list.push_back(c.source.node);
        }
    }
    // Held by the instance: a shared model is read-only, so only this instance's edits change its schedule,
    // and evaluations on other threads do not meet at the model's lock.
    if (!schedule_) schedule_ = model_->schedule();
    const std::shared_ptr<const Schedule>& s = schedule_;
    if (steady && !planned) keepPlan(roots, list, *s);
    if (threads_ > 1 && list.size() > 1) {
        if (!flow_ || flow_->schedule() != s.get() || flow_->threads() != threads_)
            flow_ = std::make_unique<FlowExecutor>(s, threads_);
        // A small part of a large graph (a crowd's curves) level by level over what is needed; most of it
        // through the flow graph, whose messages then cost less than the levels' barriers.
        if (list.size() * 4 < static_cast<std::size_t>(nodeCount()))
            flow_->runActive(
                list, needed_, [this](int n) { processNode(n); },
                [this](int n, bool records) { records ? prefetchRecords(n) : prefetchNode(n); });
        else flow_->run(needed_, [this](int n) { processNode(n); });
        return;
    }
    if (!planned) sortByRank(list, *s);
    // The nodes of a crowd's frame are far apart in memory and each reached through several lists: the next ones'
    // are fetched while this one computes.
    for (std::size_t i = 0; i < list.size(); ++i) {
        if (i + FlowExecutor::recordsAhead < list.size()) prefetchRecords(list[i + FlowExecutor::recordsAhead]);
        if (i + FlowExecutor::nodesAhead < list.size()) prefetchNode(list[i + FlowExecutor::nodesAhead]);
        processNode(list[i]);
    }
}

namespace {

// A number in a message: NaN and infinities as words (fmt would print "-nan").
std::string numberText(double x)
{
    if (std::isnan(x)) return "NaN";
    if (std::isinf(x)) return x > 0 ? "infinity" : "-infinity";
    return fmt::format("{}", x);
}

}  // namespace

Value Graph::pulledValue(const Connection& c) const
{
    const ValueType from = plugType(c.source);
    const ValueType to = plugType(c.destination);
    const double factor = c.rawUnits ? 1.0 : unitFactor(spec(c.source).unit, spec(c.destination).unit);
    const Value source = readStored(c.source);
    if ((to == ValueType::Int || to == ValueType::Enum) && from != ValueType::Int && from != ValueType::Enum) {
        // A number computed upstream (NaN from a degenerate node, say) must not become an arbitrary int,
        // nor an enum index the node has no entry for.
        const double x = std::round(toDouble(source) * factor);
        const AttributeSpec& s = spec(c.destination);
        if (to == ValueType::Enum && !(x >= 0 && x < static_cast<double>(s.enumNames.size())))
            throw Error(
                fmt::format("{} receives {} from {}, not one of its enum indices 0..{}; clamp or remap the "
                            "source",
                            plugName(c.destination), numberText(toDouble(source) * factor), plugName(c.source),
                            s.enumNames.size() - 1));
        if (!(std::abs(x) <= 2147483647.0))
            throw Error(
                fmt::format("{} receives {} from {}, which is not a whole number an int attribute holds; "
                            "clamp the source",
                            plugName(c.destination), numberText(toDouble(source) * factor), plugName(c.source)));
    }
    if (to == ValueType::Enum && (from == ValueType::Int || from == ValueType::Enum)) {
        const int v = std::get<int>(source);
        if (v < 0 || static_cast<std::size_t>(v) >= spec(c.destination).enumNames.size())
            throw Error(
                fmt::format("{} receives {} from {}, not one of its enum indices 0..{}; clamp or remap the "
                            "source",
                            plugName(c.destination), v, plugName(c.source), spec(c.destination).enumNames.size() - 1));
    }
    return convertValue(source, from, to, factor);
}

void Graph::pull(const Connection& c)
{
    // A value that crosses as it is (most of a rig's connections: matrices into matrices) is assigned in place,
    // reusing the destination's storage, without the conversion's copies.
    const ValueType type = plugType(c.source);
    const bool asItIs = c.source.child < 0 && c.destination.child < 0 && type != ValueType::Enum &&
                        type == plugType(c.destination) &&
                        (c.rawUnits || unitFactor(spec(c.source).unit, spec(c.destination).unit) == 1.0);
    if (asItIs)
        visitValueType(type, [&]<class T>(std::type_identity<T>) { storage<T>(c.destination) = stored<T>(c.source); });
    else writeStored(c.destination, pulledValue(c));
}

void Graph::keepPlan(std::span<const NodeId> roots, const std::vector<NodeId>& list, const Schedule& s)
{
    plan_.roots.assign(roots.begin(), roots.end());
    plan_.list = list;
    sortByRank(plan_.list, s);
    plan_.epoch = epoch_;
}

void Graph::prefetchRecords(NodeId node) const
{
    const std::size_t first = firstAttr_[static_cast<std::size_t>(node)], count = attributeCount(node);
    prefetchBytes(&model_->topology(node), 64);  // the record's first line: what the marking and computing read
    prefetchBytes(dirty_.data() + first, count);
    prefetchBytes(slots_.data() + first, count * sizeof(ValueStore::Slot));
    prefetchBytes(&impls_[static_cast<std::size_t>(node)], sizeof(impls_[0]));
}

void Graph::prefetchNode(NodeId node) const
{
    prefetch(model_->topology(node).incoming);
    prefetchBytes(impls_[static_cast<std::size_t>(node)].get(), 1);  // its virtual table's address
}

void Graph::processNode(NodeId node)
{
    const GraphModel::NodeTopology& top = model_->topology(node);
    const std::size_t first = firstAttr_[static_cast<std::size_t>(node)];
    char* dirty = dirty_.data() + first;
    for (const Connection& c : top.incoming)
        if (dirty[c.destination.attr]) pull(c);
    for (const Connection& c : top.incoming) dirty[c.destination.attr] = 0;

    // The type's list of outputs, not a pass over every attribute's spec: specs are large, and a crowd's frame
    // processes thousands of nodes.
    const std::vector<AttrId>& outputs = top.type->outputs();
    const auto dirtyOutput = [&](AttrId a) { return dirty[a] != 0; };
    if (std::none_of(outputs.begin(), outputs.end(), dirtyOutput)) return;
    ComputeContext context(top.name, top.specs(), store_, std::span(slots_.data() + first, attributeCount(node)));
    impls_[static_cast<std::size_t>(node)]->compute(context);
    ++computes_[static_cast<std::size_t>(node)];
    for (AttrId a : outputs) dirty[a] = 0;
}

namespace {

bool sameElements(const ArrayData* a, const ArrayData* b)
{
    if (!a || !b) return (a ? a->size() : 0) == 0 && (b ? b->size() : 0) == 0;
    return a->sameAs(*b);
}

}  // namespace

std::vector<std::string> Graph::checkEvaluation()
{
    evaluateAll();
    const ValueStore cached = store_;
    dirtyAll();
    evaluateAll();

    // Stateful nodes legitimately change when recomputed; so does everything they feed.
    std::vector<char> tainted(static_cast<std::size_t>(nodeCount()), 0);
    for (NodeId n : model_->schedule()->order()) {
        auto& t = tainted[static_cast<std::size_t>(n)];
        t = model_->topology(n).type->stateful();
        for (const Connection& c : model_->topology(n).incoming) t |= tainted[static_cast<std::size_t>(c.source.node)];
    }
    std::vector<std::string> mismatches;
    for (NodeId n = 0; n < nodeCount(); ++n) {
        if (tainted[static_cast<std::size_t>(n)]) continue;
        const GraphModel::NodeTopology& top = model_->topology(n);
        for (AttrId a = 0; static_cast<std::size_t>(a) < attributeCount(n); ++a) {
            const AttributeSpec& s = top.spec(a);
            const ValueStore::Slot slot = slots_[at(n, a)];
            const bool same = s.array ? sameElements(cached.array(slot), store_.array(slot))
                                      : bitEqual(cached.value(s.type, slot), store_.value(s.type, slot));
            if (!same) mismatches.push_back(fmt::format("{}.{}", top.name, s.name));
        }
    }
    return mismatches;
}

}  // namespace rig

#include "graph/graph.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <deque>
#include <unordered_map>
#include <utility>

#include <fmt/format.h>
#include <tbb/info.h>

#include "core/error.h"
#include "graph/suggest.h"

namespace rig {

struct Graph::NodeRecord {
    std::string name;
    std::shared_ptr<const NodeType> type;
    std::unique_ptr<std::vector<AttributeSpec>> ownSpecs;  // only once a dynamic attribute is added
    const std::vector<AttributeSpec>* specs = nullptr;
    std::vector<AttrData> data;
    std::unique_ptr<Node> impl;
    std::uint64_t computes = 0;
    std::vector<int> incoming;               // indices into connections_
    std::vector<std::vector<int>> outgoing;  // per attribute, indices into connections_

    const std::vector<AttrId>& affects(AttrId a) const
    {
        static const std::vector<AttrId> none;
        return static_cast<std::size_t>(a) < type->attributes().size() ? type->affects(a) : none;
    }
    const AttributeSpec& spec(AttrId a) const { return (*specs)[static_cast<std::size_t>(a)]; }
};

namespace {

bool validNodeName(std::string_view name)
{
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
    return std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':';
    });
}

std::string typeDescription(const AttributeSpec& spec, int child)
{
    return std::string(valueTypeName(child >= 0 ? ValueType::Double : spec.type));
}

// Numbers are shown to users in their units (degrees for angles).
double userScale(const AttributeSpec& spec) { return unitFactor(spec.unit, Unit::None); }

}  // namespace

Graph::Graph(std::shared_ptr<NodeRegistry> registry) : registry_(std::move(registry)) {}

Graph::~Graph() = default;

Graph::NodeRecord& Graph::record(NodeId node) { return *nodes_.at(static_cast<std::size_t>(node)); }

const Graph::NodeRecord& Graph::record(NodeId node) const { return *nodes_.at(static_cast<std::size_t>(node)); }

NodeId Graph::addNode(std::string_view typeName, std::string_view name)
{
    auto type = registry_->get(typeName);
    if (name.size() > maxNameLength)
        throw Error(fmt::format("a node name of {} characters is too long (at most {})", name.size(), maxNameLength));
    if (!validNodeName(name))
        throw Error(fmt::format("invalid node name '{}': use letters, digits, '_' and ':', not starting with a digit",
                                name));
    if (const NodeId existing = findNode(name); existing >= 0)
        throw Error(fmt::format("duplicate node name '{}' (already a {}); node names must be unique", name,
                                record(existing).type->name()));
    if (nodeCount() >= maxNodes)
        throw Error(fmt::format("more than {} nodes; this is not a rig (check includes that multiply, e.g. a file "
                                "included twice at every level)",
                                maxNodes));
    auto rec = std::make_unique<NodeRecord>();
    rec->name = std::string(name);
    rec->type = type;
    rec->specs = &type->attributes();
    for (const AttributeSpec& spec : type->attributes()) {
        AttrData d;
        if (!spec.array) d.value = spec.sceneTime ? Value(time_) : spec.defaultValue;
        d.dirty = !spec.input;  // never computed yet
        rec->data.push_back(std::move(d));
    }
    rec->outgoing.resize(rec->data.size());
    rec->impl = type->create();
    nodeIndex_.emplace(rec->name, static_cast<NodeId>(nodes_.size()));
    nodes_.push_back(std::move(rec));
    topologyChanged();
    return static_cast<NodeId>(nodes_.size() - 1);
}

AttrId Graph::addAttribute(NodeId node, AttributeSpec spec)
{
    NodeRecord& rec = record(node);
    if (spec.name.size() > maxNameLength)
        throw Error(fmt::format("node '{}': an attribute name of {} characters is too long (at most {})", rec.name,
                                spec.name.size(), maxNameLength));
    if (!validNodeName(spec.name))
        throw Error(fmt::format("node '{}': invalid attribute name '{}'", rec.name, spec.name));
    for (const AttributeSpec& existing : *rec.specs)
        if (existing.name == spec.name || childIndex(existing, spec.name) >= 0)
            throw Error(fmt::format("node '{}' ({}) already has an attribute '{}'", rec.name, rec.type->name(), spec.name));
    if (!rec.ownSpecs) {
        rec.ownSpecs = std::make_unique<std::vector<AttributeSpec>>(*rec.specs);
        rec.specs = rec.ownSpecs.get();
    }
    spec.input = true;
    spec.dynamic = true;
    spec.childNames = {spec.name + "X", spec.name + "Y", spec.name + "Z"};
    AttrData d;
    if (!spec.array) d.value = spec.defaultValue;
    rec.ownSpecs->push_back(std::move(spec));
    rec.data.push_back(std::move(d));
    rec.outgoing.emplace_back();
    return static_cast<AttrId>(rec.data.size() - 1);
}

NodeId Graph::findNode(std::string_view name) const
{
    const auto it = nodeIndex_.find(std::string(name));
    return it == nodeIndex_.end() ? -1 : it->second;
}

NodeId Graph::node(std::string_view name) const
{
    const NodeId n = findNode(name);
    if (n >= 0) return n;
    std::vector<std::string> names;
    for (const auto& rec : nodes_) names.push_back(rec->name);
    throw Error(fmt::format("no node named '{}'{}", messageExcerpt(name), didYouMean(name, names)));
}

const std::string& Graph::nodeName(NodeId node) const { return record(node).name; }

const NodeType& Graph::nodeType(NodeId node) const { return *record(node).type; }

const std::vector<AttributeSpec>& Graph::attributes(NodeId node) const { return *record(node).specs; }

Plug Graph::plug(std::string_view path) const
{
    const auto dot = path.find('.');
    if (dot == std::string_view::npos || dot == 0)
        throw Error(
            fmt::format("'{}' is not a plug: expected node.attribute, e.g. elbow.rotateZ", messageExcerpt(path)));
    const NodeId n = node(path.substr(0, dot));
    const NodeRecord& rec = record(n);
    std::string_view rest = path.substr(dot + 1);

    std::string_view attrName = rest.substr(0, rest.find_first_of("[."));
    rest.remove_prefix(attrName.size());
    Plug p{n, -1, -1, -1};
    if (!rest.empty() && rest.front() == '[') {
        const auto close = rest.find(']');
        const std::string_view digits = rest.substr(1, close == std::string_view::npos ? 0 : close - 1);
        int index = -1;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
        if (close != std::string_view::npos && ec == std::errc::result_out_of_range && end == digits.data() + digits.size()
            && digits.front() != '-')
            throw Error(fmt::format("'{}': array index {} is above the limit {}", messageExcerpt(path),
                                    messageExcerpt(digits), maxArrayIndex));
        if (close == std::string_view::npos || digits.empty() || ec != std::errc() || end != digits.data() + digits.size()
            || index < 0)
            throw Error(fmt::format("'{}': bad array index; expected attribute[N] with N = 0, 1, ...",
                                    messageExcerpt(path)));
        if (index > maxArrayIndex)
            throw Error(
                fmt::format("'{}': array index {} is above the limit {}", messageExcerpt(path), index, maxArrayIndex));
        p.index = index;
        rest.remove_prefix(close + 1);
    }
    std::string_view childName;
    if (!rest.empty()) {
        if (rest.front() != '.' || rest.size() < 2)
            throw Error(fmt::format("'{}' is not a plug: unexpected '{}'", messageExcerpt(path), messageExcerpt(rest)));
        childName = rest.substr(1);
    }

    for (std::size_t a = 0; a < rec.specs->size(); ++a) {
        const AttributeSpec& spec = (*rec.specs)[a];
        if (spec.name == attrName) p.attr = static_cast<AttrId>(a);
        else if (p.index < 0 && childName.empty() && !spec.array && childIndex(spec, attrName) >= 0) {
            p.attr = static_cast<AttrId>(a);
            p.child = childIndex(spec, attrName);
        }
        if (p.attr >= 0) break;
    }
    if (p.attr < 0) {
        std::vector<std::string> names;
        for (const AttributeSpec& spec : *rec.specs) {
            names.push_back(spec.name);
            if (spec.type == ValueType::Vector3) names.insert(names.end(), spec.childNames.begin(), spec.childNames.end());
        }
        throw Error(fmt::format("node '{}' ({}) has no attribute '{}'{}", rec.name, rec.type->name(), attrName,
                                didYouMean(attrName, names)));
    }
    const AttributeSpec& spec = rec.spec(p.attr);
    if (p.index >= 0 && !spec.array)
        throw Error(
            fmt::format("'{}': {} is not an array attribute; drop the [index]", messageExcerpt(path), spec.name));
    if (!childName.empty()) {
        p.child = childIndex(spec, childName);
        if (p.child < 0)
            throw Error(fmt::format("'{}': {} has no component '{}'{}", messageExcerpt(path), spec.name, childName,
                                    spec.type == ValueType::Vector3
                                        ? didYouMean(childName, {spec.childNames.begin(), spec.childNames.end()})
                                        : std::string("; only vector3 attributes have components")));
    }
    return p;
}

std::string Graph::plugName(const Plug& p) const
{
    const NodeRecord& rec = record(p.node);
    const AttributeSpec& spec = rec.spec(p.attr);
    const std::string child = p.child >= 0 ? spec.childNames[static_cast<std::size_t>(p.child)] : std::string();
    if (p.index >= 0)
        return child.empty() ? fmt::format("{}.{}[{}]", rec.name, spec.name, p.index)
                             : fmt::format("{}.{}[{}].{}", rec.name, spec.name, p.index, child);
    return fmt::format("{}.{}", rec.name, child.empty() ? spec.name : child);
}

const AttributeSpec& Graph::spec(const Plug& p) const { return record(p.node).spec(p.attr); }

ValueType Graph::plugType(const Plug& p) const { return p.child >= 0 ? ValueType::Double : spec(p).type; }

std::vector<int> Graph::elementIndices(NodeId node, AttrId attr) const
{
    const AttrData& d = record(node).data.at(static_cast<std::size_t>(attr));
    std::vector<int> indices;
    for (std::size_t i = 0; i < d.present.size(); ++i)
        if (d.present[i]) indices.push_back(static_cast<int>(i));
    return indices;
}

void Graph::checkPlug(const Plug& p) const
{
    if (p.node < 0 || p.node >= nodeCount() || p.attr < 0
        || static_cast<std::size_t>(p.attr) >= record(p.node).specs->size())
        throw internalError("Graph: plug does not exist");
    const AttributeSpec& s = spec(p);
    if (s.array && p.index < 0)
        throw Error(fmt::format("{} is an array attribute: name an element, e.g. {}[0]", plugName(p), plugName(p)));
    if (p.child >= 0 && s.type != ValueType::Vector3) throw internalError("Graph: component of a non-vector3 plug");
}

AttrData& Graph::data(const Plug& p) { return record(p.node).data[static_cast<std::size_t>(p.attr)]; }

Value Graph::readStored(const Plug& p) const
{
    const NodeRecord& rec = record(p.node);
    const AttrData& d = rec.data[static_cast<std::size_t>(p.attr)];
    const Value* v = &d.value;
    if (rec.spec(p.attr).array) {
        const auto i = static_cast<std::size_t>(p.index);
        v = i < d.present.size() && d.present[i] ? &d.elements[i] : &rec.spec(p.attr).defaultValue;
    }
    if (p.child >= 0) return std::get<Eigen::Vector3d>(*v)[p.child];
    return *v;
}

void Graph::writeStored(const Plug& p, const Value& value)
{
    NodeRecord& rec = record(p.node);
    AttrData& d = rec.data[static_cast<std::size_t>(p.attr)];
    Value* target = &d.value;
    if (rec.spec(p.attr).array) {
        const auto i = static_cast<std::size_t>(p.index);
        if (i >= d.elements.size()) {
            const std::size_t growth = i + 1 - d.elements.size();
            if (arrayElements_ + growth > maxArrayElements)
                throw Error(fmt::format("{}: the rig's array attributes would hold more than {} elements in all; "
                                        "elements are stored up to the highest index, so number them from 0",
                                        plugName(p), maxArrayElements));
            arrayElements_ += growth;
            d.elements.resize(i + 1, rec.spec(p.attr).defaultValue);
            d.present.resize(i + 1, false);
        }
        d.present[i] = true;
        target = &d.elements[i];
    }
    if (p.child >= 0) std::get<Eigen::Vector3d>(*target)[p.child] = std::get<double>(value);
    else *target = value;
}

// --- connections ------------------------------------------------------------------------------------

const Connection* Graph::incomingConnection(const Plug& dst) const
{
    for (int ci : record(dst.node).incoming) {
        const Connection& c = connections_[static_cast<std::size_t>(ci)];
        const Plug& d = c.destination;
        if (d.attr == dst.attr && d.index == dst.index && (d.child < 0 || dst.child < 0 || d.child == dst.child))
            return &c;
    }
    return nullptr;
}

std::vector<NodeId> Graph::cyclePath(NodeId from, NodeId to) const
{
    // Breadth-first over connections from `from`; returns the connection indices of a path to `to`.
    // Only the nodes reached are stored (not a table of every node): connecting stays cheap in big graphs.
    std::unordered_map<NodeId, int> via{{from, -1}};
    std::deque<NodeId> queue{from};
    while (!queue.empty()) {
        const NodeId n = queue.front();
        queue.pop_front();
        if (n == to) break;
        for (const auto& list : record(n).outgoing)
            for (int ci : list) {
                const NodeId next = connections_[static_cast<std::size_t>(ci)].destination.node;
                if (!via.emplace(next, ci).second) continue;
                queue.push_back(next);
            }
    }
    std::vector<int> path;
    if (!via.contains(to)) return path;
    for (NodeId n = to; n != from;) {
        const int ci = via.at(n);
        path.push_back(ci);
        n = connections_[static_cast<std::size_t>(ci)].source.node;
    }
    std::reverse(path.begin(), path.end());
    return path;
}

void Graph::connect(const Plug& src, const Plug& dst)
{
    checkPlug(src);
    checkPlug(dst);
    const std::string srcName = plugName(src);
    const std::string dstName = plugName(dst);
    const AttributeSpec& dstSpec = spec(dst);
    if (!dstSpec.input)
        throw Error(fmt::format("cannot connect {} -> {}: {} is an output, written by its node's compute; "
                                "connect into an input",
                                srcName, dstName, dstName));
    if (!canConvert(plugType(src), plugType(dst)))
        throw Error(fmt::format("cannot connect {} ({}) -> {} ({}): the types do not match", srcName,
                                typeDescription(spec(src), src.child), dstName, typeDescription(dstSpec, dst.child)));
    if (const Connection* existing = incomingConnection(dst))
        throw Error(fmt::format("cannot connect {} -> {}: {} is already driven by {}; an input takes one source, "
                                "disconnect it first",
                                srcName, dstName, plugName(existing->destination), plugName(existing->source)));
    std::vector<int> path = src.node == dst.node ? std::vector<int>{} : cyclePath(dst.node, src.node);
    if (src.node == dst.node || !path.empty()) {
        std::string cycle;
        for (int ci : path) {
            const Connection& c = connections_[static_cast<std::size_t>(ci)];
            cycle += fmt::format("{} -> {}, ", plugName(c.source), plugName(c.destination));
        }
        throw Error(fmt::format("cannot connect {} -> {}: it would close a cycle ({}{} -> {}); the graph must stay "
                                "acyclic at node level, so feed {} from nodes that do not depend on {}",
                                srcName, dstName, cycle, srcName, dstName, nodeName(dst.node), nodeName(dst.node)));
    }
    connections_.push_back({src, dst});
    const int ci = static_cast<int>(connections_.size() - 1);
    record(src.node).outgoing[static_cast<std::size_t>(src.attr)].push_back(ci);
    record(dst.node).incoming.push_back(ci);
    if (spec(dst).array && readStored(dst).index() == Value().index()) writeStored(dst, readStored(dst));
    topologyChanged();
    dirtyInput(dst.node, dst.attr);
}

void Graph::disconnect(const Plug& src, const Plug& dst)
{
    const auto it = std::find_if(connections_.begin(), connections_.end(), [&](const Connection& c) {
        return c.source == src && c.destination == dst;
    });
    if (it == connections_.end())
        throw Error(fmt::format("cannot disconnect {} -> {}: they are not connected", plugName(src), plugName(dst)));
    connections_.erase(it);
    for (auto& rec : nodes_) {
        rec->incoming.clear();
        for (auto& list : rec->outgoing) list.clear();
    }
    for (std::size_t ci = 0; ci < connections_.size(); ++ci) {
        const Connection& c = connections_[ci];
        record(c.source.node).outgoing[static_cast<std::size_t>(c.source.attr)].push_back(static_cast<int>(ci));
        record(c.destination.node).incoming.push_back(static_cast<int>(ci));
    }
    topologyChanged();
    // The input keeps its last value, as in Maya; what it affects must see the change of source.
    dirtyAffectedBy(dst.node, dst.attr);
}

// --- dirty propagation (push) --------------------------------------------------------------------------

void Graph::dirtyAffectedBy(NodeId node, AttrId attr)
{
    // Iterative: production chains are thousands of nodes deep. A plug already dirty has a dirty
    // downstream (the invariant pull keeps), so the walk stops there.
    std::vector<std::pair<NodeId, AttrId>> stack{{node, attr}};
    while (!stack.empty()) {
        const auto [n, a] = stack.back();
        stack.pop_back();
        NodeRecord& rec = record(n);
        for (AttrId o : rec.affects(a)) {
            AttrData& d = rec.data[static_cast<std::size_t>(o)];
            if (d.dirty) continue;
            d.dirty = true;
            stack.emplace_back(n, o);
        }
        for (int ci : rec.outgoing[static_cast<std::size_t>(a)]) {
            const Plug& dst = connections_[static_cast<std::size_t>(ci)].destination;
            AttrData& d = data(dst);
            if (d.dirty) continue;
            d.dirty = true;
            stack.emplace_back(dst.node, dst.attr);
        }
    }
}

void Graph::dirtyInput(NodeId node, AttrId attr)
{
    AttrData& d = record(node).data[static_cast<std::size_t>(attr)];
    if (d.dirty) return;
    d.dirty = true;
    dirtyAffectedBy(node, attr);
}

void Graph::dirtyAll()
{
    for (auto& rec : nodes_) {
        for (std::size_t a = 0; a < rec->data.size(); ++a)
            if (!rec->spec(static_cast<AttrId>(a)).input) rec->data[a].dirty = true;
        for (int ci : rec->incoming)
            rec->data[static_cast<std::size_t>(connections_[static_cast<std::size_t>(ci)].destination.attr)].dirty = true;
    }
}

// --- values -------------------------------------------------------------------------------------------

void Graph::setValue(const Plug& p, const Value& value)
{
    checkPlug(p);
    const AttributeSpec& s = spec(p);
    const std::string name = plugName(p);
    if (!s.input) throw Error(fmt::format("cannot set {}: it is an output, computed by its node", name));
    if (const Connection* c = incomingConnection(p))
        throw Error(fmt::format("cannot set {}: it is driven by {}; disconnect it first", name, plugName(c->source)));
    const ValueType type = plugType(p);
    if (value.index() != zeroValue(type).index())
        throw Error(fmt::format("cannot set {}: expected a {} value", name, valueTypeName(type)));
    if (!isFinite(value)) throw Error(fmt::format("cannot set {}: value is not a finite number", name));
    if (type == ValueType::Enum) {
        const int v = std::get<int>(value);
        if (v < 0 || static_cast<std::size_t>(v) >= s.enumNames.size())
            throw Error(fmt::format("cannot set {}: enum index {} out of range 0..{}", name, v, s.enumNames.size() - 1));
    }
    auto checkRange = [&](double x) {
        const double k = userScale(s);
        if (s.min && x < *s.min)
            throw Error(fmt::format("cannot set {}: {} is below its minimum {}", name, x * k, *s.min * k));
        if (s.max && x > *s.max)
            throw Error(fmt::format("cannot set {}: {} is above its maximum {}", name, x * k, *s.max * k));
    };
    if (isNumeric(type)) checkRange(toDouble(value));
    else if (const auto* v = std::get_if<Eigen::Vector3d>(&value))
        for (int i = 0; i < 3; ++i) checkRange((*v)[i]);
    writeStored(p, value);
    dirtyAffectedBy(p.node, p.attr);
}

Value Graph::getValue(const Plug& p)
{
    evaluate(std::span<const Plug>(&p, 1));
    return readStored(p);
}

void Graph::setTime(double frame)
{
    time_ = frame;
    for (NodeId n = 0; n < nodeCount(); ++n) {
        const auto& specs = *record(n).specs;
        for (std::size_t a = 0; a < specs.size(); ++a) {
            const Plug p{n, static_cast<AttrId>(a), -1, -1};
            if (specs[a].sceneTime && incomingConnection(p) == nullptr) setValue(p, frame);
        }
    }
}

void Graph::setThreads(int threads)
{
    if (threads < 0) throw Error(fmt::format("thread count {} is negative; use 0 for all cores", threads));
    threads_ = threads == 0 ? tbb::info::default_concurrency() : threads;
}

std::uint64_t Graph::computeCount() const
{
    std::uint64_t total = 0;
    for (const auto& rec : nodes_) total += rec->computes;
    return total;
}

std::uint64_t Graph::computeCount(NodeId node) const { return record(node).computes; }

// --- evaluation (pull) --------------------------------------------------------------------------------

void Graph::topologyChanged() { schedule_.reset(); }

Schedule& Graph::schedule()
{
    if (!schedule_) {
        std::vector<std::pair<int, int>> edges;
        for (const Connection& c : connections_) edges.emplace_back(c.source.node, c.destination.node);
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
        schedule_ = std::make_unique<Schedule>(nodeCount(), edges);
    }
    return *schedule_;
}

void Graph::evaluate(std::span<const Plug> plugs)
{
    std::vector<NodeId> roots;
    for (const Plug& p : plugs) {
        checkPlug(p);
        if (data(p).dirty) roots.push_back(p.node);
    }
    // Reading clean plugs must not cost a pass over the whole graph: a rig reads every joint per evaluation.
    if (roots.empty()) return;
    std::vector<char> needed(nodes_.size(), 0);
    std::erase_if(roots, [&](NodeId n) { return std::exchange(needed[static_cast<std::size_t>(n)], char{1}) != 0; });
    evaluateNodes(needed, std::move(roots));
}

void Graph::evaluateAll()
{
    std::vector<char> needed(nodes_.size(), 1);
    std::vector<NodeId> all(nodes_.size());
    for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<NodeId>(i);
    evaluateNodes(needed, std::move(all));
}

void Graph::evaluateNodes(std::vector<char>& needed, std::vector<NodeId> roots)
{
    if (roots.empty()) return;
    // A needed node pulls all of its dirty inputs, so the sources of those are needed too.
    std::vector<NodeId> list = roots;
    for (std::size_t i = 0; i < list.size(); ++i) {
        for (int ci : record(list[i]).incoming) {
            const Connection& c = connections_[static_cast<std::size_t>(ci)];
            const auto src = static_cast<std::size_t>(c.source.node);
            if (needed[src] || !data(c.destination).dirty || !data(c.source).dirty) continue;
            needed[src] = 1;
            list.push_back(c.source.node);
        }
    }
    Schedule& s = schedule();
    if (threads_ > 1 && list.size() > 1) {
        s.runParallel(needed, threads_, [this](int n) { processNode(n); });
        return;
    }
    std::sort(list.begin(), list.end(), [&](NodeId a, NodeId b) {
        return s.rank()[static_cast<std::size_t>(a)] < s.rank()[static_cast<std::size_t>(b)];
    });
    for (NodeId n : list) processNode(n);
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
    const double factor = unitFactor(spec(c.source).unit, spec(c.destination).unit);
    const Value source = readStored(c.source);
    if ((to == ValueType::Int || to == ValueType::Enum) && from != ValueType::Int && from != ValueType::Enum) {
        // A number computed upstream (NaN from a degenerate node, say) must not become an arbitrary int,
        // nor an enum index the node has no entry for.
        const double x = std::round(toDouble(source) * factor);
        const AttributeSpec& s = spec(c.destination);
        if (to == ValueType::Enum && !(x >= 0 && x < static_cast<double>(s.enumNames.size())))
            throw Error(fmt::format("{} receives {} from {}, not one of its enum indices 0..{}; clamp or remap the "
                                    "source",
                                    plugName(c.destination), numberText(toDouble(source) * factor), plugName(c.source),
                                    s.enumNames.size() - 1));
        if (!(std::abs(x) <= 2147483647.0))
            throw Error(fmt::format("{} receives {} from {}, which is not a whole number an int attribute holds; "
                                    "clamp the source",
                                    plugName(c.destination), numberText(toDouble(source) * factor), plugName(c.source)));
    }
    if (to == ValueType::Enum && (from == ValueType::Int || from == ValueType::Enum)) {
        const int v = std::get<int>(source);
        if (v < 0 || static_cast<std::size_t>(v) >= spec(c.destination).enumNames.size())
            throw Error(fmt::format("{} receives {} from {}, not one of its enum indices 0..{}; clamp or remap the "
                                    "source",
                                    plugName(c.destination), v, plugName(c.source),
                                    spec(c.destination).enumNames.size() - 1));
    }
    return convertValue(source, from, to, factor);
}

void Graph::processNode(NodeId node)
{
    NodeRecord& rec = record(node);
    for (int ci : rec.incoming) {
        const Connection& c = connections_[static_cast<std::size_t>(ci)];
        if (!rec.data[static_cast<std::size_t>(c.destination.attr)].dirty) continue;
        writeStored(c.destination, pulledValue(c));
    }
    for (int ci : rec.incoming)
        rec.data[static_cast<std::size_t>(connections_[static_cast<std::size_t>(ci)].destination.attr)].dirty = false;

    bool outputsDirty = false;
    for (std::size_t a = 0; a < rec.data.size(); ++a)
        outputsDirty |= !rec.spec(static_cast<AttrId>(a)).input && rec.data[a].dirty;
    if (!outputsDirty) return;
    ComputeContext context(rec.name, *rec.specs, rec.data);
    rec.impl->compute(context);
    ++rec.computes;
    for (std::size_t a = 0; a < rec.data.size(); ++a)
        if (!rec.spec(static_cast<AttrId>(a)).input) rec.data[a].dirty = false;
}

std::vector<std::string> Graph::checkEvaluation()
{
    evaluateAll();
    std::vector<std::vector<AttrData>> cached;
    for (const auto& rec : nodes_) cached.push_back(rec->data);
    dirtyAll();
    evaluateAll();

    // Stateful nodes legitimately change when recomputed; so does everything they feed.
    std::vector<char> tainted(nodes_.size(), 0);
    for (NodeId n : schedule().order()) {
        auto& t = tainted[static_cast<std::size_t>(n)];
        t = record(n).type->stateful();
        for (int ci : record(n).incoming)
            t |= tainted[static_cast<std::size_t>(connections_[static_cast<std::size_t>(ci)].source.node)];
    }
    std::vector<std::string> mismatches;
    for (std::size_t n = 0; n < nodes_.size(); ++n) {
        if (tainted[n]) continue;
        const NodeRecord& rec = *nodes_[n];
        for (std::size_t a = 0; a < rec.data.size(); ++a) {
            const AttrData& before = cached[n][a];
            const AttrData& after = rec.data[a];
            bool same = bitEqual(before.value, after.value) && before.present == after.present;
            for (std::size_t i = 0; same && i < after.elements.size(); ++i)
                same = bitEqual(before.elements[i], after.elements[i]);
            if (!same) mismatches.push_back(fmt::format("{}.{}", rec.name, rec.spec(static_cast<AttrId>(a)).name));
        }
    }
    return mismatches;
}

}  // namespace rig

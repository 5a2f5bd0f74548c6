#include "graph/graph_model.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <deque>
#include <span>
#include <unordered_map>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/error.h"
#include "graph/suggest.h"

namespace rig {

namespace {

// After "has no attribute 'x'": the attribute it is a typo of, or, when none is close (a name from another tool, as
// a rigInversion's 'converged'), what the node's type computes, so that the line alone says what to ask for.
std::string noAttributeHint(std::span<const AttributeSpec> specs, std::string_view name,
                            const std::vector<std::string>& names)
{
    if (std::string hint = didYouMean(name, names); !hint.empty()) return hint;
    std::vector<std::string> outputs;
    for (const AttributeSpec& spec : specs)
        if (!spec.input) outputs.push_back(spec.name);
    if (outputs.empty()) return {};
    return fmt::format("; its outputs are {} (graph-eval --types lists its inputs)", fmt::join(outputs, ", "));
}

bool validNodeName(std::string_view name)
{
    if (name.empty() || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
    return std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == ':' || c == '|';
    });
}

std::string typeDescription(const AttributeSpec& spec, int child)
{
    return std::string(valueTypeName(child >= 0 ? ValueType::Double : spec.type));
}

}  // namespace

GraphModel::GraphModel(std::shared_ptr<NodeRegistry> registry) : registry_(std::move(registry)) {}

GraphModel::GraphModel(const GraphModel& other)
    : registry_(other.registry_), nodeIndex_(other.nodeIndex_), connections_(other.connections_)
{
    nodes_.reserve(other.nodes_.size());
    for (const NodeTopology& rec : other.nodes_)
        nodes_.push_back({rec.type,
                          rec.ownSpecs,
                          {rec.incoming.begin(), rec.incoming.end(), lists_.get()},
                          rec.name,
                          {rec.outgoing.begin(), rec.outgoing.end(), lists_.get()}});
}

void GraphModel::compactLists()
{
    auto lists = std::make_unique<std::pmr::monotonic_buffer_resource>();
    std::vector<NodeTopology> compact;
    compact.reserve(nodes_.size());
    for (NodeTopology& rec : nodes_)
        compact.push_back({std::move(rec.type),
                           std::move(rec.ownSpecs),
                           {rec.incoming.begin(), rec.incoming.end(), lists.get()},
                           std::move(rec.name),
                           {rec.outgoing.begin(), rec.outgoing.end(), lists.get()}});
    nodes_ = std::move(compact);  // the vector's block changes hands: each list keeps the new arena
    lists_ = std::move(lists);    // the old blocks go, now that no list is in them
    connections_.shrink_to_fit();
}

NodeId GraphModel::addNode(std::string_view typeName, std::string_view name)
{
    auto type = registry_->get(typeName);
    if (name.size() > maxNameLength)
        throw Error(fmt::format("a node name of {} characters is too long (at most {})", name.size(), maxNameLength));
    if (!validNodeName(name))
        throw Error(fmt::format(
            "invalid node name '{}': use letters, digits, '_', ':' and '|', not starting with a digit", name));
    if (const NodeId existing = findNode(name); existing >= 0)
        throw Error(fmt::format("duplicate node name '{}' (already a {}); node names must be unique", name,
                                topology(existing).type->name()));
    if (nodeCount() >= maxNodes)
        throw Error(
            fmt::format("more than {} nodes; this is not a rig (check includes that multiply, e.g. a file "
                        "included twice at every level)",
                        maxNodes));
    nodeIndex_.emplace(std::string(name), static_cast<NodeId>(nodes_.size()));
    nodes_.push_back({type, nullptr, std::pmr::vector<Connection>(lists_.get()), std::string(name),
                      std::pmr::vector<NodeTopology::Edge>(lists_.get())});
    topologyChanged();
    return static_cast<NodeId>(nodes_.size() - 1);
}

AttrId GraphModel::addAttribute(NodeId node, AttributeSpec spec)
{
    NodeTopology& rec = nodes_.at(static_cast<std::size_t>(node));
    if (spec.name.size() > maxNameLength)
        throw Error(fmt::format("node '{}': an attribute name of {} characters is too long (at most {})", rec.name,
                                spec.name.size(), maxNameLength));
    if (!validNodeName(spec.name))
        throw Error(fmt::format("node '{}': invalid attribute name '{}'", rec.name, spec.name));
    for (const AttributeSpec& existing : rec.specs())
        if (existing.name == spec.name || childIndex(existing, spec.name) >= 0)
            throw Error(
                fmt::format("node '{}' ({}) already has an attribute '{}'", rec.name, rec.type->name(), spec.name));
    spec.input = true;
    spec.dynamic = true;
    spec.childNames = {spec.name + "X", spec.name + "Y", spec.name + "Z"};
    // Copied, not edited in place: other models copied from this one share the list.
    auto specs = std::make_shared<std::vector<AttributeSpec>>(rec.specs());
    specs->push_back(std::move(spec));
    rec.ownSpecs = sharedSpecs(*rec.type, std::move(specs));
    topologyChanged();  // a new plug: the time plugs are listed again
    return static_cast<AttrId>(rec.specs().size() - 1);
}

std::shared_ptr<const std::vector<AttributeSpec>> GraphModel::sharedSpecs(
    const NodeType& type, std::shared_ptr<const std::vector<AttributeSpec>> specs)
{
    // A crowd adds the same attributes to each member's copy of a node: one list serves them all (a type's list
    // with its descriptions is kilobytes, copied for each node that adds an attribute).
    const auto sameDynamic = [&](const std::vector<AttributeSpec>& other) {
        return other.size() == specs->size() &&
               std::equal(other.begin() + static_cast<std::ptrdiff_t>(type.attributes().size()), other.end(),
                          specs->begin() + static_cast<std::ptrdiff_t>(type.attributes().size()));
    };
    std::erase_if(dynamicSpecs_, [](const DynamicSpecs& d) { return d.specs.expired(); });
    for (const DynamicSpecs& d : dynamicSpecs_)
        if (d.type == &type)
            if (auto held = d.specs.lock(); held && sameDynamic(*held)) return held;
    dynamicSpecs_.push_back({&type, specs});
    return specs;
}

NodeId GraphModel::findNode(std::string_view name) const
{
    const auto it = nodeIndex_.find(std::string(name));
    return it == nodeIndex_.end() ? -1 : it->second;
}

NodeId GraphModel::node(std::string_view name) const
{
    const NodeId n = findNode(name);
    if (n >= 0) return n;
    std::vector<std::string> names;
    for (const auto& rec : nodes_) names.push_back(rec.name);
    throw Error(fmt::format("no node named '{}'{}", messageExcerpt(name), didYouMean(name, names)));
}

Plug GraphModel::plug(std::string_view path) const
{
    const auto dot = path.find('.');
    if (dot == std::string_view::npos || dot == 0)
        throw Error(
            fmt::format("'{}' is not a plug: expected node.attribute, e.g. elbow.rotateZ", messageExcerpt(path)));
    const NodeId n = node(path.substr(0, dot));
    const NodeTopology& rec = topology(n);
    std::string_view rest = path.substr(dot + 1);

    std::string_view attrName = rest.substr(0, rest.find_first_of("[."));
    rest.remove_prefix(attrName.size());
    Plug p{n, -1, -1, -1};
    if (!rest.empty() && rest.front() == '[') {
        const auto close = rest.find(']');
        const std::string_view digits = rest.substr(1, close == std::string_view::npos ? 0 : close - 1);
        int index = -1;
        const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), index);
        if (close != std::string_view::npos && ec == std::errc::result_out_of_range &&
            end == digits.data() + digits.size() && digits.front() != '-')
            throw Error(fmt::format("'{}': array index {} is above the limit {}", messageExcerpt(path),
                                    messageExcerpt(digits), maxArrayIndex));
        if (close == std::string_view::npos || digits.empty() || ec != std::errc() ||
            end != digits.data() + digits.size() || index < 0)
            throw Error(
                fmt::format("'{}': bad array index; expected attribute[N] with N = 0, 1, ...", messageExcerpt(path)));
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

    for (std::size_t a = 0; a < rec.specs().size(); ++a) {
        const AttributeSpec& spec = rec.specs()[a];
        if (spec.name == attrName) p.attr = static_cast<AttrId>(a);
        else if (p.index < 0 && childName.empty() && !spec.array && childIndex(spec, attrName) >= 0) {
            p.attr = static_cast<AttrId>(a);
            p.child = childIndex(spec, attrName);
        }
        if (p.attr >= 0) break;
    }
    if (p.attr < 0) {
        std::vector<std::string> names;
        for (const AttributeSpec& spec : rec.specs()) {
            names.push_back(spec.name);
            if (spec.type == ValueType::Vector3)
                names.insert(names.end(), spec.childNames.begin(), spec.childNames.end());
        }
        throw Error(fmt::format("node '{}' ({}) has no attribute '{}'{}", rec.name, rec.type->name(), attrName,
                                noAttributeHint(rec.specs(), attrName, names)));
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

std::string GraphModel::plugName(const Plug& p) const
{
    const NodeTopology& rec = topology(p.node);
    const AttributeSpec& spec = rec.spec(p.attr);
    const std::string child = p.child >= 0 ? spec.childNames[static_cast<std::size_t>(p.child)] : std::string();
    if (p.index >= 0)
        return child.empty() ? fmt::format("{}.{}[{}]", rec.name, spec.name, p.index)
                             : fmt::format("{}.{}[{}].{}", rec.name, spec.name, p.index, child);
    return fmt::format("{}.{}", rec.name, child.empty() ? spec.name : child);
}

void GraphModel::checkPlug(const Plug& p) const
{
    if (p.node < 0 || p.node >= nodeCount() || p.attr < 0 ||
        static_cast<std::size_t>(p.attr) >= topology(p.node).specs().size())
        throw internalError("GraphModel: plug does not exist");
    const AttributeSpec& s = spec(p);
    if (s.array && p.index < 0)
        throw Error(fmt::format("{} is an array attribute: name an element, e.g. {}[0]", plugName(p), plugName(p)));
    if (p.child >= 0 && s.type != ValueType::Vector3)
        throw internalError("GraphModel: component of a non-vector3 plug");
}

// --- connections ------------------------------------------------------------------------------------

const Connection* GraphModel::incomingConnection(const Plug& dst) const
{
    for (const Connection& c : topology(dst.node).incoming) {
        const Plug& d = c.destination;
        if (d.attr == dst.attr && d.index == dst.index && (d.child < 0 || dst.child < 0 || d.child == dst.child))
            return &c;
    }
    return nullptr;
}

std::vector<int> GraphModel::cyclePath(NodeId from, NodeId to) const
{
    // Breadth-first over connections from `from`; returns the connection indices of a path to `to`.
    // Only the nodes reached are stored (not a table of every node): connecting stays cheap in big graphs.
    std::unordered_map<NodeId, int> via{{from, -1}};
    std::deque<NodeId> queue{from};
    while (!queue.empty()) {
        const NodeId n = queue.front();
        queue.pop_front();
        if (n == to) break;
        for (const NodeTopology::Edge& e : topology(n).outgoing)
            if (via.emplace(e.node, e.connection).second) queue.push_back(e.node);
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

void GraphModel::connect(const Plug& src, const Plug& dst, bool convertUnits)
{
    checkPlug(src);
    checkPlug(dst);
    const std::string srcName = plugName(src);
    const std::string dstName = plugName(dst);
    const AttributeSpec& dstSpec = spec(dst);
    if (!dstSpec.input)
        throw Error(
            fmt::format("cannot connect {} -> {}: {} is an output, written by its node's compute; "
                        "connect into an input",
                        srcName, dstName, dstName));
    if (!canConvert(plugType(src), plugType(dst)))
        throw Error(fmt::format("cannot connect {} ({}) -> {} ({}): the types do not match", srcName,
                                typeDescription(spec(src), src.child), dstName, typeDescription(dstSpec, dst.child)));
    if (const Connection* existing = incomingConnection(dst))
        throw Error(
            fmt::format("cannot connect {} -> {}: {} is already driven by {}; an input takes one source, "
                        "disconnect it first",
                        srcName, dstName, plugName(existing->destination), plugName(existing->source)));
    std::vector<int> path = src.node == dst.node ? std::vector<int>{} : cyclePath(dst.node, src.node);
    if (src.node == dst.node || !path.empty()) {
        std::string cycle;
        for (int ci : path) {
            const Connection& c = connections_[static_cast<std::size_t>(ci)];
            cycle += fmt::format("{} -> {}, ", plugName(c.source), plugName(c.destination));
        }
        throw Error(
            fmt::format("cannot connect {} -> {}: it would close a cycle ({}{} -> {}); the graph must stay "
                        "acyclic at node level, so feed {} from nodes that do not depend on {}",
                        srcName, dstName, cycle, srcName, dstName, topology(dst.node).name, topology(dst.node).name));
    }
    connections_.push_back({src, dst, !convertUnits});
    const int ci = static_cast<int>(connections_.size() - 1);
    std::pmr::vector<NodeTopology::Edge>& out = nodes_[static_cast<std::size_t>(src.node)].outgoing;
    const auto after = std::upper_bound(out.begin(), out.end(), src.attr,
                                        [](AttrId a, const NodeTopology::Edge& e) { return a < e.from; });
    out.insert(after, {src.attr, dst.node, dst.attr, ci});
    nodes_[static_cast<std::size_t>(dst.node)].incoming.push_back(connections_.back());
    topologyChanged();
}

void GraphModel::disconnect(const Plug src, const Plug dst)
{
    // By value: the caller's plugs may be the connection's own, in the lists rebuilt here.
    const auto it = std::find_if(connections_.begin(), connections_.end(),
                                 [&](const Connection& c) { return c.source == src && c.destination == dst; });
    if (it == connections_.end())
        throw Error(fmt::format("cannot disconnect {} -> {}: they are not connected", plugName(src), plugName(dst)));
    connections_.erase(it);
    for (auto& rec : nodes_) {
        rec.incoming.clear();
        rec.outgoing.clear();
    }
    for (std::size_t ci = 0; ci < connections_.size(); ++ci) {
        const Connection& c = connections_[ci];
        nodes_[static_cast<std::size_t>(c.source.node)].outgoing.push_back(
            {c.source.attr, c.destination.node, c.destination.attr, static_cast<int>(ci)});
        nodes_[static_cast<std::size_t>(c.destination.node)].incoming.push_back(c);
    }
    for (auto& rec : nodes_)
        std::stable_sort(rec.outgoing.begin(), rec.outgoing.end(),
                         [](const NodeTopology::Edge& a, const NodeTopology::Edge& b) { return a.from < b.from; });
    topologyChanged();
}

ValueType GraphModel::plugType(const Plug& p) const { return p.child >= 0 ? ValueType::Double : spec(p).type; }

void GraphModel::topologyChanged()
{
    const std::lock_guard lock(scheduleMutex_);
    schedule_.reset();
    timePlugs_.reset();
}

std::shared_ptr<const Schedule> GraphModel::schedule() const
{
    const std::lock_guard lock(scheduleMutex_);
    if (!schedule_) {
        std::vector<std::pair<int, int>> edges;
        for (const Connection& c : connections_) edges.emplace_back(c.source.node, c.destination.node);
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
        schedule_ = std::make_shared<const Schedule>(nodeCount(), edges);
    }
    return schedule_;
}

std::shared_ptr<const std::vector<Plug>> GraphModel::timePlugs() const
{
    const std::lock_guard lock(scheduleMutex_);
    if (!timePlugs_) {
        auto plugs = std::make_shared<std::vector<Plug>>();
        for (NodeId n = 0; n < nodeCount(); ++n) {
            const auto& specs = topology(n).specs();
            for (std::size_t a = 0; a < specs.size(); ++a) {
                const Plug p{n, static_cast<AttrId>(a), -1, -1};
                if (specs[a].sceneTime && incomingConnection(p) == nullptr) plugs->push_back(p);
            }
        }
        timePlugs_ = std::move(plugs);
    }
    return timePlugs_;
}

}  // namespace rig

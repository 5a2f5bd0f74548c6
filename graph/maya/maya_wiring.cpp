#include <algorithm>
#include <cmath>
#include <deque>
#include <iterator>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/maya/maya_builder.h"

namespace rig::maya_build {

std::optional<Plug> Builder::dagSource(int n, const AttrPath& p, bool& identity) const
{
    const bool pm = p.name == "pm" || p.name == "parentMatrix";
    const bool pim = p.name == "pim" || p.name == "parentInverseMatrix";
    if (!(pm || pim) || !p.child.empty() || p.first > 0) return std::nullopt;
    const int parent = node(n).parent;
    identity = parent < 0;
    const NodeId g = graphNode(parent);
    if (g < 0) return std::nullopt;
    const AttrId a = findAttribute(g, pm ? "worldMatrix" : "worldInverseMatrix");
    if (a < 0) return std::nullopt;
    return Plug{g, a, -1, -1};
}

void Builder::markUnevaluated(NodeId driven, int source, const std::string& why, const Where& where)
{
    if (driven >= 0 && !unevaluated_.count(driven)) unevaluated_[driven] = {source, why, where};
}

void Builder::dropDisconnected()
{
    for (const maya::Connection& d : scene_.disconnections)
        std::erase_if(scene_.connections, [&](const maya::Connection& c) {
            return samePlug(c.source, d.source) && samePlug(c.destination, d.destination);
        });
}

bool Builder::samePlug(const std::string& a, const std::string& b) const
{
    if (a == b) return true;
    const auto [nodeA, attrA] = maya::splitPlug(a);
    const auto [nodeB, attrB] = maya::splitPlug(b);
    if (nodeA != nodeB) return false;  // both are paths from the world, as the reader writes them
    int n = -1;
    try {
        n = scene_.find(nodeA);
    }
    catch (const Error&) {
        return false;
    }
    const NodeId g = graphNode(n);
    if (g < 0) return false;
    const auto plugA = resolve(g, splitAttr(attrA));
    const auto plugB = resolve(g, splitAttr(attrB));
    return plugA && plugB && *plugA == *plugB;
}

void Builder::connectAll()
{
    dropDisconnected();
    std::vector<const maya::Connection*> selfConnections;
    collectCharacterInputs();
    std::vector<const maya::Connection*> fromOutputs, fromInputs;
    for (const maya::Connection& c : scene_.connections) (sourceIsInput(c) ? fromInputs : fromOutputs).push_back(&c);
    for (const auto* list : {&fromOutputs, &fromInputs})
        for (const maya::Connection* c : *list) connectStatement(*c, selfConnections);
    for (const maya::Connection* c : selfConnections) connectSelf(*c);
}

bool Builder::sourceIsInput(const maya::Connection& c) const
{
    const auto [name, attr] = maya::splitPlug(c.source);
    int n = -1;
    try {
        n = scene_.find(name);
    }
    catch (const Error&) {
        return false;  // reported in its turn
    }
    const NodeId g = graphNode(n);
    if (g < 0) return false;
    const auto plug = resolve(g, splitAttr(attr));
    return plug && graph_->spec(*plug).input;
}

void Builder::connectStatement(const maya::Connection& c, std::vector<const maya::Connection*>& selfConnections)
{
    if (isMessage(c.source) || isMessage(c.destination)) return;
    if (intoCharacter(c)) return;
    const auto [srcName, srcAttr] = maya::splitPlug(c.source);
    const auto [dstName, dstAttr] = maya::splitPlug(c.destination);
    int src = -1, dst = -1;
    try {
        src = scene_.find(srcName);
        dst = scene_.find(dstName);
    }
    catch (const Error& e) {
        fail(c.where, e.what());
    }
    if (dst < 0 || src < 0) {
        const std::string& missing = src < 0 ? srcName : dstName;
        // Maya's default nodes (:defaultColorMgtGlobals) exist in every scene without a createNode.
        if (missing.starts_with(':')) return;
        if (referenceMissing(missing)) {
            // Lost with its reference: an error only where what it drives reaches a joint.
            if (src < 0 && dst >= 0 && graphNode(dst) >= 0)
                markUnevaluated(graphNode(dst), -1,
                                fmt::format("it is in a reference that was not found ({})", srcName), c.where);
            return;
        }
        fail(c.where, fmt::format("connectAttr names '{}', which is no node of the scene",
                                  messageExcerpt(src < 0 ? srcName : dstName)));
    }
    if (src == dst) {
        selfConnections.push_back(&c);
        return;
    }
    connectOne(c, src, dst, srcAttr, dstAttr);
}

bool Builder::referenceMissing(std::string_view nodeName) const
{
    for (const std::string& ns : missingNamespaces_)
        if (nodeName.find(ns + ":") != std::string_view::npos) return true;
    return false;
}

std::optional<Plug> Builder::characterPlug(int n, const std::string& attr) const
{
    const NodeId g = graphNode(n);
    if (g < 0 || node(n).type != "character") return std::nullopt;
    return resolve(g, splitAttr(attr));
}

bool Builder::atMayaDefault(int n, NodeId g, const AttrPath& p) const
{
    static const std::set<std::string_view> pivots{"rp", "rotatePivot", "rpt", "rotatePivotTranslate",
                                                   "sp", "scalePivot",  "spt", "scalePivotTranslate",
                                                   "sh", "shear"};
    if (graph_->nodeType(g).name() != "joint" || !pivots.count(p.name) || !p.child.empty()) return false;
    for (const maya::SetAttr& set : node(n).sets)
        if (splitAttr(set.plug).name == p.name) return false;
    return true;
}

bool Builder::intoCharacter(const maya::Connection& c) const
{
    const auto [name, attr] = maya::splitPlug(c.destination);
    const int n = scene_.find(name);
    return n >= 0 && node(n).type == "character";
}

void Builder::collectCharacterInputs()
{
    for (const maya::Connection& c : scene_.connections) {
        const auto [name, attr] = maya::splitPlug(c.destination);
        const int n = scene_.find(name);
        if (n < 0) continue;
        if (const auto plug = characterPlug(n, attr)) characterInputs_[*plug] = &c;
    }
}

void Builder::connectOne(const maya::Connection& c, int src, int dst, std::string srcAttr, const std::string& dstAttr)
{
    const NodeId gd = graphNode(dst);
    if (gd < 0) return;  // into a node kept out of the graph
    const AttrPath dp = splitAttr(dstAttr);
    auto dplug = resolve(gd, dp);
    if (!dplug && dp.first < 0 && c.nextAvailable) dplug = nextAvailable(gd, dp);
    if (!dplug) return countNotEvaluated(dst, dstAttr);
    for (int hops = 0; node(src).type == "character"; ++hops) {
        const auto element = characterPlug(src, srcAttr);
        if (!element) return countNotEvaluated(src, srcAttr);
        const auto in = characterInputs_.find(*element);
        if (in == characterInputs_.end() || hops > 64) {
            try {
                setConverted(*dplug, *element);
            }
            catch (const Error& e) {
                fail(c.where, e.what());
            }
            return;
        }
        const auto [name, attr] = maya::splitPlug(in->second->source);
        src = scene_.find(name);
        srcAttr = attr;
        if (src < 0) return;
    }
    const NodeId gs = graphNode(src);
    if (gs < 0)
        return markUnevaluated(gd, src, fmt::format("this reader does not evaluate {}", node(src).type), c.where);
    const AttrPath sp = splitAttr(srcAttr);
    bool identity = false;
    auto splug = dagSource(src, sp, identity);
    if (!splug && identity) return;  // a root's parent matrix: the identity, the destination's default
    if (!splug &&
        (sp.name == "pm" || sp.name == "pim" || sp.name == "parentMatrix" || sp.name == "parentInverseMatrix"))
        return markUnevaluated(gd, node(src).parent, "its DAG parent is not evaluated", c.where);
    if (!splug) splug = resolve(gs, sp);
    if (!splug && atMayaDefault(src, gs, sp)) return;  // a joint's rotate pivot: zero, the destination's default
    if (!splug)
        return markUnevaluated(
            gd, src, fmt::format("{}.{} is not an attribute this reader evaluates", name(gs), srcAttr), c.where);
    bool connected = false;
    try {
        if (const Connection* existing = graph_->incomingConnection(*dplug))
            graph_->disconnect(existing->source, existing->destination);  // connectAttr -f replaces
        connected = connectOrFeed(*splug, *dplug);
    }
    catch (const Error& e) {
        fail(c.where, e.what());
    }
    if (!connected) fail(c.where, cycleError_);
}

bool Builder::connectOrFeed(const Plug& source, const Plug& destination)
{
    try {
        graph_->connect(source, destination, false);
        return true;
    }
    catch (const Error& e) {
        cycleError_ = e.what();
        if (!graph_->spec(source).input || std::string_view(e.what()).find("cycle") == std::string_view::npos)
            return false;
    }
    feed(destination, source);
    return true;
}

std::optional<Plug> Builder::nextAvailable(NodeId g, const AttrPath& p)
{
    const AttrId a = findAttribute(g, p.name);
    if (a < 0 || !graph_->attributes(g)[static_cast<std::size_t>(a)].array) return std::nullopt;
    int& next = nextIndex_[{g, a}];
    while (graph_->incomingConnection(Plug{g, a, next, -1})) ++next;
    return Plug{g, a, next++, -1};
}

void Builder::connectSelf(const maya::Connection& c)
{
    const auto [nodeName, srcAttr] = maya::splitPlug(c.source);
    const int n = scene_.find(nodeName);
    const NodeId g = graphNode(n);
    if (g < 0) return;
    const auto src = resolve(g, splitAttr(srcAttr));
    const auto dst = resolve(g, splitAttr(maya::splitPlug(c.destination).second));
    if (!src || !dst) return countNotEvaluated(n, src ? maya::splitPlug(c.destination).second : srcAttr);
    try {
        if (const Connection* in = graph_->incomingConnection(*src)) {
            const Plug from = in->source;
            graph_->disconnect(from, *src);
            graph_->connect(from, *dst, false);
        } else if (graph_->spec(*src).input && !graph_->incomingConnection(*dst)) {
            graph_->setValue(*dst, graph_->getValue(*src));
        }
    }
    catch (const Error& e) {
        fail(c.where, e.what());
    }
    aliases_[{g, splitAttr(srcAttr).name}] = *dst;
}

void Builder::wireDag()
{
    for (std::size_t i = 0; i < scene_.nodes.size(); ++i) {
        const NodeId g = graphNode_[i];
        const int parent = scene_.nodes[i].parent;
        if (g < 0 || parent < 0) continue;
        const AttrId pm = findAttribute(g, "parentMatrix");
        if (pm < 0 || graph_->incomingConnection(Plug{g, pm, -1, -1})) continue;
        const NodeId gp = graphNode(parent);
        if (gp < 0) {
            markUnevaluated(g, parent, fmt::format("this reader does not evaluate {}", node(parent).type),
                            scene_.nodes[i].where);
            continue;
        }
        const AttrId wm = findAttribute(gp, "worldMatrix");
        if (wm < 0) continue;
        try {
            graph_->connect(Plug{gp, wm, -1, -1}, Plug{g, pm, -1, -1}, false);
        }
        catch (const Error& e) {
            fail(scene_.nodes[i].where, e.what());
        }
    }
}

// destination takes what drives `source` (its connection's source, per component) or, undriven, its value.
void Builder::feed(const Plug& destination, const Plug& source)
{
    if (const Connection* in = graph_->incomingConnection(source); in && in->destination == source) {
        if (!connectOrValue(in->source, destination)) setConverted(destination, source);
        return;
    }
    const AttributeSpec& spec = graph_->spec(source);
    if (spec.type == ValueType::Vector3 && source.child < 0) {
        Eigen::Vector3d v = std::get<Eigen::Vector3d>(graph_->getValue(source));
        std::vector<std::pair<Plug, int>> driven;
        for (int c = 0; c < 3; ++c) {
            const Plug child{source.node, source.attr, source.index, c};
            if (const Connection* in = graph_->incomingConnection(child)) driven.emplace_back(in->source, c);
        }
        graph_->setValue(destination, Value(v));
        for (const auto& [from, c] : driven) {
            const Plug to{destination.node, destination.attr, destination.index, c};
            if (!connectOrValue(from, to)) setConverted(to, Plug{source.node, source.attr, source.index, c});
        }
        return;
    }
    setConverted(destination, source);
}

// Connects from -> to; false, with nothing changed, when that would close a node-level cycle (a chain joint's scale
// driven by a constraint that follows the chain: the IK then takes the scale's value at load).
bool Builder::connectOrValue(const Plug& from, const Plug& to)
{
    try {
        graph_->connect(from, to, false);
        return true;
    }
    catch (const Error& e) {
        if (std::string_view(e.what()).find("cycle") == std::string_view::npos) throw;
        return false;
    }
}

// destination = source's value, converted between numeric types (an enum into a weight).
void Builder::setConverted(const Plug& destination, const Plug& source)
{
    Value value = graph_->getValue(source);
    const ValueType from = graph_->plugType(source), to = graph_->plugType(destination);
    if (from != to) {
        if (!canConvert(from, to))
            throw Error(
                fmt::format("{} cannot take the value of {}", graph_->plugName(destination), graph_->plugName(source)));
        value = convertValue(value, from, to, 1.0);
    }
    graph_->setValue(destination, value);
}

// Connections out of a chain joint's inputs (its translate into a pole vector constraint) would close a node-level
// cycle once the IK writes the joint's rotate: they take what drives those inputs, or their values.
std::vector<Connection> Builder::detachInputs(NodeId joint)
{
    const auto& top = graph_->model().topology(joint);
    std::vector<Connection> out;
    for (const GraphModel::NodeTopology::Edge& e : top.outgoing)
        if (top.spec(e.from).input) out.push_back(graph_->connections()[static_cast<std::size_t>(e.connection)]);
    for (const Connection& c : out) {
        graph_->disconnect(c.source, c.destination);
        feed(c.destination, c.source);
    }
    return out;
}

// A connection detached from a chain joint's rotate (an orient constraint of a bound skeleton on the chain) reads
// the solver's answer, as in Maya, where the joint's rotate is now the handle's outRotate; where that would close a
// node-level cycle it keeps the value detachInputs fed it.
void Builder::readSolvedRotate(const Connection& detached)
{
    const Plug& source = detached.source;
    const Connection* in = graph_->incomingConnection(Plug{source.node, source.attr, -1, -1});
    if (!in || in->destination.child >= 0 || graph_->nodeType(in->source.node).name() != "mayaIkHandle") return;
    const Plug from{in->source.node, in->source.attr, in->source.index, source.child};
    if (graph_->plugType(from) != graph_->plugType(detached.destination)) return;
    connectOrValue(from, detached.destination);
}

void Builder::wireIk()
{
    for (const auto& [handle, links] : ik_) {
        const NodeId h = graphNode(handle);
        const std::string solverType = links.solver >= 0 ? node(links.solver).type : "ikRPsolver";
        if (links.startJoint < 0 || links.effector < 0) continue;
        std::vector<int> chain;
        for (int j = node(links.effector).parent; j >= 0; j = node(j).parent) {
            chain.insert(chain.begin(), j);
            if (j == links.startJoint) break;
        }
        if (chain.empty() || chain.front() != links.startJoint)
            fail(links.where, fmt::format("IK handle '{}': its start joint '{}' is not above its effector '{}'",
                                          node(handle).name, node(links.startJoint).name, node(links.effector).name));
        if (solverType == "ikSplineSolver" || h < 0) {
            const std::string why =
                fmt::format("this reader does not evaluate {}", h < 0 ? node(handle).type : solverType);
            for (int j : chain) markUnevaluated(graphNode(j), h < 0 ? handle : links.solver, why, links.where);
            continue;
        }
        for (int j : chain) {
            for (const maya::SetAttr& set : node(j).sets)
                if ((set.plug == "r" || set.plug == "rotate") && set.values.size() == 3) {
                    maya::ValueReader r(set.values, maya::Units{});
                    info_.savedIkRotate[name(graphNode(j))] =
                        std::get<Eigen::Vector3d>(r.read(ValueType::Vector3, Unit::None));
                }
        }
        try {
            const AttrId type = findAttribute(h, "solverType");
            if (type >= 0) graph_->setValue(Plug{h, type, -1, -1}, solverType == "ikSCsolver" ? 1 : 0);
            wireChain(handle, chain, links.effector);
        }
        catch (const Error& e) {
            fail(links.where, fmt::format("IK handle '{}': {}", name(h), e.what()));
        }
    }
}

// A joint's preferred angle (".pa", which joints here do not store), in radians.
std::optional<Eigen::Vector3d> Builder::preferredAngle(int joint) const
{
    std::optional<Eigen::Vector3d> angle;
    for (const maya::SetAttr& set : node(joint).sets)
        if ((set.plug == "pa" || set.plug == "preferredAngle") && set.values.size() == 3) {
            maya::ValueReader r(set.values, scene_.units[static_cast<std::size_t>(set.where.file)]);
            angle = std::get<Eigen::Vector3d>(r.read(ValueType::Vector3, Unit::Angle));
        }
    return angle;
}

void Builder::wireChain(int handle, const std::vector<int>& chain, int effector)
{
    const NodeId h = graphNode(handle);
    auto attr = [&](NodeId g, std::string_view n) {
        const AttrId a = findAttribute(g, n);
        if (a < 0) throw Error(fmt::format("'{}' has no attribute {}", name(g), n));
        return a;
    };
    const NodeId start = graphNode(chain.front());
    if (start < 0) throw Error(fmt::format("its start joint '{}' is not evaluated", node(chain.front()).name));
    if (const Connection* pm = graph_->incomingConnection(Plug{start, attr(start, "parentMatrix"), -1, -1}))
        graph_->connect(pm->source, Plug{h, attr(h, "startParentMatrix"), -1, -1}, false);
    feed(Plug{h, attr(h, "startInverseScale"), -1, -1}, Plug{start, attr(start, "inverseScale"), -1, -1});
    std::vector<Connection> detached;
    for (int joint : chain)
        if (graphNode(joint) >= 0) std::ranges::move(detachInputs(graphNode(joint)), std::back_inserter(detached));
    for (std::size_t i = 0; i < chain.size(); ++i) {
        const NodeId j = graphNode(chain[i]);
        if (j < 0) throw Error(fmt::format("chain joint '{}' is not evaluated", node(chain[i]).name));
        const int e = static_cast<int>(i);
        for (const auto& [from, to] : {std::pair<const char*, const char*>{"translate", "jointTranslate"},
                                       {"jointOrient", "jointOrient"},
                                       {"rotateAxis", "jointRotateAxis"},
                                       {"scale", "jointScale"},
                                       {"rotate", "jointRotate"}})
            feed(Plug{h, attr(h, to), e, -1}, Plug{j, attr(j, from), -1, -1});
        for (const auto& [from, to] : {std::pair<const char*, const char*>{"rotateOrder", "jointRotateOrder"},
                                       {"segmentScaleCompensate", "jointSegmentScaleCompensate"}})
            if (findAttribute(j, from) >= 0)
                graph_->setValue(Plug{h, attr(h, to), e, -1}, graph_->getValue(Plug{j, attr(j, from), -1, -1}));
        if (const auto pa = preferredAngle(chain[i]))
            graph_->setValue(Plug{h, attr(h, "jointPreferredAngle"), e, -1}, Value(*pa));
        const Plug rotate{j, attr(j, "rotate"), -1, -1};
        for (int c = -1; c < 3; ++c)
            if (const Connection* in = graph_->incomingConnection(Plug{j, rotate.attr, -1, c}))
                graph_->disconnect(in->source, in->destination);
        graph_->connect(Plug{h, attr(h, "outRotate"), e, -1}, rotate, false);
    }
    for (const Connection& c : detached)
        if (c.source.attr == attr(c.source.node, "rotate")) readSolvedRotate(c);
    const NodeId eff = graphNode(effector);
    if (eff >= 0) {
        // The effector sits under the last chain joint and takes the end joint's translate: fed from the same.
        const Plug effTranslate{eff, attr(eff, "translate"), -1, -1};
        Plug source = effTranslate;
        if (const Connection* in = graph_->incomingConnection(Plug{eff, effTranslate.attr, -1, 0}))
            source = Plug{in->source.node, in->source.attr, -1, -1};
        feed(Plug{h, attr(h, "effectorTranslate"), -1, -1}, source);
    }
}

// A node this library does not evaluate must not move a joint: the joints' upstream is searched, and the first node
// on it driven by such a node is refused in one line.
void Builder::checkReachesNoJoint()
{
    if (unevaluated_.empty()) return;
    const auto& model = graph_->model();
    std::vector<NodeId> reachesJoint(static_cast<std::size_t>(graph_->nodeCount()), -1);
    std::deque<NodeId> queue;
    for (NodeId g = 0; g < graph_->nodeCount(); ++g)
        if (graph_->nodeType(g).name() == "joint") {
            reachesJoint[static_cast<std::size_t>(g)] = g;
            queue.push_back(g);
        }
    while (!queue.empty()) {
        const NodeId g = queue.front();
        queue.pop_front();
        for (const Connection& c : model.topology(g).incoming) {
            const NodeId from = c.source.node;
            if (reachesJoint[static_cast<std::size_t>(from)] >= 0) continue;
            reachesJoint[static_cast<std::size_t>(from)] = reachesJoint[static_cast<std::size_t>(g)];
            queue.push_back(from);
        }
    }
    const Unevaluated* first = nullptr;
    NodeId firstJoint = -1;
    for (const auto& [g, u] : unevaluated_) {
        const NodeId joint = reachesJoint[static_cast<std::size_t>(g)];
        if (joint < 0) continue;
        if (!first || std::tie(u.where.file, u.where.line) < std::tie(first->where.file, first->where.line)) {
            first = &u;
            firstJoint = joint;
        }
    }
    if (!first) return;
    if (first->source < 0)
        fail(first->where, fmt::format("a node drives joint '{}' but {}", name(firstJoint), first->why));
    const maya::Node& src = node(first->source);
    fail(first->where,
         fmt::format("node '{}' ({}) drives joint '{}'; {}", src.name, src.type, name(firstJoint), first->why));
}

}  // namespace rig::maya_build

#include "graph/maya/maya_loader.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <numbers>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/maya/ma_scene.h"
#include "graph/maya/maya_info.h"
#include "graph/maya/maya_references.h"
#include "graph/maya/maya_values.h"

namespace rig {
namespace {

using maya::AttrPath;
using maya::Scene;
using maya::splitAttr;
using maya::Where;

// Maya DAG types that are transforms here: their own attributes are a transform's.
bool transformLike(std::string_view type)
{
    return type == "ikEffector" || type == "dagContainer" || type == "lodGroup";
}

class Builder {
public:
    Builder(Scene& scene, std::shared_ptr<NodeRegistry> registry, MayaSceneInfo& info)
        : scene_(scene), info_(info), graph_(std::make_unique<Graph>(registry))
    {
        for (const std::string& name : registry->typeNames()) {
            auto type = registry->get(name);
            if (!type->readsMaya()) continue;
            const std::string maya = type->mayaType().empty() ? name : type->mayaType();
            if (!type->mayaType().empty() || !mayaTypes_.count(maya)) mayaTypes_[maya] = type;
        }
    }

    std::unique_ptr<Graph> build()
    {
        makeNodes();
        setValues();
        checkTypes();
        readMessages();
        wireDag();  // first: DAG parenting is what a scene is, a stray connection must not close a cycle with it
        connectAll();
        readTimeCurves();
        wireIk();
        checkReachesNoJoint();
        const auto graphName = [this](int n) { return graphNode(n) < 0 ? std::string() : name(graphNode(n)); };
        maya::readSkins(scene_, graphName, info_);
        maya::readControls(scene_, graphName, info_);
        info_.nodes = graph_->nodeCount();
        info_.connections = static_cast<int>(graph_->connections().size());
        graph_->setTime(info_.savedTime);
        return std::move(graph_);
    }

private:
    [[noreturn]] void fail(const Where& where, const std::string& what) const
    {
        throw Error(fmt::format("{}: {}", maya::formatWhere(scene_, where), what));
    }
    const maya::Node& node(int n) const { return scene_.nodes[static_cast<std::size_t>(n)]; }
    NodeId graphNode(int n) const { return n < 0 ? -1 : graphNode_[static_cast<std::size_t>(n)]; }
    const std::string& name(NodeId g) const { return graph_->nodeName(g); }

    std::shared_ptr<const NodeType> ourType(int index) const
    {
        const maya::Node& n = node(index);
        const std::string type = transformLike(n.type)                                   ? "transform"
                                 : n.type == "unitConversion" && vectorConversion(index) ? "multiplyDivide"
                                                                                         : n.type;
        const auto it = mayaTypes_.find(type);
        return it == mayaTypes_.end() ? nullptr : it->second;
    }

    // Whether a plug of a scene node is a whole vector (its type's vector3 attribute, or a double3 added to it).
    bool vectorPlug(int n, const std::string& attr) const
    {
        const AttrPath p = splitAttr(attr);
        if (!p.child.empty()) return false;
        for (const maya::AddAttr& add : node(n).adds)
            if (add.longName == p.name || add.shortName == p.name) return add.attributeType.ends_with("3");
        const auto it = mayaTypes_.find(transformLike(node(n).type) ? "transform" : node(n).type);
        if (it == mayaTypes_.end()) return false;
        const AttrId a = it->second->findMayaAttribute(p.name);
        return a >= 0 && it->second->attribute(a).type == ValueType::Vector3;
    }

    // A unitConversion between whole vectors (a rotate into a multiplyDivide): Maya's conversion takes any numeric
    // data, this engine's unitConversion one number, so it is made a multiplyDivide by (cf, cf, cf) here.
    bool vectorConversion(int uc) const
    {
        const auto it = conversionEnds_.find(uc);
        if (it == conversionEnds_.end()) return false;
        for (const auto& [n, attr] : it->second)
            if (vectorPlug(n, attr)) return true;
        return false;
    }

    // The plugs each unitConversion is connected with, found in one pass over the connections.
    void findConversionEnds()
    {
        for (const maya::Connection& c : scene_.connections) {
            const auto [srcName, srcAttr] = maya::splitPlug(c.source);
            const auto [dstName, dstAttr] = maya::splitPlug(c.destination);
            int src = -1, dst = -1;
            try {
                src = scene_.find(srcName);
                dst = scene_.find(dstName);
            }
            catch (const Error&) {
                continue;  // reported where the connection is made
            }
            if (src < 0 || dst < 0) continue;
            if (node(dst).type == "unitConversion") conversionEnds_[dst].emplace_back(src, srcAttr);
            if (node(src).type == "unitConversion") conversionEnds_[src].emplace_back(dst, dstAttr);
        }
    }

    void aliasVectorConversion(NodeId g, const maya::Node& n)
    {
        if (n.type != "unitConversion" || graph_->nodeType(g).name() != "multiplyDivide") return;
        for (const char* name : {"i", "input"}) aliases_[{g, name}] = Plug{g, findAttribute(g, "input1"), -1, -1};
        for (const char* name : {"o", "output"}) aliases_[{g, name}] = Plug{g, findAttribute(g, "output"), -1, -1};
        graph_->setValue(Plug{g, findAttribute(g, "operation"), -1, -1}, 1);  // multiply
        double factor = 1.0;
        for (const maya::SetAttr& set : n.sets)
            if ((set.plug == "cf" || set.plug == "conversionFactor") && !set.values.empty()) {
                maya::ValueReader r(set.values, maya::Units{});
                factor = std::get<double>(r.read(ValueType::Double, Unit::None));
            }
        graph_->setValue(Plug{g, findAttribute(g, "input2"), -1, -1}, Eigen::Vector3d(factor, factor, factor));
        ++info_.vectorConversions;
    }

    // The name Maya shows: the leaf name when no other node has it, else the shortest unique DAG path.
    std::string displayName(int n) const
    {
        const std::string path = scene_.path(n);
        std::size_t start = path.size();
        while (true) {
            start = path.rfind('|', start - 1);
            const std::string candidate = path.substr(start + 1);
            bool unique = true;
            try {
                unique = scene_.find(candidate) == n;
            }
            catch (const Error&) {
                unique = false;
            }
            if (unique) return candidate;
            if (start == 0) return path;
        }
    }

    void makeNodes()
    {
        findConversionEnds();
        graphNode_.assign(scene_.nodes.size(), -1);
        for (std::size_t i = 0; i < scene_.nodes.size(); ++i) {
            const maya::Node& n = scene_.nodes[i];
            const auto type = ourType(static_cast<int>(i));
            if (!type) {
                ++info_.notEvaluatedTypes[n.type];
                continue;
            }
            NodeId g = -1;
            try {
                g = graph_->addNode(type->name(), displayName(static_cast<int>(i)));
            }
            catch (const Error& e) {
                fail(n.where, e.what());
            }
            graphNode_[i] = g;
            try {
                aliasVectorConversion(g, n);
            }
            catch (const Error& e) {
                fail(n.where, e.what());
            }
            // Maya's node default, where ours differs: a constraint's rest position is off unless the scene says so.
            if (const AttrId erp = findAttribute(g, "enableRestPosition"); erp >= 0)
                graph_->setValue(Plug{g, erp, -1, -1}, false);
            // Time curves and expressions turn Maya's seconds (tangents, `time`) into the scene's frames.
            if (const AttrId fps = findAttribute(g, "framesPerSecond"); fps >= 0)
                graph_->setValue(Plug{g, fps, -1, -1},
                                 scene_.units[static_cast<std::size_t>(n.where.file)].framesPerSecond);
            addDynamicAttributes(n, g);
        }
    }

    void addDynamicAttributes(const maya::Node& n, NodeId g)
    {
        const maya::Units& units = scene_.units[static_cast<std::size_t>(n.where.file)];
        for (std::size_t a = 0; a < n.adds.size(); ++a) {
            const maya::AddAttr& add = n.adds[a];
            if (!add.parent.empty()) continue;  // a compound's child: named by its parent
            std::vector<maya::AddAttr> children;
            for (std::size_t c = a + 1; c < n.adds.size() && n.adds[c].parent == add.longName; ++c)
                children.push_back(n.adds[c]);
            auto spec = maya::dynamicAttribute(add, children, units);
            if (!spec || findAttribute(g, spec->name) >= 0 ||
                (!spec->shortName.empty() && findAttribute(g, spec->shortName) >= 0)) {
                ++info_.notEvaluatedAttributes[n.type + "." + add.longName];
                continue;
            }
            try {
                graph_->addAttribute(g, std::move(*spec));
            }
            catch (const Error& e) {
                fail(add.where, e.what());
            }
        }
    }

    // An attribute of graph node g by Maya's long or short name (not a compound's child), or -1.
    AttrId findAttribute(NodeId g, std::string_view mayaName) const
    {
        const auto& specs = graph_->attributes(g);
        for (std::size_t i = 0; i < specs.size(); ++i) {
            const AttributeSpec& s = specs[i];
            if (s.mayaCompound.empty() && (s.name == mayaName || (!s.shortName.empty() && s.shortName == mayaName)))
                return static_cast<AttrId>(i);
        }
        return -1;
    }

    // A vector3 attribute one of whose children Maya names `mayaName`: (attribute, child), or (-1, -1).
    std::pair<AttrId, int> findChild(NodeId g, std::string_view mayaName, std::string_view compound = {}) const
    {
        const auto& specs = graph_->attributes(g);
        for (std::size_t i = 0; i < specs.size(); ++i) {
            const AttributeSpec& s = specs[i];
            const bool inCompound =
                !compound.empty() && (s.mayaCompound == compound || s.mayaCompoundShort == compound);
            if (!(compound.empty() ? s.mayaCompound.empty() : inCompound)) continue;
            if (const int c = mayaChildIndex(s, mayaName); c >= 0) return {static_cast<AttrId>(i), c};
        }
        return {-1, -1};
    }

    // A compound's child attribute by Maya name, or -1.
    AttrId findCompoundChild(NodeId g, std::string_view compound, std::string_view child) const
    {
        const auto& specs = graph_->attributes(g);
        for (std::size_t i = 0; i < specs.size(); ++i) {
            const AttributeSpec& s = specs[i];
            if ((s.mayaCompound == compound || s.mayaCompoundShort == compound) &&
                (s.name == child || (!s.shortName.empty() && s.shortName == child)))
                return static_cast<AttrId>(i);
        }
        return -1;
    }

    // The plug Maya's attribute path names on graph node g; nothing when this engine does not store it.
    std::optional<Plug> resolve(NodeId g, const AttrPath& p) const
    {
        if (!p.valid) return std::nullopt;
        if (const auto alias = aliases_.find({g, p.name}); alias != aliases_.end() && p.child.empty())
            return alias->second;
        if (p.child.empty()) {
            if (const AttrId a = findAttribute(g, p.name); a >= 0) {
                const bool array = graph_->attributes(g)[static_cast<std::size_t>(a)].array;
                if (!array && p.first > 0) return std::nullopt;  // worldMatrix[1]: another instance
                return Plug{g, a, array ? p.first : -1, -1};
            }
            if (const auto [a, c] = findChild(g, p.name); a >= 0) return Plug{g, a, -1, c};
            return std::nullopt;
        }
        if (const AttrId a = findCompoundChild(g, p.name, p.child); a >= 0) return Plug{g, a, p.first, -1};
        if (const auto [a, c] = findChild(g, p.child, p.name); a >= 0) return Plug{g, a, p.first, c};
        if (const AttrId a = findAttribute(g, p.name); a >= 0) {
            const AttributeSpec& s = graph_->attributes(g)[static_cast<std::size_t>(a)];
            if (const int c = mayaChildIndex(s, p.child); c >= 0) return Plug{g, a, s.array ? p.first : -1, c};
        }
        return std::nullopt;
    }

    void countNotEvaluated(int n, const std::string& attr)
    {
        ++info_.notEvaluatedAttributes[node(n).type + "." + splitAttr(attr).name];
    }

    void setValues()
    {
        for (std::size_t i = 0; i < scene_.nodes.size(); ++i) {
            const NodeId g = graphNode_[i];
            for (const maya::SetAttr& set : scene_.nodes[i].sets) {
                const bool flagged = set.keyable || set.locked || set.channelBox;
                if (set.values.empty() && (!flagged || g < 0)) continue;
                if (g < 0) {
                    if (scene_.nodes[i].type == "time" || scene_.nodes[i].name == "time1") readTime(set);
                    continue;
                }
                try {
                    setValue(static_cast<int>(i), g, set);
                }
                catch (const Error& e) {
                    fail(set.where, fmt::format("{}.{}: {}", name(g), set.plug, e.what()));
                }
            }
        }
    }

    // Nodes whose type can tell, from their values, that they cannot be evaluated (an expression calling MEL).
    void checkTypes()
    {
        for (std::size_t i = 0; i < scene_.nodes.size(); ++i) {
            const NodeId g = graphNode_[i];
            if (g < 0 || !graph_->nodeType(g).mayaCheck()) continue;
            const auto why = graph_->nodeType(g).mayaCheck()([&](AttrId a) {
                return graph_->getValue(Plug{g, a, -1, -1});
            });
            if (why) markUnevaluated(g, static_cast<int>(i), *why, scene_.nodes[i].where);
        }
    }

    // The host scene's saved time: a referenced file's own time1 (merged with the scene's) says nothing about it.
    void readTime(const maya::SetAttr& set)
    {
        if ((set.plug != "o" && set.plug != "outTime") || set.where.file != 0) return;
        maya::ValueReader r(set.values, scene_.units[0]);
        info_.savedTime = std::get<double>(r.read(ValueType::Double, Unit::None));
    }

    void setValue(int n, NodeId g, const maya::SetAttr& set)
    {
        const maya::Units& units = scene_.units[static_cast<std::size_t>(set.where.file)];
        const AttrPath p = splitAttr(set.plug);
        if (set.values.empty()) {  // flags only: the channel's keyable, lock and channel-box state
            if (const auto plug = resolve(g, p)) recordState(*plug, set);
            return;
        }
        if (graph_->nodeType(g).name() == "time" && (p.name == "o" || p.name == "outTime")) return readTime(set);
        if (node(n).type == "unitConversion" && (p.name == "cf" || p.name == "conversionFactor")) {
            if (graph_->nodeType(g).name() == "multiplyDivide") return;  // read by aliasVectorConversion
        }
        if (const auto field = graph_->nodeType(g).mayaFields().find(p.name);
            field != graph_->nodeType(g).mayaFields().end() && p.child.empty())
            return setField(g, field->second, p, set, units);
        const auto compound =
            p.child.empty() ? graph_->nodeType(g).mayaCompoundChildren(p.name) : std::vector<AttrId>{};
        if (!compound.empty()) return setCompoundRange(g, compound, p, set, units);
        const auto plug = resolve(g, p);
        if (!plug) return countNotEvaluated(n, set.plug);
        recordState(*plug, set);
        const AttributeSpec& spec = graph_->spec(*plug);
        if (!spec.input || graph_->incomingConnection(*plug)) return;  // computed, or driven: Maya saved a result
        maya::ValueReader r(set.values, units);
        const ValueType type = graph_->plugType(*plug);
        if (spec.array && plug->index >= 0 && p.last > p.first) {
            for (int e = p.first; e <= p.last && !r.done(); ++e)
                graph_->setValue(Plug{g, plug->attr, e, plug->child}, r.read(type, spec.unit));
            return;
        }
        if (spec.array && plug->index < 0) {
            for (int e = 0; !r.done(); ++e)
                graph_->setValue(Plug{g, plug->attr, e, plug->child}, r.read(type, spec.unit));
            return;
        }
        graph_->setValue(*plug, r.read(type, spec.unit));
    }

    void recordState(const Plug& plug, const maya::SetAttr& set)
    {
        if (!set.keyable && !set.locked && !set.channelBox) return;
        MayaSceneInfo::PlugState& state = info_.plugStates[graph_->plugName(plug)];
        if (set.keyable) state.keyable = set.keyable;
        if (set.locked) state.locked = set.locked;
        if (set.channelBox) state.channelBox = set.channelBox;
    }

    // ".tg[0:1]" with each element's children in turn.
    void setCompoundRange(NodeId g, const std::vector<AttrId>& children, const AttrPath& p, const maya::SetAttr& set,
                          const maya::Units& units)
    {
        maya::ValueReader r(set.values, units);
        for (int e = std::max(p.first, 0); e <= std::max(p.last, 0) && !r.done(); ++e)
            for (AttrId a : children) {
                const AttributeSpec& spec = graph_->attributes(g)[static_cast<std::size_t>(a)];
                graph_->setValue(Plug{g, a, e, -1}, r.read(spec.type, spec.unit));
            }
    }

    void setField(NodeId g, const MayaFieldParser& parser, const AttrPath& p, const maya::SetAttr& set,
                  const maya::Units& units)
    {
        MayaFieldInput in;
        in.first = p.first;
        in.last = p.last;
        for (const maya::Word& w : set.values) in.words.push_back(w.text);
        in.current = [this, g](AttrId a) { return graph_->getValue(Plug{g, a, -1, -1}); };
        in.linearToCm = units.linearToCm;
        in.angleToDegrees = units.angleToDegrees;
        for (const auto& [a, value] : parser(in)) graph_->setValue(Plug{g, a, -1, -1}, value);
    }

    // Message connections say which joints an IK handle solves: read before anything is connected.
    void readMessages()
    {
        for (const maya::Connection& c : scene_.connections) {
            const auto [dstNode, dstAttr] = maya::splitPlug(c.destination);
            const std::string attr = splitAttr(dstAttr).name;
            if (attr != "hsj" && attr != "startJoint" && attr != "hee" && attr != "endEffector" && attr != "hsv" &&
                attr != "ikSolver")
                continue;
            const int handle = scene_.find(dstNode);
            const int source = scene_.find(maya::splitPlug(c.source).first);
            if (handle < 0 || source < 0) continue;
            IkLinks& links = ik_[handle];
            (attr == "hsj" || attr == "startJoint" ? links.startJoint
             : attr == "hsv" || attr == "ikSolver" ? links.solver
                                                   : links.effector) = source;
            links.where = c.where;
        }
    }

    bool isMessage(std::string_view attr) const
    {
        const std::string n = splitAttr(attr).name;
        return n == "msg" || n == "message" || n == "hsj" || n == "startJoint" || n == "hee" || n == "endEffector" ||
               n == "hsv" || n == "ikSolver" || n == "hp" || n == "handlePath";
    }

    // Maya's parentMatrix and parentInverseMatrix outputs are the DAG parent's world matrices here.
    std::optional<Plug> dagSource(int n, const AttrPath& p, bool& identity) const
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

    void markUnevaluated(NodeId driven, int source, const std::string& why, const Where& where)
    {
        if (driven >= 0 && !unevaluated_.count(driven)) unevaluated_[driven] = {source, why, where};
    }

    // Connections out of outputs first, then those out of inputs: Maya evaluates per attribute, this engine per node,
    // and an input-to-input connection that would close a node-level cycle can be fed instead (connectOrFeed) only
    // when it is the one that closes it.
    // Connections that a disconnectAttr or a reference edit removes: the same plugs, whichever of Maya's names spell
    // them (an edit writes "ctrl.translateX" where the file's connectAttr wrote "ctrl.tx").
    void dropDisconnected()
    {
        for (const maya::Connection& d : scene_.disconnections)
            std::erase_if(scene_.connections, [&](const maya::Connection& c) {
                return samePlug(c.source, d.source) && samePlug(c.destination, d.destination);
            });
    }

    bool samePlug(const std::string& a, const std::string& b) const
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

    // The connections out of time curves, with the graph plug each drives (MayaSceneInfo::timeCurves).
    void readTimeCurves()
    {
        const auto find = [&](const std::string& plug) {
            try {
                return scene_.find(maya::splitPlug(plug).first);
            }
            catch (const Error&) {
                return -1;
            }
        };
        for (const maya::Connection& c : scene_.connections) {
            const int curve = find(c.source);
            if (curve < 0 || !node(curve).type.starts_with("animCurveT")) continue;
            MayaSceneInfo::TimeCurve t{node(curve).name, c.source, c.destination, ""};
            std::string driven = c.destination;
            if (const int dst = find(driven); dst >= 0 && node(dst).type == "unitConversion")
                for (const maya::Connection& out : scene_.connections)
                    if (find(out.source) == dst) driven = out.destination;
            const int dst = find(driven);
            if (const NodeId g = graphNode(dst); g >= 0)
                if (const auto plug = resolve(g, splitAttr(maya::splitPlug(driven).second));
                    plug && graph_->incomingConnection(*plug))
                    t.plug = graph_->plugName(*plug);
            info_.timeCurves.push_back(std::move(t));
        }
    }

    void connectAll()
    {
        dropDisconnected();
        std::vector<const maya::Connection*> selfConnections;
        collectCharacterInputs();
        std::vector<const maya::Connection*> fromOutputs, fromInputs;
        for (const maya::Connection& c : scene_.connections)
            (sourceIsInput(c) ? fromInputs : fromOutputs).push_back(&c);
        for (const auto* list : {&fromOutputs, &fromInputs})
            for (const maya::Connection* c : *list) connectStatement(*c, selfConnections);
        for (const maya::Connection* c : selfConnections) connectSelf(*c);
    }

    bool sourceIsInput(const maya::Connection& c) const
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

    void connectStatement(const maya::Connection& c, std::vector<const maya::Connection*>& selfConnections)
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

    bool referenceMissing(std::string_view nodeName) const
    {
        for (const std::string& ns : missingNamespaces_)
            if (nodeName.find(ns + ":") != std::string_view::npos) return true;
        return false;
    }

    // A character set's element: a plug of its graph node (which stores the values the scene set), or nothing.
    std::optional<Plug> characterPlug(int n, const std::string& attr) const
    {
        const NodeId g = graphNode(n);
        if (g < 0 || node(n).type != "character") return std::nullopt;
        return resolve(g, splitAttr(attr));
    }

    // A joint's pivots and shear, which joints here do not store: Maya's zero unless the scene sets them.
    bool atMayaDefault(int n, NodeId g, const AttrPath& p) const
    {
        static const std::set<std::string_view> pivots{"rp", "rotatePivot", "rpt", "rotatePivotTranslate",
                                                       "sp", "scalePivot",  "spt", "scalePivotTranslate",
                                                       "sh", "shear"};
        if (graph_->nodeType(g).name() != "joint" || !pivots.count(p.name) || !p.child.empty()) return false;
        for (const maya::SetAttr& set : node(n).sets)
            if (splitAttr(set.plug).name == p.name) return false;
        return true;
    }

    bool intoCharacter(const maya::Connection& c) const
    {
        const auto [name, attr] = maya::splitPlug(c.destination);
        const int n = scene_.find(name);
        return n >= 0 && node(n).type == "character";
    }

    // Character sets pass their elements through, and a control may drive the set that drives another control: kept
    // as a node, a set would close node-level cycles. Connections into a set are remembered; one out of it takes
    // their source instead, or, undriven, the element's value.
    void collectCharacterInputs()
    {
        for (const maya::Connection& c : scene_.connections) {
            const auto [name, attr] = maya::splitPlug(c.destination);
            const int n = scene_.find(name);
            if (n < 0) continue;
            if (const auto plug = characterPlug(n, attr)) characterInputs_[*plug] = &c;
        }
    }

    void connectOne(const maya::Connection& c, int src, int dst, std::string srcAttr, const std::string& dstAttr)
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

    // Maya's cycles are per attribute, this engine's per node: a connection from an input (joint.scale into the
    // inverseScale of a joint that is not its child) that would close a node-level cycle takes what drives that input
    // instead, or its value. False (with the message kept) when that is not possible either.
    bool connectOrFeed(const Plug& source, const Plug& destination)
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

    std::optional<Plug> nextAvailable(NodeId g, const AttrPath& p)
    {
        const AttrId a = findAttribute(g, p.name);
        if (a < 0 || !graph_->attributes(g)[static_cast<std::size_t>(a)].array) return std::nullopt;
        int& next = nextIndex_[{g, a}];
        while (graph_->incomingConnection(Plug{g, a, next, -1})) ++next;
        return Plug{g, a, next++, -1};
    }

    // node.w0 -> node.tg[0].tw (a constraint's weight): the engine connects no node to itself, so the dynamic
    // attribute becomes another name of the plug it feeds (as Maya's alias), its value and sources moved there.
    void connectSelf(const maya::Connection& c)
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

    void wireDag()
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

    void wireIk();
    void wireChain(int handle, const std::vector<int>& chain, int effector);
    std::optional<Eigen::Vector3d> preferredAngle(int joint) const;
    void feed(const Plug& destination, const Plug& source);
    void setConverted(const Plug& destination, const Plug& source);
    bool connectOrValue(const Plug& from, const Plug& to);
    void detachInputs(NodeId joint);
    void checkReachesNoJoint();

    struct IkLinks {
        int startJoint = -1, effector = -1, solver = -1;
        Where where;
    };
    struct Unevaluated {
        int source;
        std::string why;
        Where where;
    };

    Scene& scene_;
    MayaSceneInfo& info_;
    std::unique_ptr<Graph> graph_;
    std::map<std::string, std::shared_ptr<const NodeType>> mayaTypes_;
    std::vector<NodeId> graphNode_;
    std::map<std::pair<NodeId, std::string>, Plug> aliases_;
    std::map<NodeId, Unevaluated> unevaluated_;
    std::map<int, IkLinks> ik_;
    std::map<std::pair<NodeId, AttrId>, int> nextIndex_;
    std::string cycleError_;
    std::map<Plug, const maya::Connection*> characterInputs_;
    std::map<int, std::vector<std::pair<int, std::string>>> conversionEnds_;  // unitConversion -> (node, attr)

public:
    std::vector<std::string> missingNamespaces_;
};

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
void Builder::detachInputs(NodeId joint)
{
    const auto& top = graph_->model().topology(joint);
    std::vector<Connection> out;
    for (std::size_t a = 0; a < top.outgoing.size(); ++a)
        if (top.spec(static_cast<AttrId>(a)).input)
            for (int ci : top.outgoing[a]) out.push_back(graph_->connections()[static_cast<std::size_t>(ci)]);
    for (const Connection& c : out) {
        graph_->disconnect(c.source, c.destination);
        feed(c.destination, c.source);
    }
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
    for (int joint : chain)
        if (graphNode(joint) >= 0) detachInputs(graphNode(joint));
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
        for (int ci : model.topology(g).incoming) {
            const NodeId from = model.connections()[static_cast<std::size_t>(ci)].source.node;
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

std::unique_ptr<Graph> buildGraph(Scene& scene, std::shared_ptr<NodeRegistry> registry, MayaSceneInfo& info,
                                  const maya::ReadResult& read)
{
    info.skippedStatements = scene.skipped;
    info.playbackRange = scene.playbackRange;
    const maya::Units& units = scene.units.front();
    info.framesPerSecond = units.framesPerSecond;
    info.linearUnit = units.linear;
    info.angularUnit = units.angle;
    info.timeUnit = units.time;
    info.linearToCm = units.linearToCm;
    info.angleToDegrees = units.angleToDegrees;
    for (std::size_t r = 0; r < scene.references.size(); ++r) {
        const maya::Reference& ref = scene.references[r];
        if (ref.where.file == 0) info.references.push_back({ref.path, read.referenceFiles[r], ref.nameSpace, ref.node});
    }
    Builder builder(scene, std::move(registry), info);
    builder.missingNamespaces_ = read.missingNamespaces;
    return builder.build();
}

}  // namespace

bool isMayaAscii(std::string_view text) { return text.starts_with("//Maya ASCII"); }

bool isMayaBinary(std::string_view text) { return text.starts_with("FOR4") || text.starts_with("FOR8"); }

std::unique_ptr<Graph> loadMayaFile(const std::filesystem::path& file, std::shared_ptr<NodeRegistry> registry,
                                    std::vector<std::filesystem::path>* filesRead, MayaSceneInfo* info,
                                    const MayaLoadOptions& options)
{
    MayaSceneInfo local;
    MayaSceneInfo& out = info ? *info : local;
    out = MayaSceneInfo{};
    maya::Scene scene;
    const maya::ReadResult read = maya::readSceneFile(scene, file, options.searchPath, out.warnings);
    if (filesRead) *filesRead = read.files;
    return buildGraph(scene, std::move(registry), out, read);
}

std::unique_ptr<Graph> loadMayaText(std::string_view text, const std::string& fileName,
                                    std::shared_ptr<NodeRegistry> registry, MayaSceneInfo* info,
                                    const MayaLoadOptions& options)
{
    MayaSceneInfo local;
    MayaSceneInfo& out = info ? *info : local;
    out = MayaSceneInfo{};
    maya::Scene scene;
    const maya::ReadResult read = maya::readSceneText(scene, text, fileName, options.searchPath, out.warnings);
    return buildGraph(scene, std::move(registry), out, read);
}

}  // namespace rig

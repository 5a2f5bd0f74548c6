#include "graph/maya/maya_loader.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/maya/maya_builder.h"

namespace rig {
namespace maya_build {
namespace {

// Maya DAG types that are transforms here: their own attributes are a transform's.
bool transformLike(std::string_view type)
{
    return type == "ikEffector" || type == "dagContainer" || type == "lodGroup";
}

}  // namespace

Builder::Builder(Scene& scene, std::shared_ptr<NodeRegistry> registry, MayaSceneInfo& info)
    : scene_(scene), info_(info), graph_(std::make_unique<Graph>(registry))
{
    for (const std::string& name : registry->typeNames()) {
        auto type = registry->get(name);
        if (!type->readsMaya()) continue;
        const std::string maya = type->mayaType().empty() ? name : type->mayaType();
        if (!type->mayaType().empty() || !mayaTypes_.count(maya)) mayaTypes_[maya] = type;
    }
}

std::unique_ptr<Graph> Builder::build()
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
    graph_->compact();
    return std::move(graph_);
}

[[noreturn]] void Builder::fail(const Where& where, const std::string& what) const
{
    throw Error(fmt::format("{}: {}", maya::formatWhere(scene_, where), what));
}

std::shared_ptr<const NodeType> Builder::ourType(int index) const
{
    const maya::Node& n = node(index);
    const std::string type = transformLike(n.type)                                   ? "transform"
                             : n.type == "unitConversion" && vectorConversion(index) ? "multiplyDivide"
                                                                                     : n.type;
    const auto it = mayaTypes_.find(type);
    return it == mayaTypes_.end() ? nullptr : it->second;
}

bool Builder::vectorPlug(int n, const std::string& attr) const
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

bool Builder::vectorConversion(int uc) const
{
    const auto it = conversionEnds_.find(uc);
    if (it == conversionEnds_.end()) return false;
    for (const auto& [n, attr] : it->second)
        if (vectorPlug(n, attr)) return true;
    return false;
}

void Builder::findConversionEnds()
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

void Builder::aliasVectorConversion(NodeId g, const maya::Node& n)
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

std::string Builder::displayName(int n) const
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

void Builder::makeNodes()
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

void Builder::addDynamicAttributes(const maya::Node& n, NodeId g)
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

AttrId Builder::findAttribute(NodeId g, std::string_view mayaName) const
{
    const auto& specs = graph_->attributes(g);
    for (std::size_t i = 0; i < specs.size(); ++i) {
        const AttributeSpec& s = specs[i];
        if (s.mayaCompound.empty() && (s.name == mayaName || (!s.shortName.empty() && s.shortName == mayaName)))
            return static_cast<AttrId>(i);
    }
    return -1;
}

std::pair<AttrId, int> Builder::findChild(NodeId g, std::string_view mayaName, std::string_view compound) const
{
    const auto& specs = graph_->attributes(g);
    for (std::size_t i = 0; i < specs.size(); ++i) {
        const AttributeSpec& s = specs[i];
        const bool inCompound = !compound.empty() && (s.mayaCompound == compound || s.mayaCompoundShort == compound);
        if (!(compound.empty() ? s.mayaCompound.empty() : inCompound)) continue;
        if (const int c = mayaChildIndex(s, mayaName); c >= 0) return {static_cast<AttrId>(i), c};
    }
    return {-1, -1};
}

AttrId Builder::findCompoundChild(NodeId g, std::string_view compound, std::string_view child) const
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

std::optional<Plug> Builder::resolve(NodeId g, const AttrPath& p) const
{
    if (!p.valid) return std::nullopt;
    if (const auto alias = aliases_.find({g, p.name}); alias != aliases_.end() && p.child.empty()) return alias->second;
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

void Builder::countNotEvaluated(int n, const std::string& attr)
{
    ++info_.notEvaluatedAttributes[node(n).type + "." + splitAttr(attr).name];
}

void Builder::setValues()
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

void Builder::checkTypes()
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

void Builder::readTime(const maya::SetAttr& set)
{
    if ((set.plug != "o" && set.plug != "outTime") || set.where.file != 0) return;
    maya::ValueReader r(set.values, scene_.units[0]);
    info_.savedTime = std::get<double>(r.read(ValueType::Double, Unit::None));
}

void Builder::setValue(int n, NodeId g, const maya::SetAttr& set)
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
    const auto compound = p.child.empty() ? graph_->nodeType(g).mayaCompoundChildren(p.name) : std::vector<AttrId>{};
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
        for (int e = 0; !r.done(); ++e) graph_->setValue(Plug{g, plug->attr, e, plug->child}, r.read(type, spec.unit));
        return;
    }
    graph_->setValue(*plug, r.read(type, spec.unit));
}

void Builder::recordState(const Plug& plug, const maya::SetAttr& set)
{
    if (!set.keyable && !set.locked && !set.channelBox) return;
    MayaSceneInfo::PlugState& state = info_.plugStates[graph_->plugName(plug)];
    if (set.keyable) state.keyable = set.keyable;
    if (set.locked) state.locked = set.locked;
    if (set.channelBox) state.channelBox = set.channelBox;
}

void Builder::setCompoundRange(NodeId g, const std::vector<AttrId>& children, const AttrPath& p,
                               const maya::SetAttr& set, const maya::Units& units)
{
    maya::ValueReader r(set.values, units);
    for (int e = std::max(p.first, 0); e <= std::max(p.last, 0) && !r.done(); ++e)
        for (AttrId a : children) {
            const AttributeSpec& spec = graph_->attributes(g)[static_cast<std::size_t>(a)];
            graph_->setValue(Plug{g, a, e, -1}, r.read(spec.type, spec.unit));
        }
}

void Builder::setField(NodeId g, const MayaFieldParser& parser, const AttrPath& p, const maya::SetAttr& set,
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

void Builder::readMessages()
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

bool Builder::isMessage(std::string_view attr) const
{
    const std::string n = splitAttr(attr).name;
    return n == "msg" || n == "message" || n == "hsj" || n == "startJoint" || n == "hee" || n == "endEffector" ||
           n == "hsv" || n == "ikSolver" || n == "hp" || n == "handlePath";
}

void Builder::readTimeCurves()
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

}  // namespace maya_build

namespace {

std::unique_ptr<Graph> buildGraph(maya::Scene& scene, std::shared_ptr<NodeRegistry> registry, MayaSceneInfo& info,
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
    maya_build::Builder builder(scene, std::move(registry), info);
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

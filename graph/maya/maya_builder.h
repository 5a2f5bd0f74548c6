#pragma once
// Building a Graph from a Maya scene (maya_loader.h), internal to graph/maya/: the Builder's state and steps.
// maya_loader.cpp makes the nodes and sets their values; maya_wiring.cpp connects them (connections, DAG parenting,
// character sets), wires the IK chains to their handles' solver and refuses a node not evaluated that drives a joint.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "graph/graph.h"
#include "graph/maya/ma_scene.h"
#include "graph/maya/maya_info.h"
#include "graph/maya/maya_loader.h"
#include "graph/maya/maya_references.h"
#include "graph/maya/maya_values.h"

namespace rig::maya_build {

using maya::AttrPath;
using maya::Scene;
using maya::splitAttr;
using maya::Where;

class Builder {
public:
    Builder(Scene& scene, std::shared_ptr<NodeRegistry> registry, MayaSceneInfo& info);

    std::unique_ptr<Graph> build();

private:
    [[noreturn]] void fail(const Where& where, const std::string& what) const;
    const maya::Node& node(int n) const { return scene_.nodes[static_cast<std::size_t>(n)]; }
    NodeId graphNode(int n) const { return n < 0 ? -1 : graphNode_[static_cast<std::size_t>(n)]; }
    const std::string& name(NodeId g) const { return graph_->nodeName(g); }

    std::shared_ptr<const NodeType> ourType(int index) const;

    // Whether a plug of a scene node is a whole vector (its type's vector3 attribute, or a double3 added to it).
    bool vectorPlug(int n, const std::string& attr) const;

    // A unitConversion between whole vectors (a rotate into a multiplyDivide): Maya's conversion takes any numeric
    // data, this engine's unitConversion one number, so it is made a multiplyDivide by (cf, cf, cf) here.
    bool vectorConversion(int uc) const;

    // The plugs each unitConversion is connected with, found in one pass over the connections.
    void findConversionEnds();

    void aliasVectorConversion(NodeId g, const maya::Node& n);

    // The name Maya shows: the leaf name when no other node has it, else the shortest unique DAG path.
    std::string displayName(int n) const;

    void makeNodes();

    void addDynamicAttributes(const maya::Node& n, NodeId g);

    // An attribute of graph node g by Maya's long or short name (not a compound's child), or -1.
    AttrId findAttribute(NodeId g, std::string_view mayaName) const;

    // A vector3 attribute one of whose children Maya names `mayaName`: (attribute, child), or (-1, -1).
    std::pair<AttrId, int> findChild(NodeId g, std::string_view mayaName, std::string_view compound = {}) const;

    // A compound's child attribute by Maya name, or -1.
    AttrId findCompoundChild(NodeId g, std::string_view compound, std::string_view child) const;

    // The plug Maya's attribute path names on graph node g; nothing when this engine does not store it.
    std::optional<Plug> resolve(NodeId g, const AttrPath& p) const;

    void countNotEvaluated(int n, const std::string& attr);

    void setValues();

    // Nodes whose type can tell, from their values, that they cannot be evaluated (an expression calling MEL).
    void checkTypes();

    // The host scene's saved time: a referenced file's own time1 (merged with the scene's) says nothing about it.
    void readTime(const maya::SetAttr& set);

    void setValue(int n, NodeId g, const maya::SetAttr& set);

    void recordState(const Plug& plug, const maya::SetAttr& set);

    // ".tg[0:1]" with each element's children in turn.
    void setCompoundRange(NodeId g, const std::vector<AttrId>& children, const AttrPath& p, const maya::SetAttr& set,
                          const maya::Units& units);

    void setField(NodeId g, const MayaFieldParser& parser, const AttrPath& p, const maya::SetAttr& set,
                  const maya::Units& units);

    // Message connections say which joints an IK handle solves: read before anything is connected.
    void readMessages();

    bool isMessage(std::string_view attr) const;

    // Maya's parentMatrix and parentInverseMatrix outputs are the DAG parent's world matrices here.
    std::optional<Plug> dagSource(int n, const AttrPath& p, bool& identity) const;

    void markUnevaluated(NodeId driven, int source, const std::string& why, const Where& where);

    // Connections that a disconnectAttr or a reference edit removes: the same plugs, whichever of Maya's names spell
    // them (an edit writes "ctrl.translateX" where the file's connectAttr wrote "ctrl.tx").
    void dropDisconnected();

    bool samePlug(const std::string& a, const std::string& b) const;

    // The connections out of time curves, with the graph plug each drives (MayaSceneInfo::timeCurves).
    void readTimeCurves();

    // Connections out of outputs first, then those out of inputs: Maya evaluates per attribute, this engine per node,
    // and an input-to-input connection that would close a node-level cycle can be fed instead (connectOrFeed) only
    // when it is the one that closes it.
    void connectAll();

    bool sourceIsInput(const maya::Connection& c) const;

    void connectStatement(const maya::Connection& c, std::vector<const maya::Connection*>& selfConnections);

    bool referenceMissing(std::string_view nodeName) const;

    // A character set's element: a plug of its graph node (which stores the values the scene set), or nothing.
    std::optional<Plug> characterPlug(int n, const std::string& attr) const;

    // A joint's pivots and shear, which joints here do not store: Maya's zero unless the scene sets them.
    bool atMayaDefault(int n, NodeId g, const AttrPath& p) const;

    bool intoCharacter(const maya::Connection& c) const;

    // Character sets pass their elements through, and a control may drive the set that drives another control: kept
    // as a node, a set would close node-level cycles. Connections into a set are remembered; one out of it takes
    // their source instead, or, undriven, the element's value.
    void collectCharacterInputs();

    void connectOne(const maya::Connection& c, int src, int dst, std::string srcAttr, const std::string& dstAttr);

    // Maya's cycles are per attribute, this engine's per node: a connection from an input (joint.scale into the
    // inverseScale of a joint that is not its child) that would close a node-level cycle takes what drives that input
    // instead, or its value. False (with the message kept) when that is not possible either.
    bool connectOrFeed(const Plug& source, const Plug& destination);

    std::optional<Plug> nextAvailable(NodeId g, const AttrPath& p);

    // node.w0 -> node.tg[0].tw (a constraint's weight): the engine connects no node to itself, so the dynamic
    // attribute becomes another name of the plug it feeds (as Maya's alias), its value and sources moved there.
    void connectSelf(const maya::Connection& c);

    void wireDag();

    void wireIk();
    void wireChain(int handle, const std::vector<int>& chain, int effector);
    std::optional<Eigen::Vector3d> preferredAngle(int joint) const;
    void feed(const Plug& destination, const Plug& source);
    void setConverted(const Plug& destination, const Plug& source);
    bool connectOrValue(const Plug& from, const Plug& to);
    std::vector<Connection> detachInputs(NodeId joint);
    void readSolvedRotate(const Connection& detached);
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

}  // namespace rig::maya_build

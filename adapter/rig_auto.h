#pragma once
// What rig-learn --params auto and --outputs auto find in a Maya scene (docs/rig-learn.md, "Controls and joints
// found in the scene"): the channels an animator keys on the scene's controls, the joints its skins bind, and the
// time curves that key the channels, which the learner cuts so that it can set them (the curves are the clip).

#include <string>
#include <vector>

#include "graph/graph.h"
#include "graph/maya/maya_loader.h"

namespace rig {

// The connection into `p` (or into the vector it is a component of) when what drives it is animation alone: a time
// curve (animCurveTA/TL/TU/TT on the scene time), through unit conversions and animation-layer blends, and nothing
// of the rig; nullptr when `p` is free or the rig drives it (a set-driven key, a constraint, an expression).
const Connection* timeCurveInput(const Graph& g, const Plug& p);

// A plug's connection cut, to put back where the plug turns out to be no parameter.
struct CutCurve {
    Plug source, destination;
    bool rawUnits = false;
};

// Cuts the time curve into `p` (timeCurveInput), the plug keeping the value the curve gives it at the graph's time.
CutCurve cutTimeCurve(Graph& g, const Plug& p);

// Nodes reachable from `start` through connections, downstream or upstream (`start` included), by NodeId.
std::vector<char> reachableNodes(const GraphModel& m, const std::vector<NodeId>& start, bool downstream);

// --outputs auto: the joints the scene's skinClusters bind, in node order; every joint where none binds one.
struct AutoOutputs {
    std::vector<NodeId> joints;
    int skins = 0;  // skinClusters that bind at least one of the joints
};
AutoOutputs autoOutputJoints(const Graph& g, const MayaSceneInfo& info);

// A channel auto passed by, with why ("locked", "not keyable", "driven by X", "moves no output").
struct PassedChannel {
    std::string plug, why;
};

// The channels of the scene's controls (MayaSceneInfo::controls, and every node a time curve keys), on the nodes
// upstream of `outputs` (those below reach no output through any connection).
struct ControlChannels {
    std::vector<std::string> controls;  // the controls found, in node order
    // Keyable, unlocked numbers (doubles: Maya's keyable state, else the attribute's) that nothing but a time curve
    // drives: the parameter candidates, in node and attribute order.
    std::vector<Plug> candidates;
    // Keyable or channel-box whole numbers (enum, bool, int) and channel-box doubles that nothing drives, unlocked,
    // with more than one value: the switches and settings the scene holds (an ikFk switch).
    std::vector<Plug> settings;
    std::vector<PassedChannel> passed;  // keyable channels locked, made not keyable, or driven by the rig
};
ControlChannels controlChannels(const Graph& g, const MayaSceneInfo& info, const std::vector<NodeId>& outputs);

// Whether a Maya scene made the plug keyable (`setAttr -k on`, on it or on the vector it is a component of).
bool sceneKeyable(const Graph& g, const MayaSceneInfo& info, const Plug& p);

// A number plug's value in the rig file's units (degrees for an angle), as a held plug gives it.
double userValue(Graph& g, const Plug& p);

}  // namespace rig

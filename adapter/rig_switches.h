#pragma once
// The animated switches among a rig's parameters (docs/rig-learn.md, Blends): a parameter that drives a blendColors
// node's `blender` plug, directly or through plain connections (each step an input plug fed by another input plug,
// no node computing between), and the joint outputs whose own channels (any input but parentMatrix) that node feeds,
// through nodes that are not transforms or joints. rig-learn learns a rig with switches once with every switch held
// at 1 and once at 0, and blends the switched outputs by their switch's weight (app/learn/learn_run.h).

#include <string>
#include <vector>

#include "adapter/graph_rig_function.h"

namespace rig {

struct RigSwitches {
    std::vector<int> switches;        // parameter indices of the switches that switch some output, increasing
    std::vector<int> switchOfOutput;  // per rig output: the switch (a parameter index) blending it, or -1
};

// Throws a userInput rig::Error for an output that two switches blend, or a switch not limited to [0, 1] (`rigName`
// says where).
RigSwitches findSwitches(GraphRigFunction& rig, const std::string& rigName);

}  // namespace rig

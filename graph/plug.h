#pragma once
// A plug names one value of one node: node.attribute, node.attribute[index] (array attributes),
// node.attributeX (a vector3 component) or node.attribute[index].attributeX.

#include <compare>

#include "graph/attribute.h"

namespace rig {

using NodeId = int;

struct Plug {
    NodeId node = -1;
    AttrId attr = -1;
    int index = -1;  // element of an array attribute, -1 otherwise
    int child = -1;  // component 0..2 of a vector3, -1 for the whole value

    friend auto operator<=>(const Plug&, const Plug&) = default;
};

struct Connection {
    Plug source;
    Plug destination;
    bool rawUnits = false;  // no unit conversion across it (a Maya scene's connections: docs/maya.md)
};

}  // namespace rig

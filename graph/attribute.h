#pragma once
// An attribute of a node type (Maya's MFnAttribute): name, data type, direction, default, limits.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "graph/value.h"

namespace rig {

using AttrId = int;

struct AttributeSpec {
    std::string name;
    ValueType type = ValueType::Double;
    bool input = true;   // false: an output, written only by the node's compute
    Value defaultValue;  // in internal units (radians for angles)
    Unit unit = Unit::None;
    bool keyable = false;       // an animator control (Maya's keyable flag)
    bool array = false;         // a multi attribute: elements name[0], name[1], ...
    std::optional<double> min;  // inclusive limits on numbers (each component of a vector3)
    std::optional<double> max;
    std::vector<std::string> enumNames;     // Enum: names of values 0, 1, ...
    std::array<std::string, 3> childNames;  // Vector3: plugs of the components, e.g. rotateX
    bool sceneTime = false;                 // when unconnected, follows the graph's time (Maya's animCurveT* input)
    bool filePath = false;  // a String naming a file: a relative one in a rig file is read from that file's folder
    bool dynamic = false;   // added to one node by the rig file (Maya's addAttr), not by its type
    std::string description;
    // Maya's names (docs/maya.md), read by the Maya ASCII loader. shortName: ".t" for translate; a vector3's
    // children are its short name plus each child's suffix (tx, shxy) unless childShortNames says otherwise.
    // mayaCompound and mayaCompoundShort: this array attribute is one child of a Maya compound multi attribute,
    // flattened into parallel arrays (a constraint's target[i].targetTranslate is targetTranslate[i]; Maya's
    // ".tg[i].tt" is read as that).
    std::string shortName;
    std::array<std::string, 3> childShortNames;
    std::string mayaCompound;
    std::string mayaCompoundShort;

    bool operator==(const AttributeSpec&) const = default;
};

// Index of `name` among a vector3 spec's childNames, or -1.
int childIndex(const AttributeSpec& spec, std::string_view name);
// Index of `name` among a vector3 spec's Maya child names (long or short: translateX or tx), or -1.
int mayaChildIndex(const AttributeSpec& spec, std::string_view name);

}  // namespace rig

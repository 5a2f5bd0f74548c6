// character: Maya's character set, a pass-through that animation layers and clips key instead of the controls. Its
// value arrays are set or driven (by curves) and feed the controls (docs/maya.md): the controls read its elements.
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { linearValues, angularValues, unitlessValues, timeValues };

class CharacterNode : public Node {
public:
    void compute(ComputeContext&) override {}  // no outputs: the controls read its inputs
};

}  // namespace

std::shared_ptr<const NodeType> makeCharacterType()
{
    NodeTypeBuilder b("character");
    b.description(
        "Maya's character set: the animated values of a set of controls, gathered in one node that curves key and "
        "that feeds the controls (each control's plug is connected from one element). Nothing is computed: the "
        "elements pass through.");
    b.input(linearValues, "linearValues", ValueType::Double)
        .shortName("lv")
        .array()
        .unit(Unit::Distance)
        .doc("Distances the set passes to its controls' translates, cm.");
    b.input(angularValues, "angularValues", ValueType::Double)
        .shortName("av")
        .array()
        .unit(Unit::Angle)
        .doc("Angles the set passes to its controls' rotates.");
    b.input(unitlessValues, "unitlessValues", ValueType::Double)
        .shortName("uv")
        .array()
        .doc("Unitless values the set passes to its controls (scales, custom attributes).");
    b.input(timeValues, "timeValues", ValueType::Double)
        .shortName("tv")
        .array()
        .unit(Unit::Time)
        .doc("Times the set passes on, frames.");
    return b.factory<CharacterNode>().build();
}

}  // namespace rig

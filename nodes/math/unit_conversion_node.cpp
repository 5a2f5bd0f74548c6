// unitConversion: Maya's unitConversion, output = input * conversionFactor.

#include "graph/node_type.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { Input, ConversionFactor, Output };

class UnitConversionNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        context.setOutput(Output, context.getDouble(Input) * context.getDouble(ConversionFactor));
    }
};

}  // namespace

double unitConversionFactor(double mayaFactor, Unit source, Unit destination)
{
    // Maya multiplies internal units (radians) by its factor; a converting connection (a YAML rig's) already turns
    // radians into degrees from an angle plug into a unitless one (and back on the way out): that part is divided out.
    return mayaFactor / (unitFactor(source, Unit::None) * unitFactor(Unit::None, destination));
}

std::shared_ptr<const NodeType> makeUnitConversionType()
{
    NodeTypeBuilder b("unitConversion");
    b.description(
        "Multiplies its input by a factor (Maya's unitConversion node, which Maya inserts between plugs of "
        "different units): output = input * conversionFactor; input and output are unitless. A Maya scene's "
        "connections carry values as Maya stores them (docs/maya.md), so its factor is Maya's own: 57.2958 turns a "
        "rotateX's radians into the degrees an animCurveUA reads. In a YAML rig, a connection from an angle plug "
        "into a unitless one already gives degrees: unitConversionFactor (nodes/builtin_nodes.h) divides that out "
        "of a Maya factor (57.2958 becomes 1).");
    b.input(Input, "input", ValueType::Double).shortName("i").doc("The value converted.");
    b.input(ConversionFactor, "conversionFactor", ValueType::Double)
        .shortName("cf")
        .defaultValue(1.0)
        .doc("The multiplier (a Maya scene's factor as it is; in a YAML rig, see the description).");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("input * conversionFactor.");
    b.affects(Input, {Output}).affects(ConversionFactor, {Output});
    b.factory<UnitConversionNode>();
    return b.build();
}

}  // namespace rig

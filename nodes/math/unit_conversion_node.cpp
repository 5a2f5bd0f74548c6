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
    // Maya multiplies internal units (radians) by its factor; this engine already converts radians to degrees on
    // a connection from an angle plug into a unitless one (and back on the way out), so that part is divided out.
    return mayaFactor / (unitFactor(source, Unit::None) * unitFactor(Unit::None, destination));
}

std::shared_ptr<const NodeType> makeUnitConversionType()
{
    NodeTypeBuilder b("unitConversion");
    b.description(
        "Multiplies its input by a factor (Maya's unitConversion node, which Maya inserts between plugs of "
        "different units): output = input * conversionFactor. Input and output are unitless here, and this engine "
        "converts radians to degrees on a connection from an angle plug into a unitless plug (and back on the way "
        "into an angle plug), which Maya does inside the node through its factor. So a scene's factor is divided "
        "by the conversions the connections make (unitConversionFactor in nodes/builtin_nodes.h): Maya's 57.2958 "
        "between an angle plug and a unitless plug becomes 1, and a rotateX read by an animCurveUA through it "
        "arrives in degrees, as in Maya.");
    b.input(Input, "input", ValueType::Double).shortName("i").doc("The value converted.");
    b.input(ConversionFactor, "conversionFactor", ValueType::Double)
        .shortName("cf")
        .defaultValue(1.0)
        .doc("The multiplier (a scene's factor, divided by what the connections convert: see the description).");
    b.output(Output, "output", ValueType::Double).shortName("o").doc("input * conversionFactor.");
    b.affects(Input, {Output}).affects(ConversionFactor, {Output});
    b.factory<UnitConversionNode>();
    return b.build();
}

}  // namespace rig

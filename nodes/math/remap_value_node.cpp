// remapValue: Maya's remapValue, a value remapped through a 0..1 ramp (the float ramp only).

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/node_type.h"
#include "nodes/anim_curve_math.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId { InputValue, InputMin, InputMax, OutputMin, OutputMax, RampValue, Interp, OutValue };
enum InterpMode { None, Linear, Smooth, Spline };

// The ramp as a curve with constant ends: none = step, linear = linear, smooth = flat tangents
// (smoothstep between entries), spline = Catmull-Rom slopes (secant at the end entries).
AnimCurve rampCurve(const ComputeContext& context)
{
    std::vector<double> flat = context.getDoubleArray(RampValue);
    if (flat.empty()) flat = {0.0, 0.0, 1.0, 1.0};  // Maya's default ramp
    if (flat.size() % 2 != 0)
        throw Error(
            fmt::format("{}.value: the ramp has {} numbers; it must be (position, value) pairs, "
                        "an even count",
                        context.nodeName(), flat.size()));
    static constexpr TangentType tangents[] = {TangentType::step, TangentType::linear, TangentType::flat,
                                               TangentType::spline};
    const int interp = context.getEnum(Interp);  // a connection can bring any int: others act as linear
    const TangentType tangent = interp >= None && interp <= Spline ? tangents[interp] : TangentType::linear;
    std::vector<AnimKey> keys;
    for (std::size_t i = 0; i < flat.size(); i += 2) keys.push_back({flat[i], flat[i + 1], tangent, tangent});
    std::stable_sort(keys.begin(), keys.end(), [](const AnimKey& a, const AnimKey& b) { return a.x < b.x; });
    // Of entries at the same position the last one given wins.
    std::vector<AnimKey> unique;
    for (const AnimKey& key : keys) {
        if (!unique.empty() && unique.back().x == key.x) unique.back() = key;
        else unique.push_back(key);
    }
    try {
        return AnimCurve::build(std::move(unique));
    }
    catch (const Error& e) {
        throw e.in(fmt::format("{}.value", context.nodeName()));
    }
}

class RemapValueNode final : public Node {
public:
    void compute(ComputeContext& context) override
    {
        const double in = context.getDouble(InputValue);
        const double inMin = context.getDouble(InputMin);
        const double inMax = context.getDouble(InputMax);
        double t = 0.0;
        if (inMax != inMin) t = (in - inMin) / (inMax - inMin);
        else if (in != inMin) t = (in > inMin ? 1.0 : -1.0) * std::numeric_limits<double>::infinity();
        const double r = rampCurve(context).evaluate(t);
        const double outMin = context.getDouble(OutputMin);
        const double out = outMin + (context.getDouble(OutputMax) - outMin) * r;
        context.setOutput(OutValue, std::isfinite(out) ? out : 0.0);
    }
};

}  // namespace

std::shared_ptr<const NodeType> makeRemapValueType()
{
    NodeTypeBuilder b("remapValue");
    b.description(
        "Remaps inputValue through a ramp (Maya's remapValue node, its float ramp): t = (inputValue - inputMin) / "
        "(inputMax - inputMin), outValue = outputMin + (outputMax - outputMin) * ramp(t). The ramp holds its first "
        "and last entries' values outside their positions. When inputMin == inputMax the ramp is read at its "
        "right end for inputValue > inputMin, its left end below, and at 0 when equal. An overflowing result "
        "outputs 0. Maya's colour ramp (color, outColor) is not modelled.");
    b.input(InputValue, "inputValue", ValueType::Double).keyable().doc("The value remapped.");
    b.input(InputMin, "inputMin", ValueType::Double).keyable().doc("The inputValue that maps to ramp position 0.");
    b.input(InputMax, "inputMax", ValueType::Double)
        .defaultValue(1.0)
        .keyable()
        .doc("The inputValue that maps to ramp position 1.");
    b.input(OutputMin, "outputMin", ValueType::Double).keyable().doc("The outValue for a ramp value of 0.");
    b.input(OutputMax, "outputMax", ValueType::Double)
        .defaultValue(1.0)
        .keyable()
        .doc("The outValue for a ramp value of 1.");
    b.input(RampValue, "value", ValueType::DoubleArray)
        .doc(
            "The ramp, flattened as (position, value) pairs: [position0, value0, position1, value1, ...] "
            "(Maya's value[i].value_Position and value[i].value_FloatValue). Entries may come in any order; "
            "of two at the same position the later one wins; an odd count is an error. Empty means Maya's "
            "default ramp [0, 0, 1, 1] (outValue follows inputValue linearly).");
    b.input(Interp, "interp", ValueType::Enum)
        .enumNames({"none", "linear", "smooth", "spline"})
        .defaultValue(static_cast<int>(Linear))
        .doc(
            "Interpolation between ramp entries, for the whole ramp (Maya's value[i].value_Interp, one per "
            "entry there): none holds each entry's value up to the next, linear, smooth eases in and out of "
            "each entry (zero slope at entries), spline is a Catmull-Rom curve through the entries.");
    b.output(OutValue, "outValue", ValueType::Double).doc("The remapped value.");
    for (AttrId in : {InputValue, InputMin, InputMax, OutputMin, OutputMax, RampValue, Interp})
        b.affects(in, {OutValue});
    b.factory<RemapValueNode>();
    return b.build();
}

}  // namespace rig

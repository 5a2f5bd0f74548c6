// remapValue: Maya's remapValue, a value remapped through a 0..1 ramp (the float ramp only).

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/node_type.h"
#include "nodes/anim_curve_math.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

enum Attr : AttrId {
    InputValue,
    InputMin,
    InputMax,
    OutputMin,
    OutputMax,
    RampValue,
    Interp,
    ValuePosition,
    ValueFloatValue,
    ValueInterp,
    OutValue
};
enum InterpMode { None, Linear, Smooth, Spline };

constexpr TangentType interpTangent(int interp)
{
    // A connection can bring any int: values outside the enum act as linear.
    switch (interp) {
        case None:
            return TangentType::step;
        case Smooth:
            return TangentType::flat;
        case Spline:
            return TangentType::spline;
        default:
            return TangentType::linear;
    }
}

struct RampEntry {
    double position = 0.0;
    double value = 0.0;
    int interp = Linear;
};

// Maya's value[i] entries, flattened into valuePosition[i], valueFloatValue[i], valueInterp[i]: an entry exists
// where its position or its value does (Maya writes both); a missing field takes Maya's default.
std::vector<RampEntry> mayaEntries(const ComputeContext& context)
{
    std::map<int, RampEntry> entries;
    context.forEachElement(ValuePosition, [&](int i, const Value& v) { entries[i].position = std::get<double>(v); });
    context.forEachElement(ValueFloatValue, [&](int i, const Value& v) { entries[i].value = std::get<double>(v); });
    std::vector<RampEntry> out;
    if (entries.empty()) return out;
    context.forEachElement(ValueInterp, [&](int i, const Value& v) {
        if (auto it = entries.find(i); it != entries.end()) it->second.interp = std::get<int>(v);
    });
    for (const auto& [index, entry] : entries) out.push_back(entry);
    return out;
}

// The flat `value` pairs with the one `interp` for every entry.
std::vector<RampEntry> flatEntries(const ComputeContext& context)
{
    std::vector<double> flat = context.getDoubleArray(RampValue);
    if (flat.empty()) flat = {0.0, 0.0, 1.0, 1.0};  // Maya's default ramp
    if (flat.size() % 2 != 0)
        throw Error(
            fmt::format("{}.value: the ramp has {} numbers; it must be (position, value) pairs, "
                        "an even count",
                        context.nodeName(), flat.size()));
    std::vector<RampEntry> entries;
    for (std::size_t i = 0; i < flat.size(); i += 2)
        entries.push_back({flat[i], flat[i + 1], context.getEnum(Interp)});
    return entries;
}

// The ramp as a curve with constant ends. An entry's interpolation governs the span after it (Maya's
// value_Interp): none = step, linear = linear, smooth = flat tangents (smoothstep between entries), spline =
// Catmull-Rom slopes (secant at the end entries).
AnimCurve rampCurve(const ComputeContext& context)
{
    std::vector<RampEntry> entries = mayaEntries(context);
    if (entries.empty()) entries = flatEntries(context);
    std::stable_sort(entries.begin(), entries.end(),
                     [](const RampEntry& a, const RampEntry& b) { return a.position < b.position; });
    // Of entries at the same position the last one given wins.
    std::vector<RampEntry> unique;
    for (const RampEntry& entry : entries) {
        if (!unique.empty() && unique.back().position == entry.position) unique.back() = entry;
        else unique.push_back(entry);
    }
    std::vector<AnimKey> keys;
    for (std::size_t i = 0; i < unique.size(); ++i) {
        const TangentType before = interpTangent(i > 0 ? unique[i - 1].interp : unique[i].interp);
        keys.push_back({unique[i].position, unique[i].value, before, interpTangent(unique[i].interp)});
    }
    try {
        return AnimCurve::build(std::move(keys));
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
        "outputs 0. The ramp is Maya's value[i] entries (valuePosition, valueFloatValue, valueInterp) when any is "
        "given, otherwise the flat `value` pairs with one `interp`. Maya's colour ramp (color, outColor) is not modelled.");
    b.input(InputValue, "inputValue", ValueType::Double).shortName("i").keyable().doc("The value remapped.");
    b.input(InputMin, "inputMin", ValueType::Double).shortName("imn").keyable().doc("The inputValue that maps to ramp position 0.");
    b.input(InputMax, "inputMax", ValueType::Double)
        .shortName("imx")
        .defaultValue(1.0)
        .keyable()
        .doc("The inputValue that maps to ramp position 1.");
    b.input(OutputMin, "outputMin", ValueType::Double).shortName("omn").keyable().doc("The outValue for a ramp value of 0.");
    b.input(OutputMax, "outputMax", ValueType::Double)
        .shortName("omx")
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
    b.input(ValuePosition, "valuePosition", ValueType::Double)
        .array()
        .shortName("vp")
        .mayaCompound("value", "vl")
        .doc(
            "Maya's ramp entry i, its position (value[i].value_Position, \".vl[i].vp\"). When valuePosition or "
            "valueFloatValue has elements, these entries are the ramp and `value` and `interp` are ignored.");
    b.input(ValueFloatValue, "valueFloatValue", ValueType::Double)
        .array()
        .shortName("fv")
        .mayaCompound("value", "vl")
        .doc("Maya's ramp entry i, its value (value[i].value_FloatValue, \".vl[i].fv\"); 0 when absent.");
    b.input(ValueInterp, "valueInterp", ValueType::Enum)
        .array()
        .enumNames({"none", "linear", "smooth", "spline"})
        .defaultValue(static_cast<int>(Linear))
        .shortName("vi")
        .mayaCompound("value", "vl")
        .doc(
            "Maya's ramp entry i, the interpolation from it to the next entry (value[i].value_Interp, \".vl[i].vi\"); "
            "linear when absent.");
    b.output(OutValue, "outValue", ValueType::Double).shortName("ov").doc("The remapped value.");
    for (AttrId in :
         {InputValue, InputMin, InputMax, OutputMin, OutputMax, RampValue, Interp, ValuePosition, ValueFloatValue, ValueInterp})
        b.affects(in, {OutValue});
    b.factory<RemapValueNode>();
    return b.build();
}

}  // namespace rig

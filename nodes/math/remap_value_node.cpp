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

// Sets field `field` of entry i for every element of an array input, creating the entries it names (an element of
// Maya's compound multi value[i] exists once any of its fields is set).
template <class T, class F>
void applyField(const ComputeContext& context, AttrId attr, std::vector<RampEntry>& entries, int interp, F field)
{
    context.forEachElement<T>(attr, [&](int i, const T& v) {
        const auto k = static_cast<std::size_t>(i);
        if (entries.size() <= k) entries.resize(k + 1, RampEntry{0.0, 0.0, interp});
        field(entries[k], v);
    });
}

// The ramp's entries by index: entry i is (value[2i], value[2i + 1]), linear, each field replaced where
// valuePosition[i], valueFloatValue[i] or valueInterp[i] is given (a Maya scene's .vl[i].vp, .fv, .vi). Entries
// neither gives are dropped; none at all is Maya's default ramp.
std::vector<RampEntry> rampEntries(const ComputeContext& context)
{
    const std::vector<double>& flat = context.getDoubleArray(RampValue);
    if (flat.size() % 2 != 0)
        throw Error(
            fmt::format("{}.value: the ramp has {} numbers; it must be (position, value) pairs, "
                        "an even count",
                        context.nodeName(), flat.size()));
    const int interp = Linear;  // Maya's default for an entry
    std::vector<RampEntry> entries;
    std::vector<bool> given(flat.size() / 2, true);
    for (std::size_t i = 0; i < flat.size(); i += 2) entries.push_back({flat[i], flat[i + 1], interp});
    auto mark = [&](AttrId attr) {
        context.forEachIndex(attr, [&](int i) {
            if (given.size() <= static_cast<std::size_t>(i)) given.resize(static_cast<std::size_t>(i) + 1, false);
            given[static_cast<std::size_t>(i)] = true;
        });
    };
    applyField<double>(context, ValuePosition, entries, interp, [](RampEntry& e, double v) { e.position = v; });
    applyField<double>(context, ValueFloatValue, entries, interp, [](RampEntry& e, double v) { e.value = v; });
    applyField<int>(context, ValueInterp, entries, interp, [](RampEntry& e, int v) { e.interp = v; });
    for (AttrId attr : {ValuePosition, ValueFloatValue, ValueInterp}) mark(attr);
    std::vector<RampEntry> present;
    // An entry whose position or value is not a number (NaN or infinity through a connection) cannot be placed on
    // the ramp: it is left out, so a bad driver never stops the evaluation.
    for (std::size_t i = 0; i < entries.size(); ++i)
        if (given[i] && std::isfinite(entries[i].position) && std::isfinite(entries[i].value))
            present.push_back(entries[i]);
    if (present.empty()) present = {{0.0, 0.0, interp}, {1.0, 1.0, interp}};  // Maya's default ramp
    return present;
}

// The ramp as a curve with constant ends. An entry's interpolation governs the span after it (Maya's
// value_Interp): none = step, linear = linear, smooth = flat tangents (smoothstep between entries), spline =
// Catmull-Rom slopes (secant at the end entries).
AnimCurve rampCurve(const ComputeContext& context)
{
    std::vector<RampEntry> entries = rampEntries(context);
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
        "outputs 0. The ramp's entries come by index from the flat `value` pairs and from Maya's value[i] fields "
        "(valuePosition, valueFloatValue, valueInterp), which replace a pair's field where given; an entry whose "
        "position or value is NaN or infinite is left out. Maya's colour ramp "
        "(color, outColor) is not modelled.");
    b.input(InputValue, "inputValue", ValueType::Double).shortName("i").keyable().doc("The value remapped.");
    b.input(InputMin, "inputMin", ValueType::Double)
        .shortName("imn")
        .keyable()
        .doc("The inputValue that maps to ramp position 0.");
    b.input(InputMax, "inputMax", ValueType::Double)
        .shortName("imx")
        .defaultValue(1.0)
        .keyable()
        .doc("The inputValue that maps to ramp position 1.");
    b.input(OutputMin, "outputMin", ValueType::Double)
        .shortName("omn")
        .keyable()
        .doc("The outValue for a ramp value of 0.");
    b.input(OutputMax, "outputMax", ValueType::Double)
        .shortName("omx")
        .defaultValue(1.0)
        .keyable()
        .doc("The outValue for a ramp value of 1.");
    b.input(RampValue, "value", ValueType::DoubleArray)
        .doc(
            "The ramp, flattened as (position, value) pairs: [position0, value0, position1, value1, ...] "
            "(Maya's value[i].value_Position and value[i].value_FloatValue). Entries may come in any order; "
            "of two at the same position the later one wins; an odd count is an error. Empty, with no "
            "valuePosition, valueFloatValue or valueInterp elements either, means Maya's default ramp [0, 0, 1, 1] "
            "(outValue follows inputValue linearly).");
    b.input(ValuePosition, "valuePosition", ValueType::Double)
        .array()
        .shortName("vp")
        .mayaCompound("value", "vl")
        .doc(
            "Entry i's position (Maya's value[i].value_Position, \".vl[i].vp\"): replaces value[2i] or adds entry i "
            "(position 0 when only its other fields are given).");
    b.input(ValueFloatValue, "valueFloatValue", ValueType::Double)
        .array()
        .shortName("fv")
        .mayaCompound("value", "vl")
        .doc(
            "Entry i's value (Maya's value[i].value_FloatValue, \".vl[i].fv\"): replaces value[2i + 1] or adds entry "
            "i (value 0 when only its other fields are given).");
    b.input(ValueInterp, "valueInterp", ValueType::Enum)
        .array()
        .enumNames({"none", "linear", "smooth", "spline"})
        .defaultValue(static_cast<int>(Linear))
        .shortName("vi")
        .mayaCompound("value", "vl")
        .doc(
            "Entry i's interpolation toward the next entry (Maya's value[i].value_Interp, \".vl[i].vi\"): none holds "
            "the entry's value up to the next, linear (Maya's default, and the flat pairs'), smooth eases in and out "
            "(zero slope at both entries), spline is a Catmull-Rom curve through the entries.");
    b.output(OutValue, "outValue", ValueType::Double).shortName("ov").doc("The remapped value.");
    for (AttrId in :
         {InputValue, InputMin, InputMax, OutputMin, OutputMax, RampValue, ValuePosition, ValueFloatValue, ValueInterp})
        b.affects(in, {OutValue});
    b.factory<RemapValueNode>();
    return b.build();
}

}  // namespace rig

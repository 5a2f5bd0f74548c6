// animCurveTU/TA/TL/TT/UU/UA/UL/UT: Maya's animation curves and set-driven keys. T curves are driven by
// time (in frames; the scene time when `input` is unconnected), U curves by any number; U, A, L and T
// outputs are unitless, angles, distances and times. Keys come from `keys:` in a rig file, from a curve of
// a Maya .anim file (animFile and animPlug; nodes/curves/anim_file.h), or from a Maya ASCII scene's setAttr
// statements (the Maya fields at the end of this file: ".ktv", ".kit", ".kix", ...).
#include <cmath>
#include <numbers>
#include <optional>
#include <tuple>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "core/parse_number.h"
#include "nodes/anim_curve_math.h"
#include "nodes/builtin_nodes.h"
#include "nodes/curves/anim_file.h"

namespace rig {
namespace {

// framesPerSecond comes last, after the output: only time-driven curves have it.
enum Attr : AttrId {
    input,
    keyTime,
    keyValue,
    keyInTangent,
    keyOutTangent,
    tangents,
    preInfinity,
    postInfinity,
    keyTangentVectors,
    weightedTangents,
    animFile,
    animPlug,
    output,
    framesPerSecond
};

// Per-key tangent type indices name the first eight types; a key's tangent is fixed through its vector
// (keyTangentVectors). `tangents` also takes fixed (Maya's curves whose keys default to fixed).
constexpr int keyTangentTypeCount = 8;
constexpr int tangentTypeCount = 9;
constexpr int infinityCount = 5;
// Arrays hold finite numbers only (setValue checks them): a tangent vector's x of 0 stands for "not fixed"
// (a fixed tangent's x is > 0), and keys a setAttr has not reached yet hold 0.
constexpr double notGiven = 0.0;

// keyTangentVectors holds four numbers a key: in x, in y, out x, out y.
std::size_t vectorIndex(std::size_t key, bool in, bool x) { return 4 * key + (in ? 0 : 2) + (x ? 0 : 1); }

std::vector<std::string> tangentNames(int count = keyTangentTypeCount)
{
    std::vector<std::string> names;
    for (int i = 0; i < count; ++i) names.emplace_back(tangentTypeName(static_cast<TangentType>(i)));
    return names;
}

std::vector<std::string> infinityNames()
{
    std::vector<std::string> names;
    for (int i = 0; i < infinityCount; ++i) names.emplace_back(infinityName(static_cast<Infinity>(i)));
    return names;
}

// Everything a curve is built from when it does not come from a .anim file; compute rebuilds the curve only
// when one of them changes (the input changes every frame, the keys seldom).
struct KeyInputs {
    std::vector<double> times, values, ins, outs, vectors;
    // The settings, apart from the keys: compared on their own.
    struct Settings {
        int fallback = -1, pre = -1, post = -1;
        bool weighted = false;
        double framesPerSecond = 0.0;
        bool operator==(const Settings&) const = default;
    } settings;
};

class AnimCurveNode : public Node {
public:
    AnimCurveNode(std::string typeName, double yScale) : typeName_(std::move(typeName)), yScale_(yScale) {}

    void compute(ComputeContext& c) override
    {
        const std::string& file = c.getString(animFile);
        const std::string& plug = c.getString(animPlug);
        if (!file.empty() || !plug.empty()) {
            if (!c.getDoubleArray(keyTime).empty())
                throw Error(fmt::format("node '{}': has keys and animFile; give one of them", c.nodeName()));
            // The file is read again only when it or the plug changes.
            if (file != file_ || plug != plug_ || !fromFile_) {
                curve_ = fileCurve(c, file, plug);
                file_ = file;
                plug_ = plug;
                fromFile_ = true;
            }
            c.setOutput(output, curve_.evaluate(c.getDouble(input)));
            return;
        }
        if (fromFile_) {
            fromFile_ = false;
            inputs_.settings.fallback = -1;  // rebuilt from the keys below
        }
        // Compared where they are with what built the curve, and copied only when they differ (a frame then
        // allocates nothing, and the node holds one copy of its keys).
        const KeyInputs::Settings now = readSettings(c);
        const auto same = [&](AttrId a, const std::vector<double>& kept) { return c.getDoubleArray(a) == kept; };
        if (!(same(keyTime, inputs_.times) && same(keyValue, inputs_.values) && same(keyInTangent, inputs_.ins) &&
              same(keyOutTangent, inputs_.outs) && same(keyTangentVectors, inputs_.vectors) &&
              now == inputs_.settings)) {
            KeyInputs read{c.getDoubleArray(keyTime),           c.getDoubleArray(keyValue),
                           c.getDoubleArray(keyInTangent),      c.getDoubleArray(keyOutTangent),
                           c.getDoubleArray(keyTangentVectors), now};
            curve_ = build(c, read);
            inputs_ = std::move(read);
        }
        c.setOutput(output, curve_.evaluate(c.getDouble(input)));
    }

private:
    // The curve of `plug` in the .anim file `file`, its values in this node's internal units.
    AnimCurve fileCurve(const ComputeContext& c, const std::string& file, const std::string& plug) const
    {
        if (file.empty())
            throw Error(
                fmt::format("node '{}': animPlug is set but animFile is empty; give the .anim file", c.nodeName()));
        if (plug.empty())
            throw Error(
                fmt::format("node '{}': animFile {} needs animPlug, the plug whose curve to play "
                            "(NODE.ATTRIBUTE as the file's anim lines name it)",
                            c.nodeName(), file));
        AnimFile anim;
        try {
            anim = readAnimFile(file);
        }
        catch (const Error& e) {
            throw Error(fmt::format("node '{}': {}", c.nodeName(), e.what()));
        }
        const AnimFileCurve* curve = anim.find(plug);
        if (!curve) {
            std::string names;
            for (std::size_t i = 0; i < anim.curves.size() && i < 4; ++i)
                names += fmt::format("{}{}", i ? ", " : "", anim.curves[i].plugName());
            if (anim.curves.size() > 4) names += fmt::format(" and {} more", anim.curves.size() - 4);
            throw Error(fmt::format("node '{}': {} has no curve for {} (it has {}); set animPlug to one of its plugs",
                                    c.nodeName(), file, plug, names.empty() ? "none" : names));
        }
        if (curve->nodeTypeName() != typeName_)
            throw Error(fmt::format("node '{}': {}: the curve of {} goes from {} to {}; play it with an {}, not an {}",
                                    c.nodeName(), formatMark(curve->mark), plug, animQuantityName(curve->input),
                                    animQuantityName(curve->output), curve->nodeTypeName(), typeName_));
        std::vector<AnimKey> keys = curve->keys;
        for (AnimKey& k : keys) k.y *= yScale_;
        try {
            return AnimCurve::build(std::move(keys), curve->pre, curve->post);
        }
        catch (const Error& e) {
            throw e.in(fmt::format("node '{}': {}", c.nodeName(), formatMark(curve->mark)));
        }
    }

    // A key's tangent on one side: its type index (-1: `tangents`), made fixed by a vector when one is given.
    std::pair<TangentType, TangentVector> tangent(const ComputeContext& c, const KeyInputs& k, std::size_t i,
                                                  bool in) const
    {
        const std::vector<double>& types = in ? k.ins : k.outs;
        const char* what = in ? "keyInTangent" : "keyOutTangent";
        const double t = i < types.size() ? types[i] : -1.0;
        if (t != -1.0 && (t != std::floor(t) || t < 0 || t >= keyTangentTypeCount))
            throw Error(fmt::format("node '{}': {}[{}] = {} is not a tangent type index", c.nodeName(), what, i, t));
        const TangentType type = static_cast<TangentType>(t == -1.0 ? k.settings.fallback : static_cast<int>(t));
        const std::size_t at = vectorIndex(i, in, true);
        const double x = at < k.vectors.size() ? k.vectors[at] : notGiven;
        const double y = at + 1 < k.vectors.size() ? k.vectors[at + 1] : notGiven;
        if (x == notGiven) return {type, TangentVector{}};  // a fixed type without a vector is flat
        if (x < 0.0)
            throw Error(
                fmt::format("node '{}': keyTangentVectors[{}] = {}, key {}'s {}-tangent x, is negative; a "
                            "fixed tangent's x is > 0 (0: not fixed)",
                            c.nodeName(), at, x, i, in ? "in" : "out"));
        // Maya's tangent x is in seconds on a time-driven curve; keys are in frames.
        return {TangentType::fixed, TangentVector{x * (timeDriven() ? k.settings.framesPerSecond : 1.0), y}};
    }

    AnimCurve build(const ComputeContext& c, const KeyInputs& k) const
    {
        if (k.times.size() != k.values.size())
            throw Error(fmt::format("node '{}': keyTime has {} values but keyValue has {}; give one value per key",
                                    c.nodeName(), k.times.size(), k.values.size()));
        std::vector<AnimKey> keys;
        for (std::size_t i = 0; i < k.times.size(); ++i) {
            const auto [inType, inVector] = tangent(c, k, i, true);
            const auto [outType, outVector] = tangent(c, k, i, false);
            keys.push_back({k.times[i], k.values[i], inType, outType, inVector, outVector});
        }
        try {
            return AnimCurve::build(std::move(keys), static_cast<Infinity>(k.settings.pre),
                                    static_cast<Infinity>(k.settings.post), k.settings.weighted);
        }
        catch (const Error& e) {
            throw e.in(fmt::format("node '{}'", c.nodeName()));
        }
    }

    bool timeDriven() const { return typeName_[9] == 'T'; }
    // The curve's settings, its keys aside.
    KeyInputs::Settings readSettings(const ComputeContext& c) const
    {
        return {c.getEnum(tangents), c.getEnum(preInfinity), c.getEnum(postInfinity), c.getBool(weightedTangents),
                timeDriven() ? c.getDouble(framesPerSecond) : 1.0};
    }

    std::string typeName_;
    double yScale_ = 1.0;  // file units (degrees) to internal ones
    AnimCurve curve_;
    KeyInputs inputs_;  // what curve_ was built from
    std::string file_, plug_;
    bool fromFile_ = false;  // curve_ holds the file's curve
};

// A YAML value as messages show it: 'text' for a scalar, else what it is (a list, a map, nothing).
std::string describe(const YAML::Node& node)
{
    if (node.IsScalar()) return fmt::format("'{}'", node.Scalar());
    if (node.IsSequence()) return fmt::format("a list of {}", node.size());
    if (node.IsMap()) return "a map";
    return "nothing";
}

// `keys: [[x, y], [x, y, tangent], [x, y, inTangent, outTangent], ...]`, y in the file's units.
std::vector<std::pair<AttrId, Value>> parseKeys(const YAML::Node& node, const YamlFieldContext& context, double yScale)
{
    if (!node.IsSequence())
        throw Error(
            fmt::format("{}: 'keys' is a list of [x, y] or [x, y, tangent] or [x, y, in, out]", context.where(node)));
    std::vector<double> xs, ys, ins, outs;
    for (const auto& key : node) {
        if (!key.IsSequence() || key.size() < 2 || key.size() > 4)
            throw Error(fmt::format("{}: a key is [x, y], [x, y, tangent] or [x, y, inTangent, outTangent]",
                                    context.where(key)));
        double xy[2] = {0, 0};
        for (std::size_t i = 0; i < 2; ++i)
            if (!YAML::convert<double>::decode(key[i], xy[i]) || !std::isfinite(xy[i]))
                throw Error(fmt::format("{}: key {} must be a finite number, got {}", context.where(key[i]),
                                        i == 0 ? "x" : "y", describe(key[i])));
        if (!xs.empty() && xy[0] <= xs.back())
            throw Error(
                fmt::format("{}: key x {} is not greater than the previous key's x {} (keys must be strictly "
                            "increasing)",
                            context.where(key[0]), xy[0], xs.back()));
        auto tangent = [&](const YAML::Node& t) {
            const auto type = t.IsScalar() ? tangentTypeFromName(t.Scalar()) : std::nullopt;
            if (!type) {
                std::string names;
                for (const auto& n : tangentNames()) names += (names.empty() ? "" : ", ") + n;
                throw Error(
                    fmt::format("{}: unknown tangent type {}; use one of {}", context.where(t), describe(t), names));
            }
            return static_cast<double>(*type);
        };
        xs.push_back(xy[0]);
        ys.push_back(xy[1] * yScale);
        ins.push_back(key.size() >= 3 ? tangent(key[2]) : -1.0);
        outs.push_back(key.size() == 4 ? tangent(key[3]) : key.size() == 3 ? ins.back() : -1.0);
    }
    return {{keyTime, xs}, {keyValue, ys}, {keyInTangent, ins}, {keyOutTangent, outs}};
}

// --- Maya ASCII (docs/maya.md): the attributes of Maya's animCurve node that are not one attribute here. ---

// Maya's tangent type codes in files (the animCurve node's keyTanInType enum) and what each is here.
struct MayaTangentCode {
    int code;
    const char* name;
    std::optional<TangentType> type;  // nullopt: not evaluated here
};
constexpr MayaTangentCode mayaTangentCodes[] = {
    {0, "global", std::nullopt},
    {1, "fixed", TangentType::fixed},
    {2, "linear", TangentType::linear},
    {3, "flat", TangentType::flat},
    {5, "step", TangentType::step},
    {6, "slow", std::nullopt},
    {7, "fast", std::nullopt},
    {9, "spline", TangentType::spline},
    {10, "clamped", TangentType::clamped},
    {16, "plateau", TangentType::plateau},
    {17, "stepnext", TangentType::stepNext},
    {18, "auto", TangentType::auto_},
    {27, "autoMix", std::nullopt},
    {28, "autoEase", std::nullopt},
    {29, "autoCustom", std::nullopt},
};

// Maya's infinity codes (MFnAnimCurve::InfinityType): 2 is unused.
constexpr std::pair<int, Infinity> mayaInfinityCodes[] = {{0, Infinity::constant},
                                                          {1, Infinity::linear},
                                                          {3, Infinity::cycle},
                                                          {4, Infinity::cycleRelative},
                                                          {5, Infinity::oscillate}};

using MayaValues = std::vector<std::pair<AttrId, Value>>;

double mayaNumber(const std::string& word, const char* what)
{
    if (const auto number = parseFiniteNumber(word)) return *number;
    throw Error(fmt::format("{}: '{}' is not a finite number", what, messageExcerpt(word)));
}

int mayaInteger(const std::string& word, const char* what)
{
    const double number = mayaNumber(word, what);
    if (number != std::floor(number) || std::abs(number) > 1e6)
        throw Error(fmt::format("{}: '{}' is not an integer", what, messageExcerpt(word)));
    return static_cast<int>(number);
}

TangentType mayaTangent(const std::string& word, const char* what)
{
    const int code = mayaInteger(word, what);
    for (const MayaTangentCode& entry : mayaTangentCodes) {
        if (entry.code != code) continue;
        if (entry.type) return *entry.type;
        throw Error(
            fmt::format("{}: tangent type {} ({}) is not evaluated by this reader; set the keys' tangents "
                        "to fixed, linear, flat, step, stepnext, spline, clamped, plateau or auto in Maya",
                        what, code, entry.name));
    }
    throw Error(fmt::format("{}: {} is not one of Maya's tangent type codes", what, code));
}

// The element range of a multi attribute's setAttr and its words, `per` words an element. An empty word list is
// a setAttr of flags only (-l on ".ktv[0]"): nothing to set.
std::vector<std::vector<std::string>> mayaElements(const MayaFieldInput& in, std::size_t per, const char* what)
{
    if (in.words.empty()) return {};
    if (in.first < 0 || in.last < in.first)
        throw Error(fmt::format("{}: give the keys' element range ({}[0:2])", what, what));
    const std::size_t count = static_cast<std::size_t>(in.last - in.first + 1);
    if (in.words.size() != count * per)
        throw Error(fmt::format("{}[{}:{}]: {} values for {} keys; give {} a key", what, in.first, in.last,
                                in.words.size(), count, per));
    std::vector<std::vector<std::string>> elements(count);
    for (std::size_t i = 0; i < in.words.size(); ++i) elements[i / per].push_back(in.words[i]);
    return elements;
}

// The array `a` as set so far, long enough for element `last` (`per` numbers an element), new elements `fill`.
std::vector<double> currentArray(const MayaFieldInput& in, AttrId a, double fill, std::size_t per = 1)
{
    std::vector<double> values = std::get<std::vector<double>>(in.current(a));
    const std::size_t size = per * (static_cast<std::size_t>(in.last) + 1);
    if (values.size() < size) values.resize(size, fill);
    return values;
}

// ".ktv[i:j]" x y x y ...: key times (frames) or driver values, and values in the scene's units.
MayaValues mayaKeyTimeValue(const MayaFieldInput& in, Unit outUnit)
{
    const auto elements = mayaElements(in, 2, ".ktv");
    if (elements.empty()) return {};
    const double yScale = outUnit == Unit::Distance ? in.linearToCm
                          : outUnit == Unit::Angle  ? in.angleToDegrees * std::numbers::pi / 180.0
                                                    : 1.0;
    std::vector<double> times = currentArray(in, keyTime, 0.0);
    std::vector<double> values = currentArray(in, keyValue, 0.0);
    for (std::size_t k = 0; k < elements.size(); ++k) {
        times[static_cast<std::size_t>(in.first) + k] = mayaNumber(elements[k][0], ".ktv");
        values[static_cast<std::size_t>(in.first) + k] = mayaNumber(elements[k][1], ".ktv") * yScale;
    }
    return {{keyTime, times}, {keyValue, values}};
}

// ".kit[i:j]" / ".kot[i:j]": tangent type codes. A fixed key gets a placeholder flat vector that ".kix"/".kiy"
// (which Maya writes after the types) replace; any other type clears the key's vector, since Maya also writes
// the vectors of keys whose tangents it computes (auto keys' stale ones among them) and those must not count.
MayaValues mayaTangentTypes(const MayaFieldInput& in, bool inSide)
{
    const char* what = inSide ? ".kit" : ".kot";
    const auto elements = mayaElements(in, 1, what);
    if (elements.empty()) return {};
    const AttrId typeAttr = inSide ? keyInTangent : keyOutTangent;
    std::vector<double> types = currentArray(in, typeAttr, -1.0);
    std::vector<double> vectors = currentArray(in, keyTangentVectors, notGiven, 4);
    for (std::size_t k = 0; k < elements.size(); ++k) {
        const std::size_t i = static_cast<std::size_t>(in.first) + k;
        const TangentType type = mayaTangent(elements[k][0], what);
        const bool fixed = type == TangentType::fixed;
        types[i] = fixed ? -1.0 : static_cast<double>(type);
        double& x = vectors[vectorIndex(i, inSide, true)];
        double& y = vectors[vectorIndex(i, inSide, false)];
        if (fixed && x == notGiven) std::tie(x, y) = std::pair{1.0, 0.0};
        if (!fixed) x = y = notGiven;
    }
    return {{typeAttr, types}, {keyTangentVectors, vectors}};
}

// ".kix" ".kiy" ".kox" ".koy": a fixed tangent's vector, x in seconds (time curves) or the driver's units, y in
// Maya's internal units (cm, radians), kept as Maya wrote them. Only fixed keys take them: a key is fixed when
// ".kit"/".kot" said so, or when it has no type of its own and the curve's ".tan" is fixed.
MayaValues mayaTangentVector(const MayaFieldInput& in, bool inSide, bool xPart)
{
    const char* what = inSide ? (xPart ? ".kix" : ".kiy") : (xPart ? ".kox" : ".koy");
    const auto elements = mayaElements(in, 1, what);
    if (elements.empty()) return {};
    const std::vector<double> types = currentArray(in, inSide ? keyInTangent : keyOutTangent, -1.0);
    const bool curveFixed = std::get<int>(in.current(tangents)) == static_cast<int>(TangentType::fixed);
    std::vector<double> vectors = currentArray(in, keyTangentVectors, notGiven, 4);
    for (std::size_t k = 0; k < elements.size(); ++k) {
        const std::size_t i = static_cast<std::size_t>(in.first) + k;
        const double value = mayaNumber(elements[k][0], what);
        if (vectors[vectorIndex(i, inSide, true)] != notGiven || (types[i] == -1.0 && curveFixed))
            vectors[vectorIndex(i, inSide, xPart)] = value;
    }
    return {{keyTangentVectors, vectors}};
}

MayaValues mayaInfinity(const MayaFieldInput& in, AttrId a, const char* what)
{
    if (in.words.size() != 1) throw Error(fmt::format("{}: give one infinity code", what));
    const int code = mayaInteger(in.words[0], what);
    for (const auto& [entry, mode] : mayaInfinityCodes)
        if (entry == code) return {{a, static_cast<int>(mode)}};
    throw Error(
        fmt::format("{}: {} is not one of Maya's infinity codes (0 constant, 1 linear, 3 cycle, 4 "
                    "cycleRelative, 5 oscillate)",
                    what, code));
}

void addMayaFields(NodeTypeBuilder& b, Unit outUnit)
{
    b.mayaField("keyTimeValue", "ktv", [outUnit](const MayaFieldInput& in) { return mayaKeyTimeValue(in, outUnit); });
    b.mayaField("keyTanInType", "kit", [](const MayaFieldInput& in) { return mayaTangentTypes(in, true); });
    b.mayaField("keyTanOutType", "kot", [](const MayaFieldInput& in) { return mayaTangentTypes(in, false); });
    b.mayaField("keyTanInX", "kix", [](const MayaFieldInput& in) { return mayaTangentVector(in, true, true); });
    b.mayaField("keyTanInY", "kiy", [](const MayaFieldInput& in) { return mayaTangentVector(in, true, false); });
    b.mayaField("keyTanOutX", "kox", [](const MayaFieldInput& in) { return mayaTangentVector(in, false, true); });
    b.mayaField("keyTanOutY", "koy", [](const MayaFieldInput& in) { return mayaTangentVector(in, false, false); });
    b.mayaField("tangentType", "tan", [](const MayaFieldInput& in) -> MayaValues {
        if (in.words.size() != 1) throw Error(".tan: give one tangent type code");
        return {{tangents, static_cast<int>(mayaTangent(in.words[0], ".tan"))}};
    });
    // Our preInfinity and postInfinity number the modes 0 to 4; Maya's codes skip 2.
    b.mayaField("preInfinity", "pre", [](const MayaFieldInput& in) { return mayaInfinity(in, preInfinity, ".pre"); });
    b.mayaField("postInfinity", "pst", [](const MayaFieldInput& in) { return mayaInfinity(in, postInfinity, ".pst"); });
    // Editing state that does not change the curve's values: tangent and weight locks, breakdown keys, the graph
    // editor's drawing. Read and dropped, so that a scene's statistics do not count them as unknown.
    const auto ignored = [](const MayaFieldInput&) { return MayaValues{}; };
    for (const auto& [longName, shortName] : {std::pair{"keyTanLocked", "ktl"}, std::pair{"keyWeightLocked", "kwl"},
                                              std::pair{"keyBreakdown", "kbd"}, std::pair{"keyTickDrawSpecial", "ktd"}})
        b.mayaField(longName, shortName, ignored);
}

}  // namespace

int mayaTangentCode(TangentType type)
{
    for (const MayaTangentCode& entry : mayaTangentCodes)
        if (entry.type == type) return entry.code;
    throw internalError(fmt::format("no Maya code for tangent type {}", tangentTypeName(type)));
}

std::shared_ptr<const NodeType> makeAnimCurveType(const char* typeName)
{
    const std::string name(typeName);
    if (name.size() != 11 || !name.starts_with("animCurve")) throw internalError("not an animCurve type: " + name);
    const bool timeDriven = name[9] == 'T';
    const Unit outUnit = name[10] == 'A'   ? Unit::Angle
                         : name[10] == 'L' ? Unit::Distance
                         : name[10] == 'T' ? Unit::Time
                                           : Unit::None;
    const double yScale = unitFactor(Unit::None, outUnit);

    NodeTypeBuilder b(name);
    b.description(fmt::format(
        "An animation curve as Maya's {}: output = curve(input), keys with Maya's tangent "
        "types (docs/nodes.md gives each rule). Driven by {}; output is {}.",
        name,
        timeDriven ? "time in frames (the scene time unless input is connected)" : "any number (a set-driven key)",
        outUnit == Unit::Angle      ? "an angle (keys in degrees)"
        : outUnit == Unit::Distance ? "a distance (cm)"
        : outUnit == Unit::Time     ? "a time (frames)"
                                    : "unitless"));
    auto in = b.input(input, "input", ValueType::Double)
                  .shortName("i")
                  .doc(timeDriven ? "Time, frames." : "The driver's value.");
    if (timeDriven) in.unit(Unit::Time).sceneTime();
    b.input(keyTime, "keyTime", ValueType::DoubleArray).doc("Key x values, strictly increasing (set with `keys:`).");
    b.input(keyValue, "keyValue", ValueType::DoubleArray).unit(outUnit).doc("Key y values (set with `keys:`).");
    b.input(keyInTangent, "keyInTangent", ValueType::DoubleArray)
        .doc("Per-key in-tangent type index, -1 for `tangents` (set with `keys:`).");
    b.input(keyOutTangent, "keyOutTangent", ValueType::DoubleArray)
        .doc("Per-key out-tangent type index, -1 for `tangents` (set with `keys:`).");
    b.input(tangents, "tangents", ValueType::Enum)
        .enumNames(tangentNames(tangentTypeCount))
        .defaultValue(static_cast<int>(TangentType::auto_))
        .doc("Tangent type of keys that do not name one (fixed: their vector, flat without one).");
    b.input(preInfinity, "preInfinity", ValueType::Enum).enumNames(infinityNames()).doc("Before the first key.");
    b.input(postInfinity, "postInfinity", ValueType::Enum).enumNames(infinityNames()).doc("After the last key.");
    const std::string vectorDoc = fmt::format(
        "as Maya stores them: x in {}, y in the output's internal units ({}). A key whose x is > 0 here has a "
        "fixed tangent on that side, whatever its type index; 0 or no element: none.",
        timeDriven ? "seconds (framesPerSecond turns it into frames)" : "the driver's units",
        outUnit == Unit::Angle      ? "radians"
        : outUnit == Unit::Distance ? "cm"
                                    : "as keyValue");
    b.input(keyTangentVectors, "keyTangentVectors", ValueType::DoubleArray)
        .doc("Fixed tangents' vectors, four numbers a key (in x, in y, out x, out y), " + vectorDoc);
    b.input(weightedTangents, "weightedTangents", ValueType::Bool)
        .shortName("wgt")
        .doc("Maya's weighted tangents: a fixed tangent's length bends its segment (a Bezier in x and y).");
    b.input(animFile, "animFile", ValueType::String)
        .filePath()
        .doc(
            "A Maya .anim file to take the keys, tangents and infinities from instead of `keys:` "
            "(docs/keys-anim-report.md); in a rig file a relative path is read from the rig file's folder.");
    b.input(animPlug, "animPlug", ValueType::String)
        .doc(
            "The plug whose curve in animFile this node plays, NODE.ATTRIBUTE as the file's anim lines name it "
            "(e.g. L_arm_fk_ctrl.rotateX).");
    b.output(output, "output", ValueType::Double).shortName("o").unit(outUnit).doc("The curve's value at input.");
    if (timeDriven)
        b.input(framesPerSecond, "framesPerSecond", ValueType::Double)
            .defaultValue(24.0)
            .min(1e-6)
            .doc("The scene's frame rate: fixed tangents' x values are in seconds.");
    b.affectsAll();
    addMayaFields(b, outUnit);
    b.yamlField("keys", [yScale](const YAML::Node& node, const YamlFieldContext& context) {
        return parseKeys(node, context, yScale);
    });
    return b.factory([name, yScale] { return std::unique_ptr<Node>(std::make_unique<AnimCurveNode>(name, yScale)); })
        .build();
}

}  // namespace rig

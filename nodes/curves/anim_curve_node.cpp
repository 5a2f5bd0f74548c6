// animCurveTU/TA/TL/UU/UA/UL: Maya's animation curves and set-driven keys. T curves are driven by
// time (in frames; the scene time when `input` is unconnected), U curves by any number; U, A and L
// outputs are unitless, angles and distances. Keys come from `keys:` in a rig file, or from a curve of a
// Maya .anim file (animFile and animPlug; nodes/curves/anim_file.h).
#include <cmath>
#include <optional>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"
#include "nodes/anim_curve_math.h"
#include "nodes/builtin_nodes.h"
#include "nodes/curves/anim_file.h"

namespace rig {
namespace {

enum Attr : AttrId {
    input,
    keyTime,
    keyValue,
    keyInTangent,
    keyOutTangent,
    tangents,
    preInfinity,
    postInfinity,
    animFile,
    animPlug,
    output
};

constexpr int tangentTypeCount = 8;
constexpr int infinityCount = 5;

std::vector<std::string> tangentNames()
{
    std::vector<std::string> names;
    for (int i = 0; i < tangentTypeCount; ++i) names.emplace_back(tangentTypeName(static_cast<TangentType>(i)));
    return names;
}

std::vector<std::string> infinityNames()
{
    std::vector<std::string> names;
    for (int i = 0; i < infinityCount; ++i) names.emplace_back(infinityName(static_cast<Infinity>(i)));
    return names;
}

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
            fallback_ = -1;  // rebuilt from the keys below
        }
        const auto& times = c.getDoubleArray(keyTime);
        const auto& values = c.getDoubleArray(keyValue);
        const auto& ins = c.getDoubleArray(keyInTangent);
        const auto& outs = c.getDoubleArray(keyOutTangent);
        const int fallback = c.getEnum(tangents);
        const int pre = c.getEnum(preInfinity);
        const int post = c.getEnum(postInfinity);
        // Rebuilding the curve costs more than comparing its keys, and the input changes every frame.
        if (times != times_ || values != values_ || ins != ins_ || outs != outs_ || fallback != fallback_ ||
            pre != pre_ || post != post_) {
            curve_ = build(c, times, values, ins, outs, fallback, pre, post);
            times_ = times;
            values_ = values;
            ins_ = ins;
            outs_ = outs;
            fallback_ = fallback;
            pre_ = pre;
            post_ = post;
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

    static AnimCurve build(const ComputeContext& c, const std::vector<double>& times, const std::vector<double>& values,
                           const std::vector<double>& ins, const std::vector<double>& outs, int fallback, int pre,
                           int post)
    {
        if (times.size() != values.size())
            throw Error(fmt::format("node '{}': keyTime has {} values but keyValue has {}; give one value per key",
                                    c.nodeName(), times.size(), values.size()));
        auto tangent = [&](const std::vector<double>& types, std::size_t i, const char* what) {
            const double t = i < types.size() ? types[i] : -1.0;
            if (t == -1.0) return static_cast<TangentType>(fallback);
            if (t != std::floor(t) || t < 0 || t >= tangentTypeCount)
                throw Error(
                    fmt::format("node '{}': {}[{}] = {} is not a tangent type index", c.nodeName(), what, i, t));
            return static_cast<TangentType>(static_cast<int>(t));
        };
        std::vector<AnimKey> keys;
        for (std::size_t i = 0; i < times.size(); ++i)
            keys.push_back({times[i], values[i], tangent(ins, i, "keyInTangent"), tangent(outs, i, "keyOutTangent")});
        try {
            return AnimCurve::build(std::move(keys), static_cast<Infinity>(pre), static_cast<Infinity>(post));
        }
        catch (const Error& e) {
            throw e.in(fmt::format("node '{}'", c.nodeName()));
        }
    }

    std::string typeName_;
    double yScale_ = 1.0;  // file units (degrees) to internal ones
    AnimCurve curve_;
    std::vector<double> times_, values_, ins_, outs_;
    int fallback_ = -1, pre_ = -1, post_ = -1;
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

}  // namespace

std::shared_ptr<const NodeType> makeAnimCurveType(const char* typeName)
{
    const std::string name(typeName);
    if (name.size() != 11 || !name.starts_with("animCurve")) throw internalError("not an animCurve type: " + name);
    const bool timeDriven = name[9] == 'T';
    const Unit outUnit = name[10] == 'A' ? Unit::Angle : name[10] == 'L' ? Unit::Distance : Unit::None;
    const double yScale = unitFactor(Unit::None, outUnit);

    NodeTypeBuilder b(name);
    b.description(fmt::format(
        "An animation curve as Maya's {}: output = curve(input), keys with Maya's tangent "
        "types (docs/nodes.md gives each rule). Driven by {}; output is {}.",
        name,
        timeDriven ? "time in frames (the scene time unless input is connected)" : "any number (a set-driven key)",
        outUnit == Unit::Angle      ? "an angle (keys in degrees)"
        : outUnit == Unit::Distance ? "a distance (cm)"
                                    : "unitless"));
    auto in = b.input(input, "input", ValueType::Double).doc(timeDriven ? "Time, frames." : "The driver's value.");
    if (timeDriven) in.unit(Unit::Time).sceneTime();
    b.input(keyTime, "keyTime", ValueType::DoubleArray).doc("Key x values, strictly increasing (set with `keys:`).");
    b.input(keyValue, "keyValue", ValueType::DoubleArray).unit(outUnit).doc("Key y values (set with `keys:`).");
    b.input(keyInTangent, "keyInTangent", ValueType::DoubleArray)
        .doc("Per-key in-tangent type index, -1 for `tangents` (set with `keys:`).");
    b.input(keyOutTangent, "keyOutTangent", ValueType::DoubleArray)
        .doc("Per-key out-tangent type index, -1 for `tangents` (set with `keys:`).");
    b.input(tangents, "tangents", ValueType::Enum)
        .enumNames(tangentNames())
        .defaultValue(static_cast<int>(TangentType::auto_))
        .doc("Tangent type of keys that do not name one.");
    b.input(preInfinity, "preInfinity", ValueType::Enum).enumNames(infinityNames()).doc("Before the first key.");
    b.input(postInfinity, "postInfinity", ValueType::Enum).enumNames(infinityNames()).doc("After the last key.");
    b.input(animFile, "animFile", ValueType::String)
        .filePath()
        .doc(
            "A Maya .anim file to take the keys, tangents and infinities from instead of `keys:` "
            "(docs/keys-anim-report.md); in a rig file a relative path is read from the rig file's folder.");
    b.input(animPlug, "animPlug", ValueType::String)
        .doc(
            "The plug whose curve in animFile this node plays, NODE.ATTRIBUTE as the file's anim lines name it "
            "(e.g. L_arm_fk_ctrl.rotateX).");
    b.output(output, "output", ValueType::Double).unit(outUnit).doc("The curve's value at input.");
    b.affectsAll();
    b.yamlField("keys", [yScale](const YAML::Node& node, const YamlFieldContext& context) {
        return parseKeys(node, context, yScale);
    });
    return b.factory([name, yScale] { return std::unique_ptr<Node>(std::make_unique<AnimCurveNode>(name, yScale)); })
        .build();
}

}  // namespace rig

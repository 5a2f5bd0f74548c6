#include "inversion/model/approximation_io.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include "core/error.h"

namespace rig {
namespace {

// ---- writing ------------------------------------------------------------------------------------

// The shortest text that reads back to the same double; refuses what YAML readers would not read
// back as a number.
std::string number(double x, std::string_view field)
{
    if (!std::isfinite(x))
        throw internalError(fmt::format("approximationToYaml: {} is {}, not a finite number", field, x));
    return fmt::format("{}", x);
}

// A YAML double-quoted string: names and reasons may hold ':', '#', quotes or anything else.
std::string yamlString(std::string_view s)
{
    std::string out = "\"";
    for (const char c : s) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"' || c == '\\') (out += '\\') += c;
        else if (c == '\n') out += "\\n";
        else if (c == '\t') out += "\\t";
        else if (u < 0x20 || u == 0x7f) out += fmt::format("\\x{:02x}", u);
        else out += c;
    }
    return out + "\"";
}

template <class Range, class F>
std::string list(const Range& range, F&& item)
{
    std::string out = "[";
    bool first = true;
    for (const auto& x : range) {
        out += (first ? "" : ", ") + item(x);
        first = false;
    }
    return out + "]";
}

std::string vector3(const Eigen::Vector3d& v, std::string_view field)
{
    return fmt::format("[{}, {}, {}]", number(v.x(), field), number(v.y(), field), number(v.z(), field));
}

template <int D>
std::string splineValues(const CubicSpline<D>& spline, std::string_view field)
{
    return list(spline.values(), [&](const typename CubicSpline<D>::Vector& v) {
        if constexpr (D == 1) return number(v[0], field);
        else {
            std::vector<double> entries(v.data(), v.data() + D);
            return list(entries, [&](double x) { return number(x, field); });
        }
    });
}

std::string parameterFields(const RigParameter& p, const std::string& field, std::string_view indent)
{
    return fmt::format("{0}name: {1}\n{0}default: {2}\n{0}min: {3}\n{0}max: {4}\n{0}limited: {5}\n{0}angular: {6}\n",
                       indent, yamlString(p.name), number(p.defaultValue, field + ".default"),
                       number(p.min, field + ".min"), number(p.max, field + ".max"), p.limited ? "true" : "false",
                       p.angular ? "true" : "false");
}

// `held: [low, high]`: offsets beyond which the operator is held; an open end is null.
std::string heldText(const Operator& op, const std::string& field, std::string_view indent)
{
    auto end = [&](double x) { return std::isfinite(x) ? number(x, field + ".held") : std::string("null"); };
    return fmt::format("{}held: [{}, {}]\n", indent, end(op.low), end(op.high));
}

// An operator's fields, the first line starting with `first` (a list item's "- ", or a field's indent) and the
// others with `indent`: a parameter's operators and a constraint's shape are written alike.
std::string operatorText(const Operator& op, const std::string& field, std::string_view first = "      - ",
                         std::string_view indent = "        ")
{
    std::string out = fmt::format("{}kind: {}\n", first, operatorKindName(op.kind));
    if (!op.traits().sampled) {
        out += fmt::format("{}axis: {}\n{}pivot: {}\n", indent, vector3(op.axis, field + ".axis"), indent,
                           vector3(op.pivot, field + ".pivot"));
        if (op.held()) out += heldText(op, field, indent);
        if (op.linear()) out += fmt::format("{}slope: {}\n", indent, number(op.slope, field + ".slope"));
        else
            out += fmt::format("{0}curve:\n{0}  knots: {1}\n{0}  values: {2}\n", indent,
                               list(op.curve.knots(), [&](double x) { return number(x, field + ".curve.knots"); }),
                               splineValues(op.curve, field + ".curve.values"));
    } else {
        const auto& knots = op.kind == OperatorKind::sampledRigid ? op.rigid.knots() : op.affine.knots();
        if (op.held()) out += heldText(op, field, indent);
        if (knots.empty()) throw internalError(fmt::format("approximationToYaml: {} has no knots", field));
        out += fmt::format("{}knots: {}\n", indent, list(knots, [&](double x) { return number(x, field + ".knots"); }));
        out += fmt::format("{}values: {}\n", indent,
                           op.kind == OperatorKind::sampledRigid ? splineValues(op.rigid, field + ".values")
                                                                 : splineValues(op.affine, field + ".values"));
    }
    return out;
}

// The comment lines, the rig, epsilon, the held plugs and the training and validation figures.
std::string headerText(const Approximation& a)
{
    std::string out = "# A learned rig approximation (docs/approximation-format.md), written by rig-learn.\n";
    out += "# Internal units: radians for angles, centimetres for distances. Numbers read back bit for bit.\n";
    out += fmt::format("format: {}\nversion: {}\n", approximationFormatName, approximationFormatVersion);
    out += fmt::format("rigFile: {}\nrigFingerprint: {}\nepsilon: {}\n", yamlString(a.rigFile),
                       yamlString(a.rigFingerprint), number(a.epsilon, "epsilon"));
    if (!a.held.empty()) out += "held:  # plugs held at a value while learning, in the rig file's units\n";
    for (std::size_t h = 0; h < a.held.size(); ++h)
        out += fmt::format("  - plug: {}\n    value: {}\n", yamlString(a.held[h].plug),
                           number(a.held[h].value, fmt::format("held[{}].value", h)));
    const TrainingSummary& t = a.training;
    out += fmt::format("training:\n  evaluations: {}\n  orderEvaluations: {}\n  seconds: {}\n  orderer: {}\n",
                       t.evaluations, t.orderEvaluations, number(t.seconds, "training.seconds"), yamlString(t.orderer));
    const ValidationSummary& v = a.validation;
    out += fmt::format(
        "validation:\n  poses: {}\n  maxPositionErrorCm: {}\n  meanPositionErrorCm: {}\n"
        "  maxRotationErrorDeg: {}\n  meanRotationErrorDeg: {}\n  worstOutput: {}\n  worstPose: {}\n",
        v.poses, number(v.maxPositionErrorCm, "validation.maxPositionErrorCm"),
        number(v.meanPositionErrorCm, "validation.meanPositionErrorCm"),
        number(v.maxRotationErrorDeg, "validation.maxRotationErrorDeg"),
        number(v.meanRotationErrorDeg, "validation.meanRotationErrorDeg"), yamlString(v.worstOutput), v.worstPose);
    out += fmt::format(
        "  maxRelativeError: {}\n  worstRelativeOutput: {}\n  worstParameter: {}\n  nonFinitePoses: {}\n"
        "  withinEpsilon: {}\n",
        number(v.maxRelativeError, "validation.maxRelativeError"), yamlString(v.worstRelativeOutput),
        yamlString(v.worstParameter), v.nonFinitePoses, v.withinEpsilon);
    if (v.singularPoses > 0)
        out +=
            fmt::format("  singularPoses: {}\n  singularOutput: {}\n", v.singularPoses, yamlString(v.singularOutput));
    return out;
}

std::string outputsText(const Approximation& a)
{
    std::string out = a.outputs.empty() ? "outputs: []\n" : "outputs:\n";
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        const std::string field = fmt::format("outputs[{}].rest", k);
        const ApproximationOutput& o = a.outputs[k];
        out += fmt::format("  - name: {}\n", yamlString(o.name));
        if (o.parent >= 0) {
            if (static_cast<std::size_t>(o.parent) >= a.outputs.size())
                throw internalError(
                    fmt::format("approximationToYaml: outputs[{}].parent: index {} out of range", k, o.parent));
            out += fmt::format("    parent: {}\n", yamlString(a.outputs[static_cast<std::size_t>(o.parent)].name));
        }
        if (o.constraint >= 0) {
            if (static_cast<std::size_t>(o.constraint) >= a.constraints.size())
                throw internalError(
                    fmt::format("approximationToYaml: outputs[{}].constraint: index {} out of range", k, o.constraint));
            out += fmt::format("    constraint: {}\n", o.constraint);
        }
        if (o.helper) out += "    helper: true  # read by constraints, never a target\n";
        if (!o.modelled) out += "    modelled: false  # non-compositional: fitted on the real rig only\n";
        out += fmt::format("    validationError: {}\n    rest: [",
                           number(o.validationError, fmt::format("outputs[{}].validationError", k)));
        for (int r = 0; r < 4; ++r) {
            Eigen::Vector4d row = a.outputs[k].rest.row(r).transpose();
            out += fmt::format("{}[{}, {}, {}, {}]", r ? ", " : "", number(row[0], field), number(row[1], field),
                               number(row[2], field), number(row[3], field));
        }
        out += "]\n";
    }
    return out;
}

// A blend's weight (a parameter, by name) and its rule.
std::string blendText(const Approximation& a, const ConstraintBase& base, const std::string& field)
{
    if (base.weight < 0 || static_cast<std::size_t>(base.weight) >= a.parameters.size())
        throw internalError(fmt::format("approximationToYaml: {}.weight: index {} out of range", field, base.weight));
    std::string out = fmt::format("    weight: {}\n    mode: {}\n",
                                  yamlString(a.parameters[static_cast<std::size_t>(base.weight)].parameter.name),
                                  blendModeName(base.blend.mode));
    if (base.blend.mode == BlendMode::eulerChannels)
        out += fmt::format("    order: {}\n", rotateOrderName(base.blend.order));
    return out;
}

// The constraint operators, their inputs by output name; what `ConstraintBase::prepare` derives is not written.
std::string constraintsText(const Approximation& a)
{
    if (a.constraints.empty()) return {};
    std::string out = "constraints:  # constraint operators, indexed by the outputs' `constraint`\n";
    for (std::size_t c = 0; c < a.constraints.size(); ++c) {
        const ConstraintBase& base = a.constraints[c];
        const std::string field = fmt::format("constraints[{}]", c);
        const auto input = [&](std::string_view which, int k, bool optional) -> std::string {
            if (optional && k < 0) return {};
            if (k < 0 || static_cast<std::size_t>(k) >= a.outputs.size())
                throw internalError(fmt::format("approximationToYaml: {}.{}: index {} out of range", field, which, k));
            return fmt::format("    {}: {}\n", which, yamlString(a.outputs[static_cast<std::size_t>(k)].name));
        };
        out += fmt::format("  - kind: {}\n", constraintKindName(base.kind));
        if (base.kind == ConstraintKind::blend) {
            out += input("anchor", base.anchor, true) + input("ik", base.ik, false) + input("fk", base.fk, false) +
                   input("ikParent", base.ikParent, true) + input("fkParent", base.fkParent, true);
            out += blendText(a, base, field);
            continue;
        }
        if (base.kind == ConstraintKind::twistShare) {
            out += input("anchor", base.anchor, true) + input("driver", base.driver, false) +
                   input("driverParent", base.driverParent, true);
            out += fmt::format(
                "    root: {}\n    axis: {}\n    twistAxis: {}\n    readOrder: {}\n    twistOrder: {}\n"
                "    share: {}\n",
                vector3(base.root, field + ".root"), vector3(base.axis, field + ".axis"), "xyz"[base.twistAxis],
                rotateOrderName(base.readOrder), rotateOrderName(base.twistOrder),
                number(base.share, field + ".share"));
            continue;
        }
        if (base.shape.kind != OperatorKind::sampledRigid)
            throw internalError(fmt::format("approximationToYaml: {}.shape is {}, not sampledRigid", field,
                                            operatorKindName(base.shape.kind)));
        out += input("anchor", base.anchor, true) + input("goal", base.goal, false) + input("pole", base.pole, true);
        out += fmt::format("    root: {}\n    restPole: {}\n", vector3(base.root, field + ".root"),
                           vector3(base.restPole, field + ".restPole"));
        // A chain without a pole keeps its rest plane: its normal is written, and says so.
        if (base.restPlane) out += fmt::format("    restNormal: {}\n", vector3(base.restNormal, field + ".restNormal"));
        if (base.worldUp) out += "    worldUp: true\n";
        // An output turning as another does: that output, and the rest origin the chain carries.
        if (base.orient >= 0)
            out += input("orient", base.orient, false) +
                   fmt::format("    origin: {}\n", vector3(base.origin, field + ".origin"));
        out += "    shape:\n";
        out += operatorText(base.shape, field + ".shape", "      ", "      ");
    }
    return out;
}

// Parameter p with its operators.
std::string parameterText(const Approximation& a, std::size_t p)
{
    const ModelledParameter& m = a.parameters[p];
    const std::string field = fmt::format("parameters[{}]", p);
    std::string out = parameterFields(m.parameter, field, "    ");
    out.replace(0, 4, "  - ");
    out += fmt::format("    form: {}\n    fitError: {}\n    samples: {}\n    validationError: {}\n", yamlString(m.form),
                       number(m.fitError, field + ".fitError"), m.samples,
                       number(m.validationError, field + ".validationError"));
    if (!m.noEffect.empty())
        out += "    noEffect: " +
               list(m.noEffect,
                    [&](const std::pair<double, double>& r) {
                        return fmt::format("[{}, {}]", number(r.first, field + ".noEffect"),
                                           number(r.second, field + ".noEffect"));
                    }) +
               "\n";
    if (m.outputs.size() != m.operatorOfOutput.size())
        throw internalError(fmt::format("approximationToYaml: {}: {} outputs but {} operator indices", field,
                                        m.outputs.size(), m.operatorOfOutput.size()));
    const auto outputNames = [&](const std::vector<int>& outputs, const std::string& which) {
        return list(outputs, [&](int k) {
            if (k < 0 || static_cast<std::size_t>(k) >= a.outputs.size())
                throw internalError(fmt::format("approximationToYaml: {}.{}: index {} out of range", field, which, k));
            return yamlString(a.outputs[static_cast<std::size_t>(k)].name);
        });
    };
    out += "    outputs: " + outputNames(m.outputs, "outputs") + "\n";
    if (!m.unmodelledOutputs.empty())
        out += "    unmodelledOutputs: " + outputNames(m.unmodelledOutputs, "unmodelledOutputs") + "\n";
    out += "    operatorOfOutput: " +
           list(m.operatorOfOutput,
                [&](int o) {
                    if (o < 0 || static_cast<std::size_t>(o) >= m.operators.size())
                        throw internalError(
                            fmt::format("approximationToYaml: {}.operatorOfOutput: index {} out of range", field, o));
                    return fmt::format("{}", o);
                }) +
           "\n";
    out += m.operators.empty() ? "    operators: []\n" : "    operators:\n";
    for (std::size_t o = 0; o < m.operators.size(); ++o)
        out += operatorText(m.operators[o], fmt::format("{}.operators[{}]", field, o));
    return out;
}

// What the learner left out: dropped outputs and discarded parameters.
std::string setAsideText(const Approximation& a)
{
    std::string out;
    if (!a.droppedOutputs.empty()) {
        out += "droppedOutputs:\n";
        for (const DroppedOutput& d : a.droppedOutputs)
            out += fmt::format("  - name: {}\n    reason: {}\n", yamlString(d.name), yamlString(d.reason));
    }
    out += a.discarded.empty() ? "discarded: []\n" : "discarded:\n";
    for (std::size_t d = 0; d < a.discarded.size(); ++d) {
        std::string fields = parameterFields(a.discarded[d].parameter, fmt::format("discarded[{}]", d), "    ");
        fields.replace(0, 4, "  - ");
        out += fields + fmt::format("    reason: {}\n", yamlString(a.discarded[d].reason));
    }
    return out;
}

// ---- reading ------------------------------------------------------------------------------------

class Reader {
public:
    explicit Reader(std::string fileName) : file_(std::move(fileName)) {}

    [[noreturn]] void fail(const YAML::Node& at, std::string_view field, std::string_view what) const
    {
        const YAML::Mark mark = at.Mark();
        if (mark.line < 0) throw Error(fmt::format("{}: {}: {}", file_, field, what));
        throw Error(fmt::format("{}:{}:{}: {}: {}", file_, mark.line + 1, mark.column + 1, field, what));
    }

    // A map with exactly these keys (those in `optional` may be missing).
    void checkKeys(const YAML::Node& map, std::string_view field, std::initializer_list<std::string_view> required,
                   std::initializer_list<std::string_view> optional = {}) const
    {
        if (!map.IsMap()) fail(map, field, "expected a map of fields");
        std::string known;
        for (auto k : required) known += fmt::format("{}{}", known.empty() ? "" : ", ", k);
        for (auto k : optional) known += fmt::format("{}{}", known.empty() ? "" : ", ", k);
        for (const auto& kv : map) {
            const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : std::string();
            const bool ok = std::find(required.begin(), required.end(), key) != required.end() ||
                            std::find(optional.begin(), optional.end(), key) != optional.end();
            if (!ok) fail(kv.first, field, fmt::format("unknown field '{}'; the fields are {}", key, known));
        }
        // At the top of the file, a missing field is most often a file cut short or edited by hand.
        for (auto k : required)
            if (!map[std::string(k)])
                fail(map, field,
                     fmt::format("the field '{}' is missing{}", k,
                                 field == "file"
                                     ? "; the file is incomplete (cut short?) or was edited: re-run rig-learn"
                                     : ""));
    }

    YAML::Node child(const YAML::Node& map, std::string_view key) const { return map[std::string(key)]; }

    // A field that must be there (before checkKeys has looked, or where it cannot).
    YAML::Node need(const YAML::Node& map, std::string_view key, std::string_view field) const
    {
        if (!map.IsMap()) fail(map, field, "expected a map of fields");
        YAML::Node n = map[std::string(key)];
        if (!n) fail(map, field, fmt::format("the field '{}' is missing", key));
        return n;
    }

    double real(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a number");
        const std::string& text = n.Scalar();
        double x = 0.0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        if (text.empty() || ec != std::errc() || end != text.data() + text.size())
            fail(n, field, fmt::format("'{}' is not a number", text));
        if (!std::isfinite(x)) fail(n, field, fmt::format("'{}' is not a finite number", text));
        return x;
    }

    template <class Int>
    Int integer(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a whole number");
        const std::string& text = n.Scalar();
        Int x = 0;
        const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
        if (ec == std::errc::result_out_of_range && end == text.data() + text.size())
            fail(n, field,
                 fmt::format("{} is out of range ({} to {})", text, std::numeric_limits<Int>::min(),
                             std::numeric_limits<Int>::max()));
        if (text.empty() || ec != std::errc() || end != text.data() + text.size())
            fail(n, field, fmt::format("'{}' is not a whole number", text));
        return x;
    }

    // A count, an error or a time: a number that cannot be below zero (from `least`).
    template <class Int>
    Int count(const YAML::Node& n, std::string_view field, Int least = 0) const
    {
        const Int x = integer<Int>(n, field);
        if (x < least) fail(n, field, fmt::format("{} is below {}; a count is not negative", x, least));
        return x;
    }
    double nonNegative(const YAML::Node& n, std::string_view field) const
    {
        const double x = real(n, field);
        if (x < 0) fail(n, field, fmt::format("{} is negative; errors and times are not", x));
        return x;
    }

    bool boolean(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar() || (n.Scalar() != "true" && n.Scalar() != "false")) fail(n, field, "expected true or false");
        return n.Scalar() == "true";
    }

    std::string text(const YAML::Node& n, std::string_view field) const
    {
        if (!n.IsScalar()) fail(n, field, "expected a string");
        return n.Scalar();
    }

    // A node by value (a handle): `for (x : sequence(map["key"], ...))` must not hold a reference to the
    // temporary map["key"], which dies before the loop runs.
    YAML::Node sequence(const YAML::Node& n, std::string_view field, std::size_t size = 0) const
    {
        if (!n.IsSequence()) fail(n, field, size ? fmt::format("expected a list of {}", size) : "expected a list");
        if (size && n.size() != size) fail(n, field, fmt::format("expected {} entries, found {}", size, n.size()));
        return n;
    }

    std::vector<double> reals(const YAML::Node& n, const std::string& field, std::size_t size = 0) const
    {
        std::vector<double> out;
        for (const auto& x : sequence(n, field, size)) out.push_back(real(x, field));
        return out;
    }

    Eigen::Vector3d vector3(const YAML::Node& n, const std::string& field) const
    {
        const auto v = reals(n, field, 3);
        return {v[0], v[1], v[2]};
    }

    template <int D>
    CubicSpline<D> spline(const YAML::Node& knotsNode, const YAML::Node& valuesNode, const std::string& field) const
    {
        const std::vector<double> knots = reals(knotsNode, field + ".knots");
        sequence(valuesNode, field + ".values");
        if (knots.size() < 2) fail(knotsNode, field + ".knots", "a curve needs at least two knots");
        if (valuesNode.size() != knots.size())
            fail(valuesNode, field + ".values", fmt::format("{} values for {} knots", valuesNode.size(), knots.size()));
        for (std::size_t j = 1; j < knots.size(); ++j)
            if (!(knots[j] > knots[j - 1])) fail(knotsNode, field + ".knots", "the knots must increase");
        std::vector<typename CubicSpline<D>::Vector> values;
        for (const auto& v : valuesNode) {
            typename CubicSpline<D>::Vector y;
            if constexpr (D == 1) y[0] = real(v, field + ".values");
            else {
                const auto entries = reals(v, field + ".values", D);
                for (int d = 0; d < D; ++d) y[d] = entries[static_cast<std::size_t>(d)];
            }
            values.push_back(y);
        }
        return CubicSpline<D>(knots, std::move(values));
    }

    RigParameter parameter(const YAML::Node& n, const std::string& field) const
    {
        RigParameter p;
        p.name = text(child(n, "name"), field + ".name");
        if (p.name.empty()) fail(child(n, "name"), field + ".name", "a parameter needs a name");
        p.defaultValue = real(child(n, "default"), field + ".default");
        p.min = real(child(n, "min"), field + ".min");
        p.max = real(child(n, "max"), field + ".max");
        p.limited = boolean(child(n, "limited"), field + ".limited");
        p.angular = boolean(child(n, "angular"), field + ".angular");
        if (!(p.min <= p.defaultValue && p.defaultValue <= p.max))
            fail(n, field, fmt::format("the default {} is not within min {} and max {}", p.defaultValue, p.min, p.max));
        return p;
    }

    Operator op(const YAML::Node& n, const std::string& field) const
    {
        const std::string kindName = text(need(n, "kind", field), field + ".kind");
        const auto kind = operatorKindFromName(kindName);
        if (!kind) {
            std::string names;
            for (const OperatorKindTraits& t : operatorKindTraits)
                names += fmt::format("{}{}", names.empty() ? "" : ", ", t.name);
            fail(need(n, "kind", field), field + ".kind",
                 fmt::format("unknown operator '{}'; the operators are {}", kindName, names));
        }
        Operator op;
        op.kind = *kind;
        if (const YAML::Node held = child(n, "held")) {
            const YAML::Node ends = sequence(held, field + ".held", 2);
            auto end = [&](const YAML::Node& e, double open) {
                return e.IsNull() || (e.IsScalar() && e.Scalar() == "null") ? open : real(e, field + ".held");
            };
            op.low = end(ends[0], -std::numeric_limits<double>::infinity());
            op.high = end(ends[1], std::numeric_limits<double>::infinity());
            if (!(op.low <= 0.0 && 0.0 <= op.high))
                fail(held, field + ".held", "expected [low, high] with low <= 0 <= high");
        }
        if (op.traits().sampled) {
            checkKeys(n, field, {"kind", "knots", "values"}, {"held"});
            if (op.kind == OperatorKind::sampledRigid)
                op.rigid = spline<6>(child(n, "knots"), child(n, "values"), field);
            else op.affine = spline<12>(child(n, "knots"), child(n, "values"), field);
            return op;
        }
        checkKeys(n, field, {"kind", "axis", "pivot"}, {"slope", "curve", "held"});
        if (!child(n, "slope") == !child(n, "curve")) fail(n, field, "give either slope (linear) or curve, not both");
        op.axis = vector3(child(n, "axis"), field + ".axis");
        // Axes are unit vectors up to rounding; anything else is a damaged file.
        if (std::abs(op.axis.norm() - 1.0) > 1e-9) fail(child(n, "axis"), field + ".axis", "not a unit vector");
        op.pivot = vector3(child(n, "pivot"), field + ".pivot");
        if (child(n, "slope")) op.slope = real(child(n, "slope"), field + ".slope");
        else {
            const YAML::Node curve = child(n, "curve");
            checkKeys(curve, field + ".curve", {"knots", "values"});
            op.curve = spline<1>(child(curve, "knots"), child(curve, "values"), field + ".curve");
        }
        return op;
    }

private:
    std::string file_;
};

// One document: a marker line ('---' or '...' at column 0, which ends a document wherever it stands) after the
// first content line would start another, which YAML::Load would silently drop. Found by reading lines, not by
// YAML::LoadAll: yaml-cpp 0.7 returns empty documents without end on some damaged text until the memory runs out
// (found by fuzz/approximation_loader_fuzzer).
void checkOneDocument(std::string_view text, const std::string& fileName)
{
    bool content = false;
    int lineNumber = 0;
    for (std::size_t start = 0; start < text.size();) {
        const std::size_t end = std::min(text.find('\n', start), text.size());
        const std::string_view line = text.substr(start, end - start);
        start = end + 1;
        ++lineNumber;
        const bool marker = (line.starts_with("---") || line.starts_with("...")) &&
                            (line.size() == 3 || line[3] == ' ' || line[3] == '\t' || line[3] == '\r');
        if (marker && content)
            throw Error(
                fmt::format("{}:{}:1: file: '{}' ends the YAML document; an approximation file is "
                            "one document: remove it and what follows, or re-run rig-learn",
                            fileName, lineNumber, line.substr(0, 3)));
        const auto first = line.find_first_not_of(" \t\r");
        content = content || (!marker && first != std::string_view::npos && line[first] != '#');
    }
}

YAML::Node parseDocument(std::string_view text, const std::string& fileName)
{
    try {
        return YAML::Load(std::string(text));
    }
    catch (const YAML::DeepRecursion& e) {
        throw Error(
            fmt::format("{}:{}:{}: YAML lists and maps nested more than {} levels deep; an "
                        "approximation file nests a few levels, so the file is damaged",
                        fileName, e.mark.line + 1, e.mark.column + 1, e.depth() - 1));
    }
    catch (const YAML::Exception& e) {
        throw Error(
            fmt::format("{}:{}:{}: YAML syntax error: {}", fileName, e.mark.line + 1, e.mark.column + 1, e.msg));
    }
}

// The format and version first: any other problem in a file of another kind or version says less.
// Returns the version.
int checkFormat(const Reader& r, const YAML::Node& root, const std::string& fileName)
{
    if (!root.IsMap())
        throw Error(
            fmt::format("{}: not an approximation file (expected a map with format: {}); rig-learn -o "
                        "writes one",
                        fileName, approximationFormatName));
    if (!root["format"])
        throw Error(fmt::format("{}: not an approximation file (no 'format: {}'); rig-learn -o writes one", fileName,
                                approximationFormatName));
    const YAML::Node format = root["format"];
    if (!format.IsScalar() || format.Scalar() != approximationFormatName)
        r.fail(format, "format",
               fmt::format("not an approximation file (expected format: {})", approximationFormatName));
    const int version = r.integer<int>(r.need(root, "version", "file"), "version");
    if (version < 1 || version > approximationFormatVersion)
        r.fail(root["version"], "version",
               fmt::format("version {} is not supported; this program reads versions 1 to {} (re-run rig-learn)",
                           version, approximationFormatVersion));
    r.checkKeys(root, "file",
                {"format", "version", "rigFile", "rigFingerprint", "epsilon", "training", "validation", "outputs",
                 "parameters", "discarded"},
                {"droppedOutputs", "held", "constraints"});
    return version;
}

// A field version 3 added (helper outputs, constraint operators) means nothing to an older file's writer: such a
// file was edited, or its version was.
void checkVersion3Field(const Reader& r, const YAML::Node& n, const std::string& field, int version)
{
    if (n && version < 3)
        r.fail(n, field,
               fmt::format("version 3 added this field, but the file says version {}; re-run rig-learn, or write "
                           "version: 3",
                           version));
}

TrainingSummary readTraining(const Reader& r, const YAML::Node& training)
{
    r.checkKeys(training, "training", {"evaluations", "orderEvaluations", "seconds", "orderer"});
    TrainingSummary t;
    t.evaluations = r.integer<std::uint64_t>(training["evaluations"], "training.evaluations");
    t.orderEvaluations = r.integer<std::uint64_t>(training["orderEvaluations"], "training.orderEvaluations");
    t.seconds = r.nonNegative(training["seconds"], "training.seconds");
    t.orderer = r.text(training["orderer"], "training.orderer");
    return t;
}

ValidationSummary readValidation(const Reader& r, const YAML::Node& validation)
{
    r.checkKeys(validation, "validation",
                {"poses", "maxPositionErrorCm", "meanPositionErrorCm", "maxRotationErrorDeg", "meanRotationErrorDeg",
                 "worstOutput", "worstPose"},
                {"maxRelativeError", "worstRelativeOutput", "worstParameter", "nonFinitePoses", "withinEpsilon",
                 "singularPoses", "singularOutput"});
    ValidationSummary v;
    v.poses = r.count<int>(validation["poses"], "validation.poses");
    v.maxPositionErrorCm = r.nonNegative(validation["maxPositionErrorCm"], "validation.maxPositionErrorCm");
    v.meanPositionErrorCm = r.nonNegative(validation["meanPositionErrorCm"], "validation.meanPositionErrorCm");
    v.maxRotationErrorDeg = r.nonNegative(validation["maxRotationErrorDeg"], "validation.maxRotationErrorDeg");
    v.meanRotationErrorDeg = r.nonNegative(validation["meanRotationErrorDeg"], "validation.meanRotationErrorDeg");
    v.worstOutput = r.text(validation["worstOutput"], "validation.worstOutput");
    v.worstPose = r.count<int>(validation["worstPose"], "validation.worstPose", -1);
    if (const YAML::Node n = validation["maxRelativeError"])
        v.maxRelativeError = r.nonNegative(n, "validation.maxRelativeError");
    if (const YAML::Node n = validation["worstRelativeOutput"])
        v.worstRelativeOutput = r.text(n, "validation.worstRelativeOutput");
    if (const YAML::Node n = validation["worstParameter"]) v.worstParameter = r.text(n, "validation.worstParameter");
    if (const YAML::Node n = validation["nonFinitePoses"])
        v.nonFinitePoses = r.count<int>(n, "validation.nonFinitePoses");
    if (const YAML::Node n = validation["withinEpsilon"]) v.withinEpsilon = r.boolean(n, "validation.withinEpsilon");
    if (const YAML::Node n = validation["singularPoses"]) v.singularPoses = r.count<int>(n, "validation.singularPoses");
    if (const YAML::Node n = validation["singularOutput"]) v.singularOutput = r.text(n, "validation.singularOutput");
    return v;
}

// The outputs with their parents (by name), into a.outputs; returns each output's index by name. Their constraint
// indices are read once the constraints are (readConstraintIndices).
std::map<std::string, int> readOutputs(const Reader& r, const YAML::Node& root, int version, Approximation& a)
{
    std::map<std::string, int> outputIndex;
    const YAML::Node outputs = r.sequence(root["outputs"], "outputs");
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const std::string field = fmt::format("outputs[{}]", k);
        r.checkKeys(outputs[k], field, {"name", "rest"},
                    {"parent", "validationError", "modelled", "helper", "constraint"});
        checkVersion3Field(r, outputs[k]["helper"], field + ".helper", version);
        checkVersion3Field(r, outputs[k]["constraint"], field + ".constraint", version);
        ApproximationOutput out;
        out.name = r.text(outputs[k]["name"], field + ".name");
        if (!outputIndex.emplace(out.name, static_cast<int>(k)).second)
            r.fail(outputs[k]["name"], field + ".name", fmt::format("the output '{}' is listed twice", out.name));
        const YAML::Node rows = r.sequence(outputs[k]["rest"], field + ".rest", 4);
        for (int row = 0; row < 4; ++row) {
            const auto v = r.reals(rows[static_cast<std::size_t>(row)], field + ".rest", 4);
            for (int c = 0; c < 4; ++c) out.rest(row, c) = v[static_cast<std::size_t>(c)];
        }
        if (const YAML::Node n = outputs[k]["validationError"])
            out.validationError = r.nonNegative(n, field + ".validationError");
        if (const YAML::Node n = outputs[k]["modelled"]) out.modelled = r.boolean(n, field + ".modelled");
        if (const YAML::Node n = outputs[k]["helper"]) out.helper = r.boolean(n, field + ".helper");
        a.outputs.push_back(std::move(out));
    }
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const YAML::Node n = outputs[k]["parent"];
        if (!n) continue;
        const std::string field = fmt::format("outputs[{}].parent", k);
        const std::string name = r.text(n, field);
        const auto it = outputIndex.find(name);
        if (it == outputIndex.end()) r.fail(n, field, fmt::format("'{}' is not one of the outputs", name));
        if (!a.outputs[k].modelled || !a.outputs[static_cast<std::size_t>(it->second)].modelled)
            r.fail(n, field, "a non-compositional output (modelled: false) is in world space: no parent, no children");
        a.outputs[k].parent = it->second;
    }
    return outputIndex;
}

// A twist share's fields (ConstraintBase); its driver's rest rotation relative to its parent's comes from their
// rest matrices.
template <class Input>
ConstraintBase readTwistShare(const Reader& r, const YAML::Node& n, const std::string& field, const Input& input,
                              const Approximation& a)
{
    ConstraintBase base;
    base.kind = ConstraintKind::twistShare;
    base.anchor = input("anchor");
    base.driver = input("driver");
    base.driverParent = input("driverParent");
    base.root = r.vector3(r.child(n, "root"), field + ".root");
    const YAML::Node axis = r.child(n, "axis");
    base.axis = r.vector3(axis, field + ".axis");
    if (!(std::abs(base.axis.norm() - 1.0) < 1e-9))
        r.fail(axis, field + ".axis", "must be a unit vector (re-run rig-learn)");
    const YAML::Node twistAxis = r.child(n, "twistAxis");
    const std::string axisName = r.text(twistAxis, field + ".twistAxis");
    if (axisName != "x" && axisName != "y" && axisName != "z")
        r.fail(twistAxis, field + ".twistAxis", fmt::format("'{}' is not an axis; it is x, y or z", axisName));
    base.twistAxis = axisName[0] - 'x';
    const auto order = [&](std::string_view key) {
        const YAML::Node v = r.child(n, key);
        const std::string path = fmt::format("{}.{}", field, key);
        const std::optional<RotateOrder> o = rotateOrderFromName(r.text(v, path));
        if (!o) r.fail(v, path, "not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx");
        return *o;
    };
    base.readOrder = order("readOrder");
    base.twistOrder = order("twistOrder");
    base.share = r.real(r.child(n, "share"), field + ".share");
    const auto restRotation = [&](int k) -> Eigen::Matrix3d {
        if (k < 0) return Eigen::Matrix3d::Identity();
        return polarRotation(a.outputs[static_cast<std::size_t>(k)].rest.block<3, 3>(0, 0));
    };
    base.driverRest = restRotation(base.driverParent).transpose() * restRotation(base.driver);
    return base;
}

// A blend's inputs and rule; its weight, a parameter, is read once the parameters are (readBlendWeights).
template <class Input>
ConstraintBase readBlend(const Reader& r, const YAML::Node& n, const std::string& field, const Input& input)
{
    ConstraintBase base;
    base.kind = ConstraintKind::blend;
    base.anchor = input("anchor");
    base.ik = input("ik");
    base.fk = input("fk");
    base.ikParent = input("ikParent");
    base.fkParent = input("fkParent");
    if (base.ik == base.fk) r.fail(r.child(n, "fk"), field + ".fk", "is the IK branch too; a blend has two branches");
    const YAML::Node mode = r.child(n, "mode");
    const std::string modeName = r.text(mode, field + ".mode");
    const std::optional<BlendMode> known = blendModeFromName(modeName);
    if (!known)
        r.fail(mode, field + ".mode",
               fmt::format("unknown blend '{}'; the blends are {} and {}", modeName,
                           blendModeName(BlendMode::eulerChannels), blendModeName(BlendMode::slerp)));
    base.blend.mode = *known;
    const YAML::Node order = r.child(n, "order");
    if (base.blend.mode == BlendMode::slerp && order)
        r.fail(order, field + ".order", "a slerp has no rotate order; remove it");
    if (base.blend.mode == BlendMode::eulerChannels) {
        if (!order) r.fail(n, field, "an eulerChannels blend needs `order`, the rotate order its angles are read in");
        const std::optional<RotateOrder> o = rotateOrderFromName(r.text(order, field + ".order"));
        if (!o) r.fail(order, field + ".order", "not a rotate order; it is one of xyz, yzx, zxy, xzy, yxz, zyx");
        base.blend.order = *o;
    }
    return base;
}

// Whether some blend names this parameter as its weight (checked further by readBlendWeights).
bool blendWeight(const YAML::Node& root, const std::string& name)
{
    const YAML::Node constraints = root["constraints"];
    if (!constraints || !constraints.IsSequence()) return false;
    for (const YAML::Node& c : constraints)
        if (c.IsMap() && c["kind"] && c["kind"].IsScalar() && c["kind"].Scalar() == "blend" && c["weight"] &&
            c["weight"].IsScalar() && c["weight"].Scalar() == name)
            return true;
    return false;
}

// The blends' weights, by parameter name: a modelled parameter limited to [0, 1], as a switch is.
void readBlendWeights(const Reader& r, const YAML::Node& root, Approximation& a)
{
    for (std::size_t c = 0; c < a.constraints.size(); ++c) {
        ConstraintBase& base = a.constraints[c];
        if (base.kind != ConstraintKind::blend) continue;
        const std::string field = fmt::format("constraints[{}].weight", c);
        const YAML::Node n = root["constraints"][c]["weight"];
        const std::string name = r.text(n, field);
        const auto it = std::find_if(a.parameters.begin(), a.parameters.end(),
                                     [&](const ModelledParameter& m) { return m.parameter.name == name; });
        if (it == a.parameters.end()) r.fail(n, field, fmt::format("'{}' is not one of the parameters", name));
        const RigParameter& p = it->parameter;
        if (!p.limited || p.min < 0.0 || p.max > 1.0)
            r.fail(
                n, field,
                fmt::format("'{}' is not limited to [0, 1]; a blend's weight is a switch's (re-run rig-learn)", name));
        base.weight = static_cast<int>(it - a.parameters.begin());
    }
}

// One constraint operator; its inputs are modelled outputs, by name.
ConstraintBase readConstraint(const Reader& r, const YAML::Node& n, const std::string& field,
                              const std::map<std::string, int>& outputIndex, const Approximation& a)
{
    const YAML::Node kind = r.need(n, "kind", field);
    const std::string kindName = r.text(kind, field + ".kind");
    const std::optional<ConstraintKind> known = constraintKindFromName(kindName);
    if (!known)
        r.fail(kind, field + ".kind",
               fmt::format("unknown constraint '{}'; the constraints are {}, {} and {}", kindName,
                           constraintKindName(ConstraintKind::planarChain),
                           constraintKindName(ConstraintKind::twistShare), constraintKindName(ConstraintKind::blend)));
    if (*known == ConstraintKind::blend)
        r.checkKeys(n, field, {"kind", "ik", "fk", "weight", "mode"}, {"anchor", "ikParent", "fkParent", "order"});
    else if (*known == ConstraintKind::twistShare)
        r.checkKeys(n, field, {"kind", "driver", "root", "axis", "twistAxis", "readOrder", "twistOrder", "share"},
                    {"anchor", "driverParent"});
    else
        r.checkKeys(n, field, {"kind", "goal", "root", "restPole", "shape"},
                    {"anchor", "pole", "restNormal", "worldUp", "orient", "origin"});
    const auto input = [&](std::string_view which) {
        const YAML::Node v = r.child(n, which);
        if (!v) return -1;
        const std::string path = fmt::format("{}.{}", field, which);
        const std::string name = r.text(v, path);
        const auto it = outputIndex.find(name);
        if (it == outputIndex.end()) r.fail(v, path, fmt::format("'{}' is not one of the outputs", name));
        if (!a.outputs[static_cast<std::size_t>(it->second)].modelled)
            r.fail(v, path,
                   fmt::format("'{}' is not modelled (modelled: false); a constraint reads outputs the approximation "
                               "predicts: re-run rig-learn",
                               name));
        return it->second;
    };
    if (*known == ConstraintKind::twistShare) return readTwistShare(r, n, field, input, a);
    if (*known == ConstraintKind::blend) return readBlend(r, n, field, input);
    ConstraintBase base;
    base.kind = ConstraintKind::planarChain;
    base.anchor = input("anchor");
    base.goal = input("goal");
    base.pole = input("pole");
    base.orient = input("orient");
    if (base.orient >= 0) base.origin = r.vector3(r.need(n, "origin", field), field + ".origin");
    else if (const YAML::Node origin = r.child(n, "origin"))
        r.fail(origin, field + ".origin", "an origin belongs to a chain with an orient output; remove it");
    base.root = r.vector3(r.child(n, "root"), field + ".root");
    base.restPole = r.vector3(r.child(n, "restPole"), field + ".restPole");
    if (const YAML::Node up = r.child(n, "worldUp")) {
        base.worldUp = r.boolean(up, field + ".worldUp");
        if (base.worldUp && base.pole >= 0)
            r.fail(up, field + ".worldUp", "a chain with a pole has no world up; remove one");
    }
    if (const YAML::Node normal = r.child(n, "restNormal")) {
        if (base.pole >= 0) r.fail(normal, field + ".restNormal", "a chain with a pole has no rest plane; remove one");
        base.restNormal = r.vector3(normal, field + ".restNormal");
        if (!(std::abs(base.restNormal.norm() - 1.0) < 1e-9))
            r.fail(normal, field + ".restNormal", "must be a unit vector (re-run rig-learn)");
        base.restPlane = true;
    }
    const YAML::Node shape = r.child(n, "shape");
    const YAML::Node shapeKind = r.need(shape, "kind", field + ".shape");
    const std::string shapeName = r.text(shapeKind, field + ".shape.kind");
    if (shapeName != operatorKindName(OperatorKind::sampledRigid))
        r.fail(shapeKind, field + ".shape.kind",
               fmt::format("'{}' is not sampledRigid; a chain's shape is a sampledRigid operator (re-run rig-learn)",
                           shapeName));
    base.shape = r.op(shape, field + ".shape");
    if (!base.prepare(a.outputs[static_cast<std::size_t>(base.goal)].rest.block<3, 1>(0, 3)))
        r.fail(n, field,
               "the rest points span no plane (the goal's rest origin on `root`, or `restPole` on the line through "
               "them); re-run rig-learn");
    return base;
}

// The top-level `constraints` list (version 3), into a.constraints.
void readConstraints(const Reader& r, const YAML::Node& root, int version,
                     const std::map<std::string, int>& outputIndex, Approximation& a)
{
    const YAML::Node constraints = root["constraints"];
    if (!constraints) return;
    checkVersion3Field(r, constraints, "constraints", version);
    for (std::size_t c = 0; c < r.sequence(constraints, "constraints").size(); ++c)
        a.constraints.push_back(readConstraint(r, constraints[c], fmt::format("constraints[{}]", c), outputIndex, a));
}

// The outputs' `constraint` indices: in range, on a modelled output without a parent, whose constraint does not
// read the output itself.
void readConstraintIndices(const Reader& r, const YAML::Node& root, Approximation& a)
{
    const YAML::Node outputs = root["outputs"];
    for (std::size_t k = 0; k < outputs.size(); ++k) {
        const YAML::Node n = outputs[k]["constraint"];
        if (!n) continue;
        const std::string field = fmt::format("outputs[{}].constraint", k);
        const int c = r.integer<int>(n, field);
        if (c < 0 || static_cast<std::size_t>(c) >= a.constraints.size())
            r.fail(n, field,
                   a.constraints.empty()
                       ? fmt::format("{} is not a constraint index: the file has no constraints list", c)
                       : fmt::format("{} is not a constraint index (0..{})", c, a.constraints.size() - 1));
        ApproximationOutput& out = a.outputs[k];
        if (out.parent >= 0)
            r.fail(n, field,
                   "a constraint output has no parent (its constraint's inputs move it); remove `parent` or "
                   "`constraint`");
        if (!out.modelled) r.fail(n, field, "a non-compositional output (modelled: false) has no constraint");
        const ConstraintBase& base = a.constraints[static_cast<std::size_t>(c)];
        for (const int i : base.frameInputs())
            if (i == static_cast<int>(k))
                r.fail(n, field,
                       fmt::format("constraints[{}] reads '{}' itself; a constraint reads outputs learned before its "
                                   "output",
                                   c, out.name));
        out.constraint = c;
    }
}

// Approximation::outputOrder takes a cycle of frames (parents, constraints' inputs) for a bug; in a file it is
// damage, refused here with the cycle named: placing outputs once their inputs are placed leaves the cycles and
// what they feed, where following unplaced inputs comes round to one.
void checkFrameCycles(const Reader& r, const YAML::Node& root, const Approximation& a)
{
    const std::vector<std::vector<int>> dependents = a.dependents();
    std::vector<std::size_t> unplacedInputs(a.outputs.size());
    std::vector<int> ready;
    for (std::size_t k = 0; k < a.outputs.size(); ++k) {
        unplacedInputs[k] = a.frameInputs(static_cast<int>(k)).size();
        if (!unplacedInputs[k]) ready.push_back(static_cast<int>(k));
    }
    while (!ready.empty()) {
        const int u = ready.back();
        ready.pop_back();
        for (const int d : dependents[static_cast<std::size_t>(u)])
            if (--unplacedInputs[static_cast<std::size_t>(d)] == 0) ready.push_back(d);
    }
    const auto left = std::find_if(unplacedInputs.begin(), unplacedInputs.end(), [](std::size_t n) { return n > 0; });
    if (left == unplacedInputs.end()) return;
    std::vector<int> walk, position(a.outputs.size(), -1);
    int u = static_cast<int>(left - unplacedInputs.begin());
    while (position[static_cast<std::size_t>(u)] < 0) {
        position[static_cast<std::size_t>(u)] = static_cast<int>(walk.size());
        walk.push_back(u);
        const std::vector<int> inputs = a.frameInputs(u);
        u = *std::find_if(inputs.begin(), inputs.end(),
                          [&](int i) { return unplacedInputs[static_cast<std::size_t>(i)] > 0; });
    }
    const std::vector<int> cycle(walk.begin() + position[static_cast<std::size_t>(u)], walk.end());
    const auto name = [&](int k) {
        return fmt::format("'{}'", messageExcerpt(a.outputs[static_cast<std::size_t>(k)].name));
    };
    std::string reads;
    for (std::size_t j = 0; j < cycle.size() && j < 6; ++j) reads += name(cycle[j]) + " reads ";
    reads += cycle.size() > 6 ? "..." : name(cycle.front());
    const YAML::Node outputs = root["outputs"];
    for (const int k : cycle)
        if (a.outputs[static_cast<std::size_t>(k)].constraint >= 0)
            r.fail(outputs[static_cast<std::size_t>(k)]["constraint"], fmt::format("outputs[{}].constraint", k),
                   fmt::format("the frames form a cycle ({}); a constraint reads outputs learned before its output, "
                               "never one that moves with it",
                               reads));
    r.fail(outputs, "outputs", "the outputs' parents form a cycle; an output's parent is an ancestor joint");
}

// One modelled parameter; `names` holds the parameters' names read so far (a name is listed once).
ModelledParameter readParameter(const Reader& r, const YAML::Node& root, const YAML::Node& n, const std::string& field,
                                const Approximation& a, const std::map<std::string, int>& outputIndex,
                                std::set<std::string>& names)
{
    r.checkKeys(n, field,
                {"name", "default", "min", "max", "limited", "angular", "form", "fitError", "samples", "outputs",
                 "operatorOfOutput", "operators"},
                {"validationError", "noEffect", "unmodelledOutputs"});
    ModelledParameter m;
    m.parameter = r.parameter(n, field);
    if (!names.insert(m.parameter.name).second)
        r.fail(n["name"], field + ".name", fmt::format("the parameter '{}' is listed twice", m.parameter.name));
    m.form = r.text(n["form"], field + ".form");
    m.fitError = r.nonNegative(n["fitError"], field + ".fitError");
    m.samples = r.count<int>(n["samples"], field + ".samples");
    if (const YAML::Node v = n["validationError"]) m.validationError = r.nonNegative(v, field + ".validationError");
    if (const YAML::Node v = n["noEffect"])
        for (const auto& range : r.sequence(v, field + ".noEffect")) {
            const auto ends = r.reals(range, field + ".noEffect", 2);
            if (!(ends[0] <= ends[1])) r.fail(range, field + ".noEffect", "a range is [low, high]");
            m.noEffect.emplace_back(ends[0], ends[1]);
        }
    const auto outputList = [&](const YAML::Node& list, const std::string& which, bool modelled) {
        std::vector<int> indices;
        for (const auto& o : r.sequence(list, field + "." + which)) {
            const std::string name = r.text(o, field + "." + which);
            const auto it = outputIndex.find(name);
            if (it == outputIndex.end())
                r.fail(o, field + "." + which, fmt::format("'{}' is not one of the outputs", name));
            if (!indices.empty() && it->second <= indices.back())
                r.fail(o, field + "." + which,
                       "the outputs must be listed once each, in the order of the outputs list");
            if (a.outputs[static_cast<std::size_t>(it->second)].modelled != modelled)
                r.fail(o, field + "." + which,
                       fmt::format("'{}' is {}modelled (its outputs entry says modelled: {}); list it under {}", name,
                                   modelled ? "not " : "", !modelled, modelled ? "unmodelledOutputs" : "outputs"));
            indices.push_back(it->second);
        }
        return indices;
    };
    m.outputs = outputList(n["outputs"], "outputs", true);
    if (const YAML::Node v = n["unmodelledOutputs"]) m.unmodelledOutputs = outputList(v, "unmodelledOutputs", false);
    // A blend's weight moves its outputs through the blend alone (readBlendWeights).
    if (m.outputs.empty() && m.unmodelledOutputs.empty() && !blendWeight(root, m.parameter.name))
        r.fail(n["outputs"], field + ".outputs", "a parameter affects at least one output");
    const YAML::Node operators = r.sequence(n["operators"], field + ".operators");
    if (operators.size() == 0 && !m.outputs.empty())
        r.fail(operators, field + ".operators", "a modelled parameter has at least one operator");
    for (std::size_t o = 0; o < operators.size(); ++o)
        m.operators.push_back(r.op(operators[o], fmt::format("{}.operators[{}]", field, o)));
    const YAML::Node which = r.sequence(n["operatorOfOutput"], field + ".operatorOfOutput", m.outputs.size());
    for (const auto& o : which) {
        const int index = r.integer<int>(o, field + ".operatorOfOutput");
        if (index < 0 || static_cast<std::size_t>(index) >= m.operators.size())
            r.fail(o, field + ".operatorOfOutput",
                   fmt::format("{} is not an operator index (0..{})", index, m.operators.size() - 1));
        m.operatorOfOutput.push_back(index);
    }
    return m;
}

// droppedOutputs and discarded (`names`: the modelled parameters' names, which a discarded one may not repeat).
void readSetAside(const Reader& r, const YAML::Node& root, std::set<std::string>& names, Approximation& a)
{
    if (const YAML::Node droppedOutputs = root["droppedOutputs"])
        for (std::size_t d = 0; d < r.sequence(droppedOutputs, "droppedOutputs").size(); ++d) {
            const std::string field = fmt::format("droppedOutputs[{}]", d);
            r.checkKeys(droppedOutputs[d], field, {"name", "reason"});
            a.droppedOutputs.push_back({r.text(droppedOutputs[d]["name"], field + ".name"),
                                        r.text(droppedOutputs[d]["reason"], field + ".reason")});
        }
    const YAML::Node discarded = r.sequence(root["discarded"], "discarded");
    for (std::size_t d = 0; d < discarded.size(); ++d) {
        const std::string field = fmt::format("discarded[{}]", d);
        r.checkKeys(discarded[d], field, {"name", "default", "min", "max", "limited", "angular", "reason"});
        DiscardedParameter x;
        x.parameter = r.parameter(discarded[d], field);
        if (!names.insert(x.parameter.name).second)
            r.fail(discarded[d]["name"], field + ".name",
                   fmt::format("the parameter '{}' is listed twice", x.parameter.name));
        x.reason = r.text(discarded[d]["reason"], field + ".reason");
        a.discarded.push_back(std::move(x));
    }
}

// The plugs held while learning; none of them is a parameter (`names`).
void readHeld(const Reader& r, const YAML::Node& root, const std::set<std::string>& names, Approximation& a)
{
    if (const YAML::Node held = root["held"])
        for (std::size_t h = 0; h < r.sequence(held, "held").size(); ++h) {
            const std::string field = fmt::format("held[{}]", h);
            r.checkKeys(held[h], field, {"plug", "value"});
            const YAML::Node plug = held[h]["plug"];
            HeldPlug x{r.text(plug, field + ".plug"), r.real(held[h]["value"], field + ".value")};
            if (x.plug.empty()) r.fail(plug, field + ".plug", "a held plug needs a name");
            if (names.count(x.plug))
                r.fail(plug, field + ".plug",
                       fmt::format("'{}' is also a parameter; a plug is inverted or held, not both: re-run rig-learn",
                                   x.plug));
            for (const HeldPlug& before : a.held)
                if (before.plug == x.plug)
                    r.fail(plug, field + ".plug", fmt::format("the plug '{}' is held twice", x.plug));
            a.held.push_back(std::move(x));
        }
}

}  // namespace

std::string approximationToYaml(const Approximation& a)
{
    std::string out = headerText(a) + outputsText(a) + constraintsText(a);
    out += a.parameters.empty() ? "parameters: []\n" : "parameters:  # composition order, outermost first\n";
    for (std::size_t p = 0; p < a.parameters.size(); ++p) out += parameterText(a, p);
    return out + setAsideText(a);
}

Approximation approximationFromYaml(std::string_view text, const std::string& fileName)
{
    checkOneDocument(text, fileName);
    // Read through a const node: operator[] on a mutable one would add the keys it looks for.
    const YAML::Node root = parseDocument(text, fileName);
    const Reader r(fileName);
    const int version = checkFormat(r, root, fileName);

    Approximation a;
    a.rigFile = r.text(root["rigFile"], "rigFile");
    a.rigFingerprint = r.text(root["rigFingerprint"], "rigFingerprint");
    a.epsilon = r.real(root["epsilon"], "epsilon");
    if (!(a.epsilon > 0)) r.fail(root["epsilon"], "epsilon", "must be positive");

    a.training = readTraining(r, root["training"]);
    a.validation = readValidation(r, root["validation"]);
    const std::map<std::string, int> outputIndex = readOutputs(r, root, version, a);
    readConstraints(r, root, version, outputIndex, a);
    readConstraintIndices(r, root, a);
    checkFrameCycles(r, root, a);
    std::set<std::string> names;
    const YAML::Node parameters = r.sequence(root["parameters"], "parameters");
    for (std::size_t p = 0; p < parameters.size(); ++p)
        a.parameters.push_back(
            readParameter(r, root, parameters[p], fmt::format("parameters[{}]", p), a, outputIndex, names));
    readBlendWeights(r, root, a);
    readSetAside(r, root, names, a);
    readHeld(r, root, names, a);
    return a;
}

Approximation readApproximationFile(const std::filesystem::path& file)
{
    // A folder opens as a stream of nothing, and a device or a pipe never ends: refuse them by name.
    std::error_code ec;
    const auto status = std::filesystem::status(file, ec);
    if (std::filesystem::is_directory(status))
        throw Error(
            fmt::format("{}: is a folder; give the approximation file (rig-learn -o writes one)", file.string()));
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        throw Error(
            fmt::format("{}: is not a regular file (a device or a pipe?); give the approximation "
                        "file (rig-learn -o writes one)",
                        file.string()));
    if (std::filesystem::exists(status) && std::filesystem::file_size(file, ec) > approximationMaxFileBytes)
        throw Error(
            fmt::format("{}: more than the {} MB an approximation file may have; it is not one, "
                        "or it is damaged",
                        file.string(), approximationMaxFileBytes >> 20));
    std::ifstream in(file, std::ios::binary);
    if (!in) {
        const int error = errno;
        throw Error(
            fmt::format("{}: cannot read it ({}); {}", file.string(), std::strerror(error),
                        error == ENOENT ? "check the name (rig-learn -o writes one)" : "check its permissions"));
    }
    std::ostringstream s;
    s << in.rdbuf();
    return approximationFromYaml(s.str(), file.string());
}

std::string checkFingerprint(const Approximation& approximation, const std::string& fingerprint, bool strict)
{
    if (approximation.rigFingerprint == fingerprint) return {};
    const std::string message = fmt::format(
        "the rig changed since the approximation was learned from {} (fingerprint {}, now {}); re-run "
        "rig-learn",
        approximation.rigFile, approximation.rigFingerprint, fingerprint);
    if (strict) throw Error(message);
    return message;
}

}  // namespace rig

#include "inversion/model/approximation_io.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "core/error.h"

// Approximation files written (approximation_io.h): every number in the shortest form that reads back to the same
// double. Read back by approximation_reader.cpp.

namespace rig {
namespace {

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
        if (base.kind == ConstraintKind::oriented) {
            out += input("anchor", base.anchor, true) + input("orient", base.orient, false) +
                   fmt::format("    origin: {}\n", vector3(base.origin, field + ".origin"));
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
        if (base.poleTurns) out += "    poleTurns: true\n";
        // The ikSCsolver's plane: the rest plane turned minimally, with the turn of the chain's line by the reach.
        if (base.minimalTurn) {
            out += "    minimalTurn: true\n";
            if (base.goalTurns) out += "    goalTurns: true\n";
            out += "    lineTurn:\n";
            out += operatorText(base.lineTurn, field + ".lineTurn", "      ", "      ");
        }
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

}  // namespace

std::string approximationToYaml(const Approximation& a)
{
    std::string out = headerText(a) + outputsText(a) + constraintsText(a);
    out += a.parameters.empty() ? "parameters: []\n" : "parameters:  # composition order, outermost first\n";
    for (std::size_t p = 0; p < a.parameters.size(); ++p) out += parameterText(a, p);
    return out + setAsideText(a);
}

}  // namespace rig

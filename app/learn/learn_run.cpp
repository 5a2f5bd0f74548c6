#include "app/learn/learn_run.h"

#include <fnmatch.h>
#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include "adapter/inversion_spec.h"
#include "app/learn/switch_learn.h"
#include "core/error.h"
#include "core/parse_number.h"
#include "graph/rig_file.h"
#include "inversion/solve/pole_hold.h"

namespace rig::app {

double parseEpsilon(const std::string& text)
{
    double x = 0.0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), x);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(x))
        throw Error(
            fmt::format("--epsilon '{}': not a number; give a positive number of cm per unit of a parameter, "
                        "e.g. --epsilon 0.001",
                        text));
    if (!(x > 0))
        throw Error(
            fmt::format("--epsilon '{}': must be positive (cm per unit of a parameter), e.g. --epsilon 0.001", text));
    return x;
}

HeldPlug parseHeldPlug(const std::string& assignment)
{
    const auto eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0)
        throw Error(fmt::format("--set '{}': expected PLUG=VALUE, e.g. --set L_leg_settings.ikFk=1",
                                messageExcerpt(assignment)));
    const std::string plug = assignment.substr(0, eq), text = assignment.substr(eq + 1);
    const auto value = parseFiniteNumber(text);
    if (!value)
        throw Error(
            fmt::format("--set {}: '{}' is not a number; give a finite number in the rig file's units "
                        "(degrees for angles), e.g. --set {}=1",
                        messageExcerpt(plug), messageExcerpt(text), messageExcerpt(plug)));
    return {plug, *value};
}

GraphRigOptions::LearnRange parseLearnRange(const std::string& assignment)
{
    const std::string example = "e.g. --range L_knee_fk_ctrl.rotateX=-90:160";
    const auto eq = assignment.rfind('=');
    if (eq == std::string::npos || eq == 0)
        throw Error(fmt::format("--range '{}': expected PLUG=MIN:MAX (a parameter glob), {}",
                                messageExcerpt(assignment), example));
    const std::string glob = assignment.substr(0, eq), text = assignment.substr(eq + 1);
    const auto colon = text.find(':');
    const auto low = colon == std::string::npos ? std::nullopt : parseFiniteNumber(text.substr(0, colon));
    const auto high = colon == std::string::npos ? std::nullopt : parseFiniteNumber(text.substr(colon + 1));
    if (!low || !high || !(*low < *high))
        throw Error(
            fmt::format("--range {}: '{}' is no MIN:MAX of two finite numbers with MIN < MAX (the rig file's units, "
                        "degrees for angles), {}",
                        messageExcerpt(glob), messageExcerpt(text), example));
    return {glob, *low, *high};
}

void checkLearnRanges(const GraphRigFunction& rig, const std::vector<GraphRigOptions::LearnRange>& ranges,
                      const std::string& where)
{
    for (const GraphRigOptions::LearnRange& range : ranges) {
        bool matched = false, free = false;
        for (const RigParameter& p : rig.parameters())
            if (fnmatch(range.glob.c_str(), p.name.c_str(), 0) == 0) {
                matched = true;
                free = free || !p.limited;
            }
        if (!matched)
            throw Error(
                fmt::format("{} {}: matches no parameter; name one of those the parameter globs choose "
                            "(--params, the spec's params:)",
                            where, messageExcerpt(range.glob)));
        if (!free)
            throw Error(
                fmt::format("{} {}: every parameter it matches declares its own limits (min, max), which "
                            "learning uses; a range is for a control without limits",
                            where, messageExcerpt(range.glob)));
    }
}

Orderer ordererFromName(const std::string& name)
{
    if (name == "structured") return Orderer::structured;
    if (name == "talk") return Orderer::talk;
    throw Error(fmt::format("--orderer: {} not in {{talk,structured}}", messageExcerpt(name)));
}

double learningFraction(std::string_view stage, double fraction)
{
    const double start = stage == "sampling" ? 0.0 : stage == "classifying" ? 0.45 : stage == "ordering" ? 0.6 : 0.85;
    const double width = stage == "sampling" ? 0.45 : stage == "classifying" ? 0.15 : stage == "ordering" ? 0.25 : 0.15;
    return start + width * fraction;
}

bool discoversHelpers(const LearnJob& job) { return !job.noHelpers && (job.autoHelpers || job.helpers.empty()); }

namespace {

// Takes "auto" out of a list of globs; whether it was there.
bool takeAuto(std::vector<std::string>& globs)
{
    const auto end = std::remove(globs.begin(), globs.end(), std::string("auto"));
    const bool found = end != globs.end();
    globs.erase(end, globs.end());
    return found;
}

}  // namespace

GraphRigOptions rigOptions(const LearnJob& job)
{
    GraphRigOptions options{job.params, job.outputs, job.plugins,          job.held,
                            job.ranges, job.helpers, discoversHelpers(job)};
    const bool maya = isMayaFile(job.rig);
    options.autoParameters = takeAuto(options.parameterGlobs);
    options.autoOutputs = takeAuto(options.outputGlobs) || (maya && job.outputs.empty());
    options.cutTimeCurves = maya;
    return options;
}

std::string autoSpecText(const GraphRigFunction& rig, const std::string& rigFile)
{
    InversionSpec spec;
    for (const RigParameter& p : rig.parameters()) spec.params.push_back(p.name);
    const std::vector<char> helper = rig.helperOutputs();
    for (std::size_t k = 0; k < helper.size(); ++k)
        if (!helper[k]) spec.outputs.push_back(rig.outputs()[k]);
    spec.set = rig.held();
    const AutoChoice& a = rig.autoChoice();
    std::vector<std::string> header{
        fmt::format("The inversion choices rig-learn made for {}; edit them, then: rig-learn {} --spec THIS_FILE "
                    "-o APPROX.yaml",
                    rigFile, rigFile),
        fmt::format("params: {} channels of {} controls (transforms with a nurbsCurve shape, or keyed by a time curve) "
                    "that move an output",
                    spec.params.size(), a.controls.size())};
    if (!a.cutCurves.empty())
        header.push_back(fmt::format("  {} of them keyed by a time curve, cut while learning (the curves are the clip)",
                                     a.cutCurves.size()));
    header.push_back(a.skins > 0 ? fmt::format("outputs: the {} joints {} skinCluster{} bind", spec.outputs.size(),
                                               a.skins, a.skins > 1 ? "s" : "")
                     : a.skins == 0
                         ? fmt::format("outputs: every joint ({}; no skinCluster binds one)", spec.outputs.size())
                         : fmt::format("outputs: {} joints", spec.outputs.size()));
    if (!a.settings.empty())
        header.push_back(fmt::format("set: the controls' {} settings at the scene's values", a.settings.size()));
    if (!a.passed.empty()) header.push_back("channels of the controls passed by:");
    for (const PassedChannel& p : a.passed) header.push_back(fmt::format("  {}: {}", p.plug, p.why));
    return inversionSpecYaml(spec, header);
}

LearnOutcome learn(const LearnJob& job)
{
    const auto loadStart = std::chrono::steady_clock::now();
    GraphRigFunction rig(job.rig, rigOptions(job));
    if (job.rigLoaded) job.rigLoaded(rig);
    LearnOutcome out;
    out.loadSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - loadStart).count();
    out.absoluteTolerance = job.options.absoluteTolerance;
    out.rigParameters = rig.parameters().size();
    out.rigOutputs = rig.outputs().size();
    out.autoChoice = rig.autoChoice();
    const std::vector<char> helper = rig.helperOutputs();
    for (std::size_t k = 0; k < helper.size(); ++k)
        if (helper[k]) out.helpers.push_back(rig.outputs()[k]);
    // Switches among the parameters: the rig learned in each branch and blended (switch_learn.h).
    const RigSwitches switches = findSwitches(rig, job.rig);
    try {
        out.approximation = switches.switches.empty() ? learnApproximation(rig, job.options, job.rig, &out.unmodelled)
                                                      : learnSwitched(job, rig, switches, out.unmodelled);
    }
    catch (const Error& e) {
        // A rig that refuses a sampled value (a node's own limit) or fails to evaluate: say where.
        throw Error(fmt::format("{}: evaluating the rig while learning: {}", job.rig, e.what()));
    }
    out.approximation.held = rig.held();
    return out;
}

int validatedOutputs(const Approximation& a)
{
    if (a.validation.poses == 0 || a.parameters.empty()) return 0;
    // A blend's branch copies are not the rig's: they are measured through their blends.
    return static_cast<int>(std::count_if(a.outputs.begin(), a.outputs.end(), [](const ApproximationOutput& o) {
        return o.modelled && !(o.helper && rigOutputName(o.name) != o.name);
    }));
}

std::string storedForm(const ModelledParameter& m)
{
    const auto name = [](const Operator& op) {
        return op.linear() ? std::string(operatorKindName(op.kind))
                           : fmt::format("{} (curve)", operatorKindName(op.kind));
    };
    if (m.operators.empty()) return m.form == "blend weight" ? m.form : "none (real rig only)";
    if (m.operators.size() == 1) return name(m.operators.front());
    std::map<std::string, int> counts;
    for (const Operator& op : m.operators) ++counts[name(op)];
    std::string out = "per output:";
    for (const auto& [form, count] : counts) out += fmt::format(" {} {}", count, form);
    return out;
}

namespace {

// Each output's frame (world, its parent's name, or constraint), whether it is a helper, its constraint operator
// and its validation error, for the JSON report.
Json outputsJson(const Approximation& a)
{
    Json outputs = Json::array();
    const auto nameOf = [&](int k) { return k < 0 ? Json() : Json(a.outputs[static_cast<std::size_t>(k)].name); };
    for (const ApproximationOutput& o : a.outputs) {
        const std::string frame = o.constraint >= 0 ? "constraint"
                                  : o.parent >= 0   ? a.outputs[static_cast<std::size_t>(o.parent)].name
                                                    : "world";
        Json constraint;
        if (o.constraint >= 0) {
            const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
            if (c.kind == ConstraintKind::blend)
                constraint = {{"kind", constraintKindName(c.kind)},
                              {"anchor", nameOf(c.anchor)},
                              {"ik", nameOf(c.ik)},
                              {"fk", nameOf(c.fk)},
                              {"ik_parent", nameOf(c.ikParent)},
                              {"fk_parent", nameOf(c.fkParent)},
                              {"weight", a.parameters[static_cast<std::size_t>(c.weight)].parameter.name},
                              {"mode", blendModeName(c.blend.mode)},
                              {"order", c.blend.mode == BlendMode::eulerChannels ? Json(rotateOrderName(c.blend.order))
                                                                                 : Json()}};
            else if (c.kind == ConstraintKind::twistShare)
                constraint = {{"kind", constraintKindName(c.kind)},
                              {"anchor", nameOf(c.anchor)},
                              {"driver", nameOf(c.driver)},
                              {"driver_parent", nameOf(c.driverParent)},
                              {"twist_axis", std::string(1, "xyz"[c.twistAxis])},
                              {"read_order", rotateOrderName(c.readOrder)},
                              {"twist_order", rotateOrderName(c.twistOrder)},
                              {"share", c.share}};
            else if (c.kind == ConstraintKind::oriented)
                constraint = {
                    {"kind", constraintKindName(c.kind)}, {"anchor", nameOf(c.anchor)}, {"orient", nameOf(c.orient)}};
            else
                constraint = {{"kind", constraintKindName(c.kind)},
                              {"anchor", nameOf(c.anchor)},
                              {"goal", nameOf(c.goal)},
                              {"pole", nameOf(c.pole)},
                              {"world_up", c.worldUp},
                              {"pole_turns", c.poleTurns},
                              {"minimal_turn", c.minimalTurn},
                              {"knots", c.shape.rigid.knots().size()}};
        }
        outputs.push_back({{"name", o.name},
                           {"frame", frame},
                           {"helper", o.helper},
                           {"constraint", std::move(constraint)},
                           {"validation_error", o.modelled ? numberJson(o.validationError) : Json()}});
    }
    return outputs;
}

// Per held pole and aim target, its controls: what the joints cannot decide, which the solver holds (pole_hold.h).
Json notIdentifiableJson(const Approximation& a)
{
    Json held = Json::array();
    for (const PoleHold& hold : poleHolds(a)) {
        Json controls = Json::array();
        for (const int p : hold.parameters)
            controls.push_back(a.parameters[static_cast<std::size_t>(p)].parameter.name);
        held.push_back(
            {{"pole",
              a.outputs[static_cast<std::size_t>(a.constraints[static_cast<std::size_t>(hold.constraint)].pole)].name},
             {"controls", std::move(controls)},
             {"why", "the pole's distance from the chain and its place along it; the plane it spans is solved"}});
    }
    for (const AimHold& hold : aimHolds(a)) {
        Json controls = Json::array();
        for (const int p : hold.parameters)
            controls.push_back(a.parameters[static_cast<std::size_t>(p)].parameter.name);
        held.push_back(
            {{"target",
              a.outputs[static_cast<std::size_t>(a.constraints[static_cast<std::size_t>(hold.constraint)].goal)].name},
             {"controls", std::move(controls)},
             {"why", "the aim target's distance along the line of sight; its direction is solved"}});
    }
    return held;
}

// Per blend (an animated switch's output, switch_learn.h): the output, its weight and its branches' copies.
Json blendsJson(const Approximation& a)
{
    Json blends = Json::array();
    for (const ApproximationOutput& o : a.outputs) {
        if (o.constraint < 0) continue;
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
        if (c.kind != ConstraintKind::blend) continue;
        blends.push_back({{"output", o.name},
                          {"weight", a.parameters[static_cast<std::size_t>(c.weight)].parameter.name},
                          {"ik", a.outputs[static_cast<std::size_t>(c.ik)].name},
                          {"fk", a.outputs[static_cast<std::size_t>(c.fk)].name}});
    }
    return blends;
}

// --ranges-from's clip, its statuses on the first approximation and the ranges widened (rig file's units); null
// without it.
Json clipRangesJson(const std::optional<ClipRanges>& c)
{
    if (!c) return Json();
    Json widened = Json::array();
    for (const WidenedRange& w : c->widened)
        widened.push_back({{"parameter", w.parameter},
                           {"unit", w.angular ? "deg" : "rig"},
                           {"learned", {numberJson(w.learnedMin), numberJson(w.learnedMax)}},
                           {"reached", {numberJson(w.low), numberJson(w.high)}},
                           {"range", {numberJson(w.min), numberJson(w.max)}}});
    return {{"clip", c->clip},
            {"frames", c->frames.empty() ? Json() : Json(c->frames)},
            {"first_statuses", c->firstStatuses},
            {"widened", std::move(widened)}};
}

}  // namespace

Json learnReport(const LearnOutcome& outcome, const std::string& rig, const std::optional<std::string>& approximation,
                 bool written)
{
    const Approximation& a = outcome.approximation;
    Json modelled = Json::array(), forms = Json::array(), saturated = Json::array();
    for (const ModelledParameter& m : a.parameters) {
        modelled.push_back(m.parameter.name);
        // A parameter on the real rig only was never validated: no error, rather than an error of 0.
        forms.push_back({{"name", m.parameter.name},
                         {"form", storedForm(m)},
                         {"fit_error", numberJson(m.fitError)},
                         {"samples", m.samples},
                         {"outputs", m.outputs.size()},
                         {"validation_error", m.outputs.empty() ? Json() : numberJson(m.validationError)}});
        for (const auto& [from, to] : m.noEffect)
            saturated.push_back({{"name", m.parameter.name}, {"from", numberJson(from)}, {"to", numberJson(to)}});
    }
    Json discarded = Json::array();
    for (const auto& d : a.discarded) discarded.push_back({{"name", d.parameter.name}, {"reason", d.reason}});
    Json redundant = Json::array();
    for (const auto& [i, j] : redundantParameters(a))
        redundant.push_back(Json::array({a.parameters[static_cast<std::size_t>(i)].parameter.name,
                                         a.parameters[static_cast<std::size_t>(j)].parameter.name}));
    Json outputs = outputsJson(a);
    Json unmodelled = Json::array();
    for (const UnmodelledOutput& u : outcome.unmodelled) unmodelled.push_back({{"name", u.name}, {"reason", u.reason}});
    Json dropped = Json::array();
    for (const DroppedOutput& d : a.droppedOutputs) dropped.push_back({{"name", d.name}, {"reason", d.reason}});
    const ValidationSummary& v = a.validation;
    return Json{{"rig", rig},
                {"approximation", approximation ? Json(*approximation) : Json()},
                {"fingerprint", a.rigFingerprint},
                {"epsilon", numberJson(a.epsilon)},
                {"absolute_tolerance_cm", numberJson(outcome.absoluteTolerance)},
                {"orderer", a.training.orderer},
                {"parameters", outcome.rigParameters},
                {"outputs", outcome.rigOutputs},
                {"helpers", outcome.helpers},
                {"not_identifiable", notIdentifiableJson(a)},
                {"blends", blendsJson(a)},
                {"held", heldJson(a.held)},
                {"evaluations", a.training.evaluations},
                {"order_evaluations", a.training.orderEvaluations},
                {"seconds", numberJson(a.training.seconds)},
                {"load_seconds", numberJson(outcome.loadSeconds)},
                {"modelled", std::move(modelled)},
                {"forms", std::move(forms)},
                {"discarded", std::move(discarded)},
                {"redundant", std::move(redundant)},
                {"saturated", std::move(saturated)},
                {"frames", std::move(outputs)},
                {"dropped_outputs", std::move(dropped)},
                {"unmodelled_outputs", std::move(unmodelled)},
                {"within_epsilon", v.withinEpsilon},
                {"ranges_from", clipRangesJson(outcome.clipRanges)},
                {"written", written},
                {"validation",
                 {{"poses", v.poses},
                  {"validated_outputs", validatedOutputs(a)},
                  {"max_position_error_cm", numberJson(v.maxPositionErrorCm)},
                  {"mean_position_error_cm", numberJson(v.meanPositionErrorCm)},
                  {"max_rotation_error_deg", numberJson(v.maxRotationErrorDeg)},
                  {"mean_rotation_error_deg", numberJson(v.meanRotationErrorDeg)},
                  {"worst_output", v.worstOutput},
                  {"worst_pose", v.worstPose},
                  {"max_relative_error", numberJson(v.maxRelativeError)},
                  {"worst_relative_output", v.worstRelativeOutput},
                  {"worst_parameter", v.worstParameter},
                  {"non_finite_poses", v.nonFinitePoses},
                  {"singular_poses", v.singularPoses},
                  {"singular_output", v.singularOutput}}}};
}

std::string validationFailure(const Approximation& approximation)
{
    const ValidationSummary& v = approximation.validation;
    if (v.withinEpsilon) return {};
    if (v.nonFinitePoses > 0)
        return fmt::format("the rig gave non-finite matrices at {} of {} validation poses", v.nonFinitePoses, v.poses);
    return fmt::format(
        "the approximation exceeds epsilon {:g}: {:.3g} cm per unit of the parameters moved on {} "
        "(moving {} most)",
        approximation.epsilon, v.maxRelativeError, v.worstRelativeOutput, v.worstParameter);
}

}  // namespace rig::app

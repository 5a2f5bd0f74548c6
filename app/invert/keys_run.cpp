#include "app/invert/keys_run.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

#include "core/error.h"

namespace rig::app {
namespace {

// The frame numbers of the reported frames.
std::vector<double> reportedFrames(const InvertOutcome& outcome)
{
    const auto first = outcome.clip.frameNumbers.begin() + outcome.first;
    return {first, first + static_cast<std::ptrdiff_t>(outcome.values.size())};
}

const RigParameter& parameter(const InvertOutcome& outcome, std::size_t p)
{
    return outcome.approximation->parameters[p].parameter;
}

}  // namespace

AnimFileCurve plugCurve(const Graph& graph, const std::string& name)
{
    const Plug plug = graph.plug(name);
    const AttributeSpec& spec = graph.spec(plug);
    AnimFileCurve curve;
    curve.node = graph.nodeName(plug.node);
    curve.leaf = spec.name + (plug.index >= 0 ? fmt::format("[{}]", plug.index) : "");
    curve.attribute = curve.leaf;
    if (plug.child >= 0) {
        curve.leaf = spec.childNames[static_cast<std::size_t>(plug.child)];
        curve.attribute += "." + curve.leaf;
    }
    curve.output = spec.unit == Unit::Angle      ? AnimQuantity::angular
                   : spec.unit == Unit::Distance ? AnimQuantity::linear
                                                 : AnimQuantity::unitless;
    return curve;
}

namespace {

// Keys in user units (degrees, cm), as files hold them.
std::vector<AnimKey> userKeys(const RigParameter& p, const std::vector<AnimKey>& keys)
{
    std::vector<AnimKey> out = keys;
    for (AnimKey& k : out) k.y = parameterUserValue(p, k.y);
    return out;
}

std::string percent(double fraction) { return fmt::format("{:.1f}%", 100.0 * fraction); }

}  // namespace

TangentType keyTangent(const std::string& name)
{
    if (const auto type = tangentTypeFromName(name)) return *type;
    throw Error(
        fmt::format("--key-tangent {}: not a tangent type; use one of auto, spline, clamped, plateau, linear, "
                    "flat, step, stepnext",
                    messageExcerpt(name)));
}

void checkKeySettings(const KeySettings& settings)
{
    if (!(settings.toleranceCm > 0.0) || !std::isfinite(settings.toleranceCm))
        throw Error(fmt::format("--key-tolerance {}: give a positive distance in cm (e.g. 0.1)", settings.toleranceCm));
    if (!(settings.toleranceDeg > 0.0) || !std::isfinite(settings.toleranceDeg))
        throw Error(
            fmt::format("--key-tolerance-deg {}: give a positive angle in degrees (e.g. 0.5)", settings.toleranceDeg));
    // Below the floors the round-off of the rig's own evaluation is over the tolerance, even on the dense pose.
    if (settings.toleranceCm < KeyReductionOptions::minToleranceCm)
        throw Error(fmt::format(
            "--key-tolerance {}: below {} cm, joint positions differ by their round-off; give "
            "a distance of at least {} cm (e.g. 0.1)",
            settings.toleranceCm, KeyReductionOptions::minToleranceCm, KeyReductionOptions::minToleranceCm));
    if (settings.toleranceDeg < KeyReductionOptions::minToleranceDeg)
        throw Error(fmt::format(
            "--key-tolerance-deg {}: below {} degrees, joint rotations differ by their "
            "round-off; give an angle of at least {} degrees (e.g. 0.5)",
            settings.toleranceDeg, KeyReductionOptions::minToleranceDeg, KeyReductionOptions::minToleranceDeg));
    keyTangent(settings.tangent);
}

double KeysOutcome::reduction() const
{
    return denseKeys > 0 ? 1.0 - static_cast<double>(keyed.keyCount()) / static_cast<double>(denseKeys) : 0.0;
}

KeysOutcome keyCurves(const InvertOutcome& outcome, const KeySettings& settings,
                      const std::function<void(double)>& progress)
{
    checkKeySettings(settings);
    KeysOutcome out;
    out.settings = settings;
    RigBinding binding(*outcome.approximation, *outcome.rig);
    const std::vector<double> frames = reportedFrames(outcome);
    KeyReductionOptions options;
    options.toleranceCm = settings.toleranceCm;
    options.toleranceDeg = settings.toleranceDeg;
    options.tangent = keyTangent(settings.tangent);
    // On CMU clips the uniform step's search costs about a sixth of the keys (its first step fails).
    if (progress) options.progress = [&](double fraction) { progress(0.85 * fraction); };
    out.keyed = reduceKeys(binding, frames, outcome.values, options);
    if (progress) options.progress = [&](double fraction) { progress(0.85 + 0.15 * fraction); };
    out.uniform = uniformKeys(binding, frames, outcome.values, options);
    out.denseKeys = frames.size() * outcome.approximation->parameters.size();
    return out;
}

std::string keyedCurvesJson(const InvertOutcome& outcome, const KeysOutcome& keys)
{
    const auto frames = reportedFrames(outcome);
    std::string out =
        fmt::format("{{\n  \"tangent\": \"{}\",\n  \"frames\": [{}, {}],\n  \"curves\": {{\n", keys.settings.tangent,
                    jsonText(numberJson(frames.front())), jsonText(numberJson(frames.back())));
    for (std::size_t p = 0; p < keys.keyed.keys.size(); ++p) {
        Json list = Json::array();
        for (const AnimKey& k : userKeys(parameter(outcome, p), keys.keyed.keys[p]))
            list.push_back(
                {numberJson(k.x), numberJson(k.y), tangentTypeName(k.inTangent), tangentTypeName(k.outTangent)});
        out += fmt::format("    {}: {}{}\n", jsonText(Json(parameter(outcome, p).name)), jsonText(list),
                           p + 1 < keys.keyed.keys.size() ? "," : "");
    }
    return out + "  }\n}\n";
}

std::string keyedCurvesCsv(const InvertOutcome& outcome, const KeysOutcome& keys)
{
    std::string out = "plug,frame,value,in_tangent,out_tangent\n";
    for (std::size_t p = 0; p < keys.keyed.keys.size(); ++p)
        for (const AnimKey& k : userKeys(parameter(outcome, p), keys.keyed.keys[p]))
            out += fmt::format("{},{},{},{},{}\n", parameter(outcome, p).name, k.x, k.y, tangentTypeName(k.inTangent),
                               tangentTypeName(k.outTangent));
    return out;
}

std::vector<AnimFileCurve> outputCurves(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent)
{
    const auto frames = reportedFrames(outcome);
    const auto dense = keys ? std::vector<std::vector<AnimKey>>{} : denseKeys(frames, outcome.values, tangent);
    std::vector<AnimFileCurve> curves;
    for (std::size_t p = 0; p < outcome.approximation->parameters.size(); ++p) {
        AnimFileCurve curve = plugCurve(outcome.rig->graph(), parameter(outcome, p).name);
        curve.keys = userKeys(parameter(outcome, p), keys ? keys->keyed.keys[p] : dense[p]);
        curves.push_back(std::move(curve));
    }
    return curves;
}

std::string curvesAnim(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent)
{
    const auto frames = reportedFrames(outcome);
    AnimFile file;
    // Key times are the clip's frames: the file says at what rate, when the clip does and Maya has a name for it.
    if (outcome.clip.frameTime > 0.0)
        if (const auto unit = mayaTimeUnit(1.0 / outcome.clip.frameTime)) file.timeUnit = *unit;
    file.startTime = frames.front();
    file.endTime = frames.back();
    file.curves = outputCurves(outcome, keys, tangent);
    return formatAnimFile(file);
}

Json keysReport(const InvertOutcome& outcome, const KeysOutcome& keys)
{
    const auto frames = reportedFrames(outcome);
    const auto& outputs = outcome.approximation->outputs;
    const KeyedError& e = keys.keyed.error;
    Json perControl = Json::object();
    for (std::size_t p = 0; p < keys.keyed.keys.size(); ++p)
        perControl[parameter(outcome, p).name] = keys.keyed.keys[p].size();
    const UniformKeys& u = keys.uniform;
    const double uniformReduction =
        keys.denseKeys > 0 ? 1.0 - static_cast<double>(u.keyCount) / static_cast<double>(keys.denseKeys) : 0.0;
    return Json{{"tolerance_cm", numberJson(keys.settings.toleranceCm)},
                {"tolerance_deg", numberJson(keys.settings.toleranceDeg)},
                {"tangent", keys.settings.tangent},
                {"dense_keys", keys.denseKeys},
                {"keys", keys.keyed.keyCount()},
                {"reduction", numberJson(keys.reduction())},
                // The real rig under the keyed curves against it under the dense ones.
                {"max_position_error_cm", numberJson(e.maxPositionCm)},
                {"max_rotation_error_deg", numberJson(e.maxRotationDeg)},
                {"worst_joint", outputs[static_cast<std::size_t>(e.worstOutputOverall)].name},
                {"worst_frame", numberJson(frames[static_cast<std::size_t>(e.worstFrame)])},
                {"rig_evaluations", keys.keyed.rigEvaluations},
                {"per_control", std::move(perControl)},
                {"uniform",
                 {{"step", u.step},
                  {"keys", u.keyCount},
                  {"constant_curves", u.constantCurves},
                  {"reduction", numberJson(uniformReduction)},
                  {"max_position_error_cm", numberJson(u.error.maxPositionCm)},
                  {"max_rotation_error_deg", numberJson(u.error.maxRotationDeg)}}}};
}

std::string keysText(const InvertOutcome& outcome, const KeysOutcome& keys)
{
    const auto frames = reportedFrames(outcome);
    const KeyedError& e = keys.keyed.error;
    const UniformKeys& u = keys.uniform;
    std::string out = fmt::format(
        "keys              {} for {} controls against {} dense keys (one per frame and control): {} fewer ({} "
        "tangents, tolerance {} cm, {} deg)\n",
        keys.keyed.keyCount(), keys.keyed.keys.size(), keys.denseKeys, percent(keys.reduction()), keys.settings.tangent,
        keys.settings.toleranceCm, keys.settings.toleranceDeg);
    out += fmt::format(
        "keyed error       worst {:.4g} cm, {:.4g} deg on the real rig against the dense curves ({} at "
        "frame {})\n",
        e.maxPositionCm, e.maxRotationDeg,
        outcome.approximation->outputs[static_cast<std::size_t>(e.worstOutputOverall)].name,
        frames[static_cast<std::size_t>(e.worstFrame)]);
    // The dense keys less the constant curves' keys after their first: the counts add up on the screen.
    if (u.step == 1)
        out += fmt::format(
            "uniform keys      no step over 1 frame holds the tolerance: a key on every frame, constant curves keyed "
            "once ({} of {}): {} keys\n",
            u.constantCurves, keys.keyed.keys.size(), u.keyCount);
    else
        out += fmt::format(
            "uniform keys      every {} frames: {} keys, {} fewer, at the same tolerance (worst {:.4g} "
            "cm, {:.4g} deg)\n",
            u.step, u.keyCount, percent(1.0 - static_cast<double>(u.keyCount) / static_cast<double>(keys.denseKeys)),
            u.error.maxPositionCm, u.error.maxRotationDeg);
    // Keys per control, as many to a line as fit.
    std::string line = "keys per control ";
    for (std::size_t p = 0; p < keys.keyed.keys.size(); ++p) {
        const std::string entry = fmt::format(" {} {}", parameter(outcome, p).name, keys.keyed.keys[p].size());
        if (line.size() + entry.size() > 110 && line.size() > 18) {
            out += line + "\n";
            line = std::string(17, ' ');
        }
        line += entry;
    }
    return out + line + "\n";
}

}  // namespace rig::app

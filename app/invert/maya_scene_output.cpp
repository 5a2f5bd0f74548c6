#include "app/invert/maya_scene_output.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/rig_file.h"
#include "nodes/clips/maya_clip.h"
#include "nodes/curves/maya_anim_writer.h"

namespace rig::app {
namespace {

std::string unitName(AnimQuantity quantity)
{
    return quantity == AnimQuantity::angular ? "deg" : quantity == AnimQuantity::linear ? "cm" : "";
}

// The time curve of the clip's scene that drives `plug` (the same name, or the same without namespaces where one
// curve has it), or none.
std::optional<std::size_t> sceneCurveOf(const ClipScene& scene, const std::string& plug)
{
    std::optional<std::size_t> bare;
    int bareCount = 0;
    const std::string name = withoutNamespaces(plug);
    for (std::size_t c = 0; c < scene.info.timeCurves.size(); ++c) {
        if (scene.curveValues[c].empty()) continue;
        const std::string& driven = scene.info.timeCurves[c].plug;
        if (driven == plug) return c;
        if (withoutNamespaces(driven) == name) {
            bare = c;
            ++bareCount;
        }
    }
    return bareCount == 1 ? bare : std::nullopt;
}

}  // namespace

std::vector<SceneCurveDifference> sceneCurveDifferences(const InvertOutcome& outcome)
{
    std::vector<SceneCurveDifference> out;
    const ClipScene* scene = outcome.clip.scene.get();
    if (!scene) return out;
    const auto& parameters = outcome.approximation->parameters;
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const RigParameter& parameter = parameters[p].parameter;
        const auto c = sceneCurveOf(*scene, parameter.name);
        if (!c) continue;
        SceneCurveDifference d{parameter.name, unitName(plugCurve(outcome.rig->graph(), parameter.name).output)};
        for (std::size_t f = 0; f < outcome.values.size(); ++f) {
            const std::size_t frame = static_cast<std::size_t>(outcome.first) + f;
            double difference = parameterUserValue(parameter, outcome.values[f][p]) -
                                parameterUserValue(parameter, scene->curveValues[*c][frame]);
            // A turn more or less on one rotation channel is the same pose.
            if (parameter.angular) difference = std::remainder(difference, 360.0);
            difference = std::abs(difference);
            if (f == 0 || !(difference <= d.worst)) {
                d.worst = difference;
                d.frame = outcome.clip.frameNumbers[frame];
            }
        }
        out.push_back(std::move(d));
    }
    std::stable_sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
        return std::isnan(a.worst) ? !std::isnan(b.worst) : a.worst > b.worst;
    });
    return out;
}

std::string sceneCurvesText(const std::vector<SceneCurveDifference>& differences)
{
    if (differences.empty()) return {};
    std::string out = fmt::format(
        "scene curves      {} controls the clip's own time curves drive: the recovered values' worst difference\n",
        differences.size());
    for (const auto& d : differences)
        out += fmt::format("                  {:<28} {:.4g}{}{} at frame {}\n", d.control, d.worst,
                           d.unit.empty() ? "" : " ", d.unit, d.frame);
    return out;
}

Json sceneCurvesJson(const std::vector<SceneCurveDifference>& differences)
{
    Json out = Json::object();
    for (const auto& d : differences)
        out[d.control] = {{"worst_difference", numberJson(d.worst)}, {"unit", d.unit}, {"frame", numberJson(d.frame)}};
    return out;
}

void checkMayaSceneOutput(const std::string& rig, const std::string& output)
{
    if (!isMayaFile(rig))
        throw Error(fmt::format(
            "-o {}: a Maya scene of curves references its rig's scene, and {} is not a Maya scene; write the curves "
            "as .anim, .json or .csv",
            output, rig));
}

namespace {

// The rig as OUT.ma references it: as the clip's scene did, where the clip is a scene that references this rig; else
// under the rig file's name. The path is relative to the output's folder when given relative (Maya, as graph-eval,
// resolves a relative reference from the referencing scene's folder).
void referenceRig(MayaAnimScene& scene, const InvertOutcome& outcome, const std::string& rig, const std::string& output)
{
    namespace fs = std::filesystem;
    std::error_code ec;
    if (outcome.clip.scene)
        for (const auto& ref : outcome.clip.scene->info.references)
            if (!ref.file.empty() && fs::equivalent(ref.file, rig, ec)) {
                scene.nameSpace = ref.nameSpace;
                scene.referenceNode = ref.node;
                break;
            }
    if (scene.nameSpace.empty()) scene.nameSpace = mayaName(fs::path(rig).stem().string());
    if (scene.referenceNode.empty()) scene.referenceNode = scene.nameSpace + "RN";
    const fs::path given(rig);
    const fs::path relative = fs::relative(fs::absolute(given), fs::absolute(output).parent_path(), ec);
    scene.rigPath = given.is_absolute() || ec || relative.empty() ? given.generic_string() : relative.generic_string();
}

std::vector<MayaHeldPlug> heldPlugs(const InvertOutcome& outcome)
{
    std::vector<MayaHeldPlug> out;
    for (const HeldPlug& held : outcome.approximation->held) {
        const AnimFileCurve plug = plugCurve(outcome.rig->graph(), held.plug);
        out.push_back({plug.node, plug.leaf, plug.output, held.value});
    }
    return out;
}

}  // namespace

std::string curvesMayaScene(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent,
                            const std::string& rig, const std::string& output)
{
    MayaAnimScene scene;
    scene.fileName = std::filesystem::path(output).filename().string();
    loadRigFile(rig, outcome.rig->graph().sharedRegistry(), nullptr, &scene.rig);
    referenceRig(scene, outcome, rig, output);
    // Key times are the clip's frames, at the clip scene's rate, or the clip's where Maya has a name for it.
    scene.timeUnit = outcome.clip.scene ? outcome.clip.scene->info.timeUnit : scene.rig.timeUnit;
    if (!outcome.clip.scene && outcome.clip.frameTime > 0.0)
        if (const auto unit = mayaTimeUnit(1.0 / outcome.clip.frameTime)) scene.timeUnit = *unit;
    scene.curves = outputCurves(outcome, keys, tangent);
    scene.held = heldPlugs(outcome);
    return formatMayaAnimScene(scene);
}

}  // namespace rig::app

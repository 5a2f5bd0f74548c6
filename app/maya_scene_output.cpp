#include "app/maya_scene_output.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/maya_clip.h"

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
    // The units of each parameter's plug, as the curves name them.
    const std::vector<AnimFileCurve> curves = outputCurves(outcome, nullptr, TangentType::linear);
    const auto& parameters = outcome.approximation->parameters;
    for (std::size_t p = 0; p < parameters.size(); ++p) {
        const RigParameter& parameter = parameters[p].parameter;
        const auto c = sceneCurveOf(*scene, parameter.name);
        if (!c) continue;
        SceneCurveDifference d{parameter.name, unitName(curves[p].output)};
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

// The namespace, the reference node and the path under which OUT.ma references the rig.
struct RigReference {
    std::string nameSpace, node, path;
};

// A Maya name made of a file's name: letters, digits and '_', not starting with a digit.
std::string mayaName(const std::string& text)
{
    std::string out;
    for (const char c : text) out += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    if (out.empty() || std::isdigit(static_cast<unsigned char>(out.front()))) out.insert(0, "_");
    return out;
}

RigReference rigReference(const InvertOutcome& outcome, const std::string& rig, const std::string& output)
{
    namespace fs = std::filesystem;
    RigReference r;
    std::error_code ec;
    // As the animation scene had it, where the clip is one that references this rig.
    if (outcome.clip.scene)
        for (const auto& ref : outcome.clip.scene->info.references)
            if (!ref.file.empty() && fs::equivalent(ref.file, rig, ec)) {
                r.nameSpace = ref.nameSpace;
                r.node = ref.node;
                break;
            }
    if (r.nameSpace.empty()) r.nameSpace = mayaName(fs::path(rig).stem().string());
    if (r.node.empty()) r.node = r.nameSpace + "RN";
    // Maya resolves a relative path from the referencing scene's folder (and so does graph-eval).
    const fs::path given(rig);
    const fs::path relative = fs::relative(fs::absolute(given), fs::absolute(output).parent_path(), ec);
    r.path = given.is_absolute() || ec || relative.empty() ? given.generic_string() : relative.generic_string();
    return r;
}

// A name of the rig's graph ("grp|ctrl", "ctrl.rotateX") under the namespace: each DAG component gets it.
std::string qualified(const std::string& nameSpace, const std::string& name)
{
    const std::size_t dot = name.find('.', name.rfind('|') == std::string::npos ? 0 : name.rfind('|'));
    std::string out;
    std::size_t start = 0;
    const std::size_t end = std::min(dot, name.size());
    while (start <= end) {
        const std::size_t bar = std::min(name.find('|', start), end);
        if (bar > start) out += nameSpace + ":" + name.substr(start, bar - start);
        if (bar < end) out += '|';
        start = bar + 1;
    }
    return out + (dot < name.size() ? name.substr(dot) : "");
}

// A MEL string literal.
std::string quoted(const std::string& text)
{
    std::string out = "\"";
    for (const char c : text) {
        if (c == '"' || c == '\\') out += '\\';
        out += c;
    }
    return out + "\"";
}

// The scale from user units (cm, degrees) to the rig scene's.
double toSceneUnits(const MayaSceneInfo& rig, AnimQuantity quantity)
{
    return quantity == AnimQuantity::angular  ? 1.0 / rig.angleToDegrees
           : quantity == AnimQuantity::linear ? 1.0 / rig.linearToCm
                                              : 1.0;
}

std::string curveNodeType(AnimQuantity quantity)
{
    return quantity == AnimQuantity::angular  ? "animCurveTA"
           : quantity == AnimQuantity::linear ? "animCurveTL"
                                              : "animCurveTU";
}

// One animCurve node with its keys, as Maya writes it.
std::string curveNode(const std::string& name, const AnimFileCurve& curve, double scale)
{
    const std::size_t n = curve.keys.size();
    std::string out =
        fmt::format("createNode {} -n {};\n\tsetAttr \".wgt\" no;\n", curveNodeType(curve.output), quoted(name));
    std::string times, inTypes, outTypes;
    for (const AnimKey& k : curve.keys) {
        times += fmt::format(" {} {}", k.x, k.y * scale);
        inTypes += fmt::format(" {}", mayaTangentCode(k.inTangent));
        outTypes += fmt::format(" {}", mayaTangentCode(k.outTangent));
    }
    out += fmt::format("\tsetAttr -s {} \".ktv[0:{}]\"{};\n", n, n - 1, times);
    out += fmt::format("\tsetAttr -s {} \".kit[0:{}]\"{};\n", n, n - 1, inTypes);
    out += fmt::format("\tsetAttr -s {} \".kot[0:{}]\"{};\n", n, n - 1, outTypes);
    return out;
}

// The rig scene's own time curves on the controls the curves drive: the reference edits that disconnect them.
std::vector<std::string> disconnections(const MayaSceneInfo& rig, const std::set<std::string>& controls,
                                        const std::string& nameSpace)
{
    // A DG node (a curve, a unitConversion) has no DAG path: a plug's node under the world is named by its leaf.
    const auto plug = [&](const std::string& text) {
        const std::string name = text.rfind('|') == 0 ? text.substr(1) : text;
        return quoted(qualified(nameSpace, name));
    };
    std::vector<std::string> edits;
    for (const auto& curve : rig.timeCurves)
        if (controls.count(curve.plug))
            edits.push_back(fmt::format("\t\t4 {} {} \"\"\n", plug(curve.source), plug(curve.destination)));
    return edits;
}

// The plugs the approximation was learned holding, set as reference edits (the rig is in that state in Maya too).
std::vector<std::string> heldEdits(const InvertOutcome& outcome, const MayaSceneInfo& rig, const std::string& nameSpace)
{
    const Graph& graph = outcome.rig->graph();
    std::vector<std::string> edits;
    for (const HeldPlug& held : outcome.approximation->held) {
        const Plug plug = graph.plug(held.plug);
        const AttributeSpec& spec = graph.spec(plug);
        const std::string attribute = plug.child >= 0
                                          ? spec.childNames[static_cast<std::size_t>(plug.child)]
                                          : spec.name + (plug.index >= 0 ? fmt::format("[{}]", plug.index) : "");
        const double scale = toSceneUnits(rig, spec.unit == Unit::Angle      ? AnimQuantity::angular
                                               : spec.unit == Unit::Distance ? AnimQuantity::linear
                                                                             : AnimQuantity::unitless);
        edits.push_back(fmt::format("\t\t2 {} {} \" {}\"\n", quoted(qualified(nameSpace, graph.nodeName(plug.node))),
                                    quoted(attribute), held.value * scale));
    }
    return edits;
}

// Unique curve node names as Maya makes them: the control's leaf name and the attribute.
std::vector<std::string> curveNames(const std::vector<AnimFileCurve>& curves)
{
    std::set<std::string> taken;
    std::vector<std::string> names;
    for (const auto& curve : curves) {
        const std::string leaf =
            curve.node.substr(curve.node.rfind('|') == std::string::npos ? 0 : curve.node.rfind('|') + 1);
        const std::string base = mayaName(withoutNamespaces(leaf) + "_" + curve.leaf);
        std::string name = base;
        for (int i = 1; !taken.insert(name).second; ++i) name = fmt::format("{}{}", base, i);
        names.push_back(name);
    }
    return names;
}

}  // namespace

std::string curvesMayaScene(const InvertOutcome& outcome, const KeysOutcome* keys, TangentType tangent,
                            const std::string& rig, const std::string& output)
{
    MayaSceneInfo rigInfo;
    loadRigFile(rig, outcome.rig->graph().sharedRegistry(), nullptr, &rigInfo);
    const RigReference ref = rigReference(outcome, rig, output);
    const std::vector<AnimFileCurve> curves = outputCurves(outcome, keys, tangent);
    const std::vector<std::string> names = curveNames(curves);
    const ClipScene* clipScene = outcome.clip.scene.get();
    std::string timeUnit = clipScene ? clipScene->info.timeUnit : rigInfo.timeUnit;
    if (!clipScene && outcome.clip.frameTime > 0.0)
        if (const auto unit = mayaTimeUnit(1.0 / outcome.clip.frameTime)) timeUnit = *unit;
    const double first = curves.front().keys.front().x, last = curves.front().keys.back().x;

    std::string out = fmt::format("//Maya ASCII 2018 scene\n//Name: {}\n//Codeset: UTF-8\n",
                                  std::filesystem::path(output).filename().string());
    for (const char* flags : {"-rdi 1 -ns", "-r -ns"})
        out +=
            fmt::format("file {} {} -rfn {} {};\n", flags, quoted(ref.nameSpace), quoted(ref.node), quoted(ref.path));
    out += "requires maya \"2018\";\n";
    out += fmt::format("currentUnit -l {} -a {} -t {};\n", rigInfo.linearUnit, rigInfo.angularUnit, timeUnit);
    out += "fileInfo \"application\" \"maya\";\nfileInfo \"rig-invert\" \"curves recovered from joint targets\";\n";

    std::set<std::string> controls;
    std::vector<std::string> edits = heldEdits(outcome, rigInfo, ref.nameSpace);
    for (const auto& curve : curves) controls.insert(curve.plugName());
    const auto disconnected = disconnections(rigInfo, controls, ref.nameSpace);
    edits.insert(edits.begin(), disconnected.begin(), disconnected.end());
    for (std::size_t c = 0; c < curves.size(); ++c)
        edits.push_back(fmt::format("\t\t5 4 {} {} {} \"\"\n", quoted(ref.node),
                                    quoted(qualified(ref.nameSpace, curves[c].plugName())),
                                    quoted(fmt::format("{}.placeHolderList[{}]", ref.node, c + 1))));
    out += fmt::format("createNode reference -n {};\n", quoted(ref.node));
    out += fmt::format("\tsetAttr \".ed\" -type \"dataReferenceEdits\" \n\t\t{}\n\t\t{} {}\n", quoted(ref.node),
                       quoted(ref.node), edits.size());
    for (const auto& edit : edits) out += edit;
    out += "\t\t;\n";
    for (std::size_t c = 0; c < curves.size(); ++c)
        out += curveNode(names[c], curves[c], toSceneUnits(rigInfo, curves[c].output));
    out += fmt::format(
        "createNode script -n \"sceneConfigurationScriptNode\";\n\tsetAttr \".b\" -type \"string\" "
        "\"playbackOptions -min {0} -max {1} -ast {0} -aet {1} \";\n\tsetAttr \".st\" 6;\n",
        first, last);
    out += fmt::format("select -ne :time1;\n\tsetAttr \".o\" {};\n", first);
    for (std::size_t c = 0; c < curves.size(); ++c)
        out += fmt::format("connectAttr {} {};\n", quoted(names[c] + ".o"),
                           quoted(fmt::format("{}.phl[{}]", ref.node, c + 1)));
    return out + fmt::format("// End of {}\n", std::filesystem::path(output).filename().string());
}

}  // namespace rig::app

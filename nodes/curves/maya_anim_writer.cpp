#include "nodes/curves/maya_anim_writer.h"

#include <algorithm>
#include <cctype>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "nodes/builtin_nodes.h"
#include "nodes/clips/maya_clip.h"

namespace rig {
namespace {

// A name of the rig's graph ("grp|ctrl", "grp|ctrl.rotateX") under the namespace: each DAG component gets it.
std::string qualified(const std::string& nameSpace, const std::string& name)
{
    const std::size_t lastBar = name.rfind('|');
    const std::size_t dot = name.find('.', lastBar == std::string::npos ? 0 : lastBar);
    const std::size_t end = std::min(dot, name.size());
    std::string out;
    std::size_t start = 0;
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

// The factor from cm or degrees to the rig scene's units.
double toSceneUnits(const MayaSceneInfo& rig, AnimQuantity quantity)
{
    return quantity == AnimQuantity::angular  ? 1.0 / rig.angleToDegrees
           : quantity == AnimQuantity::linear ? 1.0 / rig.linearToCm
                                              : 1.0;
}

// One animCurve node with its keys, as Maya writes it (a time curve: animCurveT + L, A or U).
std::string curveNode(const std::string& name, const AnimFileCurve& curve, double scale)
{
    const std::size_t n = curve.keys.size();
    std::string times, inTypes, outTypes;
    for (const AnimKey& k : curve.keys) {
        times += fmt::format(" {} {}", k.x, k.y * scale);
        inTypes += fmt::format(" {}", mayaTangentCode(k.inTangent));
        outTypes += fmt::format(" {}", mayaTangentCode(k.outTangent));
    }
    std::string out = fmt::format("createNode {} -n {};\n\tsetAttr \".wgt\" no;\n", curve.nodeTypeName(), quoted(name));
    if (n == 0) return out;
    out += fmt::format("\tsetAttr -s {} \".ktv[0:{}]\"{};\n", n, n - 1, times);
    out += fmt::format("\tsetAttr -s {} \".kit[0:{}]\"{};\n", n, n - 1, inTypes);
    out += fmt::format("\tsetAttr -s {} \".kot[0:{}]\"{};\n", n, n - 1, outTypes);
    return out;
}

// The edits that disconnect the rig scene's own time curves from the curves' plugs.
std::vector<std::string> disconnections(const MayaAnimScene& scene)
{
    std::set<std::string> plugs;
    for (const auto& curve : scene.curves) plugs.insert(curve.plugName());
    // A plug's node under the world is named by its leaf: a DG node (a curve, a unitConversion) has no DAG path.
    const auto plug = [&](const std::string& text) {
        return quoted(qualified(scene.nameSpace, text.rfind('|') == 0 ? text.substr(1) : text));
    };
    std::vector<std::string> edits;
    for (const auto& curve : scene.rig.timeCurves)
        if (plugs.count(curve.plug))
            edits.push_back(fmt::format("\t\t4 {} {} \"\"\n", plug(curve.source), plug(curve.destination)));
    return edits;
}

std::vector<std::string> edits(const MayaAnimScene& scene)
{
    std::vector<std::string> out = disconnections(scene);
    for (const MayaHeldPlug& held : scene.held)
        out.push_back(fmt::format("\t\t2 {} {} \" {}\"\n", quoted(qualified(scene.nameSpace, held.node)),
                                  quoted(held.attribute), held.value * toSceneUnits(scene.rig, held.quantity)));
    for (std::size_t c = 0; c < scene.curves.size(); ++c)
        out.push_back(fmt::format("\t\t5 4 {} {} {} \"\"\n", quoted(scene.referenceNode),
                                  quoted(qualified(scene.nameSpace, scene.curves[c].plugName())),
                                  quoted(fmt::format("{}.placeHolderList[{}]", scene.referenceNode, c + 1))));
    return out;
}

// Unique curve node names as Maya makes them: the control's leaf name (no namespace) and the attribute.
std::vector<std::string> curveNames(const std::vector<AnimFileCurve>& curves)
{
    std::set<std::string> taken;
    std::vector<std::string> names;
    for (const auto& curve : curves) {
        const std::size_t bar = curve.node.rfind('|');
        const std::string leaf = bar == std::string::npos ? curve.node : curve.node.substr(bar + 1);
        const std::string base = mayaName(withoutNamespaces(leaf) + "_" + curve.leaf);
        std::string name = base;
        for (int i = 1; !taken.insert(name).second; ++i) name = fmt::format("{}{}", base, i);
        names.push_back(name);
    }
    return names;
}

}  // namespace

std::string mayaName(const std::string& text)
{
    const bool digitFirst = !text.empty() && std::isdigit(static_cast<unsigned char>(text.front()));
    std::string out = text.empty() || digitFirst ? "_" : "";
    for (const char c : text) out += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
    return out;
}

std::string formatMayaAnimScene(const MayaAnimScene& scene)
{
    double first = std::numeric_limits<double>::infinity(), last = -first;
    for (const auto& curve : scene.curves)
        if (!curve.keys.empty()) {
            first = std::min(first, curve.keys.front().x);
            last = std::max(last, curve.keys.back().x);
        }
    if (first > last) first = last = 0.0;
    std::string out = fmt::format("//Maya ASCII 2018 scene\n//Name: {}\n//Codeset: UTF-8\n", scene.fileName);
    for (const char* flags : {"-rdi 1 -ns", "-r -ns"})
        out += fmt::format("file {} {} -rfn {} {};\n", flags, quoted(scene.nameSpace), quoted(scene.referenceNode),
                           quoted(scene.rigPath));
    out += "requires maya \"2018\";\n";
    out += fmt::format("currentUnit -l {} -a {} -t {};\n", scene.rig.linearUnit, scene.rig.angularUnit, scene.timeUnit);
    out += "fileInfo \"application\" \"maya\";\n";
    const std::vector<std::string> referenceEdits = edits(scene);
    out += fmt::format("createNode reference -n {};\n", quoted(scene.referenceNode));
    out += fmt::format("\tsetAttr \".ed\" -type \"dataReferenceEdits\" \n\t\t{}\n\t\t{} {}\n",
                       quoted(scene.referenceNode), quoted(scene.referenceNode), referenceEdits.size());
    for (const auto& edit : referenceEdits) out += edit;
    out += "\t\t;\n";
    const std::vector<std::string> names = curveNames(scene.curves);
    for (std::size_t c = 0; c < scene.curves.size(); ++c)
        out += curveNode(names[c], scene.curves[c], toSceneUnits(scene.rig, scene.curves[c].output));
    out += fmt::format(
        "createNode script -n \"sceneConfigurationScriptNode\";\n\tsetAttr \".b\" -type \"string\" "
        "\"playbackOptions -min {0} -max {1} -ast {0} -aet {1} \";\n\tsetAttr \".st\" 6;\n",
        first, last);
    out += fmt::format("select -ne :time1;\n\tsetAttr \".o\" {};\n", first);
    for (std::size_t c = 0; c < scene.curves.size(); ++c)
        out += fmt::format("connectAttr {} {};\n", quoted(names[c] + ".o"),
                           quoted(fmt::format("{}.phl[{}]", scene.referenceNode, c + 1)));
    return out + fmt::format("// End of {}\n", scene.fileName);
}

}  // namespace rig

#include "nodes/clips/bvh_rig.h"

#include <filesystem>
#include <map>
#include <set>

#include <fmt/format.h>

#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

namespace rig {
namespace {

bool nameChar(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == ':';
}

bool isDigit(char c) { return c >= '0' && c <= '9'; }

// The rig-file name rules: letters, digits, '_' and ':', not starting with a digit. Every other byte
// becomes '_'; a leading digit gets a '_' in front; an empty name becomes "joint".
std::string sanitize(const std::string& prefix, const std::string& name)
{
    std::string out = prefix;
    for (char c : name) out += nameChar(c) ? c : '_';
    if (out.empty()) out = "joint";
    if (isDigit(out[0])) out.insert(out.begin(), '_');
    return out;
}

// Hands out node names, adding _2, _3, ... to a name already taken.
class Names {
public:
    std::string take(const std::string& wanted)
    {
        std::string name = wanted;
        for (int n = 2; used_.count(name); ++n) name = fmt::format("{}_{}", wanted, n);
        used_.insert(name);
        return name;
    }

private:
    std::set<std::string> used_;
};

// One rig joint of a BVH joint's chain: its rotation channels (clip columns, file order) and the
// Maya rotate order that multiplies them in that order.
struct ChainLink {
    std::string name;
    std::vector<int> rotations;
    std::string order;
};

// A BVH joint's rotation channels, R = R1 * R2 * ... * Rn in file order, split into runs of distinct
// axes from the left. One joint applies a run [a1 .. am] exactly with the Maya order am ... a1 (the
// last channel is applied first) followed by the missing axes, which stay at zero: "Zrotation
// Xrotation Yrotation" gives yxz, "Zrotation Xrotation" gives xzy. A repeated axis starts a new run,
// played by a child joint at zero translation.
std::vector<std::vector<int>> rotationRuns(const BvhJoint& joint)
{
    std::vector<std::vector<int>> runs(1);
    std::set<int> axes;
    for (std::size_t k = 0; k < joint.channels.size(); ++k) {
        if (!bvhIsRotation(joint.channels[k])) continue;
        const int axis = bvhChannelAxis(joint.channels[k]);
        if (axes.count(axis)) {
            runs.emplace_back();
            axes.clear();
        }
        axes.insert(axis);
        runs.back().push_back(joint.firstChannel + static_cast<int>(k));
    }
    return runs;
}

std::string mayaOrder(const BvhJoint& joint, const std::vector<int>& run)
{
    std::string order;
    for (auto it = run.rbegin(); it != run.rend(); ++it)
        order += "xyz"[bvhChannelAxis(joint.channels[static_cast<std::size_t>(*it - joint.firstChannel)])];
    for (char axis : std::string("xyz"))
        if (order.find(axis) == std::string::npos) order += axis;
    return order;
}

std::string vec(const Eigen::Vector3d& v) { return fmt::format("[{}, {}, {}]", v.x(), v.y(), v.z()); }

std::string singleQuoted(const std::string& text)
{
    std::string out = "'";
    for (char c : text) out += c == '\'' ? std::string("''") : std::string(1, c);
    return out + "'";
}

std::string positionRule(const BvhClip& clip, bool root)
{
    bool any = false;
    bool replace = false;
    for (const BvhJoint& j : clip.joints) {
        if ((j.parent < 0) != root) continue;
        for (BvhChannel c : j.channels)
            if (!bvhIsRotation(c)) {
                any = true;
                replace = j.positionReplacesOffset;
            }
    }
    if (!any) return "none";
    return replace ? "the whole local translation (replacing OFFSET)" : "offsets added to OFFSET";
}

// What the rig's nodes are called and what the clip's channels drive: the BVH joints first, so that they
// keep their names when something else would clash, then their helper joints, End Sites and the clip node.
struct RigLayout {
    std::vector<std::string> jointName;
    std::vector<std::pair<std::string, std::string>> renamed;  // BVH name -> node name, where they differ
    std::vector<std::vector<ChainLink>> chains;                // per BVH joint: helpers first, the joint last
    std::vector<std::string> endName;                          // per BVH joint, its End Site's ("" for none)
    std::string clipName;
    std::vector<std::string> plugOf;  // channel k -> the plug it drives
    int endSites = 0;
    int helpers = 0;
};

// Node names have a length limit (GraphModel::maxNameLength); BVH names are cut to fit with this prefix.
void checkPrefix(const std::string& prefix)
{
    if (prefix.size() > 100)
        throw Error(fmt::format("--prefix: {} characters is too long (at most 100)", prefix.size()));
    for (char c : prefix)
        if (!nameChar(c))
            throw Error(fmt::format("--prefix '{}': use letters, digits, '_' and ':' (e.g. --prefix mocap:)", prefix));
    if (!prefix.empty() && isDigit(prefix[0]))
        throw Error(fmt::format("--prefix '{}': a node name cannot start with a digit", prefix));
}

// Names taken in the order above, a name already taken getting _2, _3, ...: the BVH joints keep theirs.
void nameNodes(const BvhClip& clip, const std::string& prefix, RigLayout& layout)
{
    Names names;
    for (const BvhJoint& j : clip.joints) {
        layout.jointName.push_back(names.take(sanitize(prefix, j.name)));
        if (layout.jointName.back() != prefix + j.name) layout.renamed.emplace_back(j.name, layout.jointName.back());
    }
    layout.chains.resize(clip.joints.size());
    layout.endName.resize(clip.joints.size());
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        const auto runs = rotationRuns(clip.joints[j]);
        const std::string& name = layout.jointName[j];
        for (std::size_t r = 0; r < runs.size(); ++r) {
            ChainLink link;
            link.name = r + 1 == runs.size() ? name : names.take(fmt::format("{}_rot{}", name, r + 1));
            link.rotations = runs[r];
            link.order = mayaOrder(clip.joints[j], runs[r]);
            layout.chains[j].push_back(std::move(link));
        }
        if (clip.joints[j].endSite) layout.endName[j] = names.take(name + "_end");
    }
    layout.clipName = names.take(prefix + "clip");
}

// Channel k -> the plug it drives: a position channel the chain's first joint's translate, a rotation
// channel the rotate of the link that plays it.
void connectChannels(const BvhClip& clip, RigLayout& layout)
{
    layout.plugOf.assign(static_cast<std::size_t>(clip.channelCount), std::string());
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        const BvhJoint& joint = clip.joints[j];
        const auto& chain = layout.chains[j];
        for (std::size_t k = 0; k < joint.channels.size(); ++k) {
            const auto column = static_cast<std::size_t>(joint.firstChannel) + k;
            const char axis = "XYZ"[bvhChannelAxis(joint.channels[k])];
            if (!bvhIsRotation(joint.channels[k])) {
                layout.plugOf[column] = fmt::format("{}.translate{}", chain.front().name, axis);
                continue;
            }
            for (const ChainLink& link : chain)
                for (int c : link.rotations)
                    if (static_cast<std::size_t>(c) == column)
                        layout.plugOf[column] = fmt::format("{}.rotate{}", link.name, axis);
        }
    }
}

// A clip within the reader's limits can still ask for a rig too big to load (every joint with 64
// rotation channels repeating one axis): the rig files' size and memory stay bounded.
void countJoints(const BvhClip& clip, const std::string& clipFile, RigLayout& layout)
{
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        layout.endSites += clip.joints[j].endSite ? 1 : 0;
        layout.helpers += static_cast<int>(layout.chains[j].size()) - 1;
    }
    constexpr std::size_t maxRigJoints = 50'000;
    if (const std::size_t total = clip.joints.size() + static_cast<std::size_t>(layout.endSites + layout.helpers);
        total > maxRigJoints)
        throw Error(
            fmt::format("{}: the rig would have {} joints ({} BVH joints, {} End Sites, {} helpers for rotation "
                        "channels that repeat an axis), more than {}; this clip is not a skeleton",
                        clipFile, total, clip.joints.size(), layout.endSites, layout.helpers, maxRigJoints));
}

// The file's header comment: where the rig comes from, its rules, renames and the channels' plugs.
std::string headerComment(const BvhClip& clip, const std::string& clipFile, const RigLayout& layout,
                          const BvhRigOptions& options)
{
    std::string text;
    text += fmt::format(
        "# Generated by skel2rig from {} ({} joints, {} End Sites, {} channels, {} frames, frame "
        "time {} s).\n",
        oneLine(std::filesystem::path(clipFile).filename().string()), clip.joints.size(), layout.endSites,
        clip.channelCount, clip.frameCount, clip.frameTime);
    if (!options.source.empty()) text += fmt::format("# Source: {}.\n", oneLine(options.source));
    text +=
        "# A forward-kinematics rig: one joint per BVH joint (translate = OFFSET, rotateOrder from the order of\n"
        "# its rotation channels), each End Site a leaf joint named <joint>_end. See docs/bvh.md.\n";
    if (layout.helpers > 0)
        text += fmt::format(
            "# {} helper joints (<joint>_rotN, zero translation) play rotation channels that repeat an "
            "axis.\n",
            layout.helpers);
    text += fmt::format("# Position channels: root: {}; other joints: {}.\n", positionRule(clip, true),
                        positionRule(clip, false));
    // A comment is one line: a file name with a newline in it must not end it.
    for (const auto& w : clip.warnings) text += fmt::format("# Warning: {}\n", oneLine(w));
    if (!layout.renamed.empty()) {
        text += "# Renamed to fit the rig-file name rules (letters, digits, _ and :):\n";
        for (const auto& [from, to] : layout.renamed) text += fmt::format("#   '{}' -> {}\n", from, to);
    }
    text += fmt::format(
        "# Parameters ({}): the plugs the clip's channels set, channel k of a motion line -> plug.\n"
        "# Rotations in degrees; positions are the whole local translate in cm.\n",
        clip.channelCount);
    for (const BvhJoint& joint : clip.joints)
        for (std::size_t k = 0; k < joint.channels.size(); ++k) {
            const auto column = static_cast<std::size_t>(joint.firstChannel) + k;
            text += fmt::format("#   [{}] {}.{} -> {}\n", column, joint.name, bvhChannelName(joint.channels[k]),
                                layout.plugOf[column]);
        }
    return text;
}

// The joints: each BVH joint's chain under its parent, then its End Site.
std::string jointNodes(const BvhClip& clip, const RigLayout& layout)
{
    std::string text;
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        const BvhJoint& joint = clip.joints[j];
        std::string parent =
            joint.parent < 0 ? std::string() : layout.jointName[static_cast<std::size_t>(joint.parent)];
        for (std::size_t r = 0; r < layout.chains[j].size(); ++r) {
            const ChainLink& link = layout.chains[j][r];
            std::string line = fmt::format("  - {{name: \"{}\", type: joint", link.name);
            if (!parent.empty()) line += fmt::format(", parent: \"{}\"", parent);
            if (r == 0) line += fmt::format(", translate: {}", vec(joint.offset));
            if (!link.rotations.empty()) line += fmt::format(", rotateOrder: {}", link.order);
            text += line + "}\n";
            parent = link.name;
        }
        if (joint.endSite)
            text += fmt::format("  - {{name: \"{}\", type: joint, parent: \"{}\", translate: {}}}\n", layout.endName[j],
                                layout.jointName[j], vec(*joint.endSite));
    }
    return text;
}

// --with-motion: a clip node (bvhClip, or skeletonClip playing the take) reading the clip by absolute path, its
// channels connected to their plugs.
std::string motionNodes(const std::string& clipFile, const RigLayout& layout, const BvhRigOptions& options)
{
    const auto path = std::filesystem::absolute(clipFile).lexically_normal();
    std::string text = options.general
                           ? fmt::format("  - {{name: \"{}\", type: skeletonClip, file: {}, take: {}}}\n",
                                         layout.clipName, singleQuoted(path.string()), singleQuoted(options.take))
                           : fmt::format("  - {{name: \"{}\", type: bvhClip, file: {}}}\n", layout.clipName,
                                         singleQuoted(path.string()));
    text += "connections:\n";
    for (std::size_t k = 0; k < layout.plugOf.size(); ++k)
        text += fmt::format("  - \"{}.channel[{}] -> {}\"\n", layout.clipName, k, layout.plugOf[k]);
    return text;
}

}  // namespace

BvhRig bvhRig(const BvhClip& clip, const std::string& clipFile, const BvhRigOptions& options)
{
    checkPrefix(options.prefix);
    RigLayout layout;
    nameNodes(clip, options.prefix, layout);
    connectChannels(clip, layout);
    countJoints(clip, clipFile, layout);
    std::string text = headerComment(clip, clipFile, layout, options) + "nodes:\n" + jointNodes(clip, layout);
    if (options.withMotion) text += motionNodes(clipFile, layout, options);

    // The rig must load; anything else is a bug here, not in the user's file.
    try {
        loadGraphText(text, clipFile + " (its rig)", makeBuiltinRegistry());
    }
    catch (const Error& e) {
        throw internalError(fmt::format("the generated rig does not load: {}", e.what()));
    }
    BvhRig rig;
    rig.text = std::move(text);
    rig.joints = static_cast<int>(clip.joints.size()) + layout.endSites + layout.helpers;
    rig.endSites = layout.endSites;
    rig.helpers = layout.helpers;
    if (options.withMotion) rig.clipNode = layout.clipName;
    return rig;
}

std::vector<std::string> bvhRigJointNames(const BvhClip& clip)
{
    RigLayout layout;
    nameNodes(clip, "", layout);
    return layout.jointName;
}

}  // namespace rig

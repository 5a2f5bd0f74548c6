#include "adapter/first_map.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "core/error.h"
#include "core/rotation_math.h"

namespace rig {
namespace {

bool isSeparator(char c) { return c == '_' || c == '.' || c == ' ' || c == '-'; }

std::string lower(std::string text)
{
    for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return text;
}

std::string withoutNamespace(const std::string& name)
{
    const auto cut = name.find_last_of(":|");
    return cut == std::string::npos ? name : name.substr(cut + 1);
}

// The prefix every joint of a skeleton shares up to a separator ("mixamorig_", "Bip01 "), which names do not
// carry from one skeleton to another; "" for none.
std::string commonPrefix(const std::vector<std::string>& joints)
{
    if (joints.size() < 2) return "";
    std::string prefix = withoutNamespace(joints.front());
    for (const auto& joint : joints) {
        const std::string name = withoutNamespace(joint);
        std::size_t n = 0;
        while (n < prefix.size() && n < name.size() && prefix[n] == name[n]) ++n;
        prefix.resize(n);
    }
    while (!prefix.empty() && !isSeparator(prefix.back())) prefix.pop_back();
    return prefix;
}

// The side a name's start or end gives (Left, L_, LThumb; _l, .R, Left at the end), taken off `name`; 0 for none.
char takeSide(std::string& name)
{
    const std::string low = lower(name);
    for (const char* word : {"left", "right"}) {
        const std::string w = word;
        if (low.size() > w.size() && low.starts_with(w)) {
            name.erase(0, w.size());
            return w[0];
        }
        if (low.size() > w.size() && low.ends_with(w)) {
            name.erase(name.size() - w.size());
            return w[0];
        }
    }
    const char first = low.empty() ? 0 : low[0];
    if ((first == 'l' || first == 'r') && name.size() > 1 &&
        (isSeparator(name[1]) || std::isupper(static_cast<unsigned char>(name[1])))) {
        name.erase(0, 1);
        return first;
    }
    const char last = low.empty() ? 0 : low.back();
    if ((last == 'l' || last == 'r') && name.size() > 2 && isSeparator(name[name.size() - 2])) {
        name.erase(name.size() - 1);
        return last;
    }
    return 0;
}

std::string yamlName(const std::string& name)
{
    const bool plain = !name.empty() && (std::isalpha(static_cast<unsigned char>(name[0])) || name[0] == '_') &&
                       std::all_of(name.begin(), name.end(),
                                   [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
    static const std::vector<std::string> words{"y", "n", "yes", "no", "on", "off", "true", "false", "null"};
    if (plain && std::find(words.begin(), words.end(), lower(name)) == words.end()) return name;
    std::string quoted = "\"";
    for (const char c : name) {
        if (c == '"' || c == '\\') quoted += '\\';
        quoted += c;
    }
    return quoted + "\"";
}

// Comma-separated names as comment lines of at most 120 columns, each starting with `lead`.
std::string commentList(const std::string& lead, const std::vector<std::string>& names)
{
    std::string out, line = lead;
    for (std::size_t i = 0; i < names.size(); ++i) {
        const std::string item = names[i] + (i + 1 < names.size() ? "," : "");
        if (line.size() + 1 + item.size() > 120) {
            out += line + "\n";
            line = "#  ";
        }
        line += " " + item;
    }
    return out + line + "\n";
}

struct Matching {
    std::vector<int> rigOf;   // per clip joint its rig joint, -1 for none
    std::vector<int> clipOf;  // per rig joint its clip joint
    std::vector<std::string> how;
    void match(int c, int r, std::string why)
    {
        rigOf[static_cast<std::size_t>(c)] = r;
        clipOf[static_cast<std::size_t>(r)] = c;
        how[static_cast<std::size_t>(c)] = std::move(why);
    }
};

void matchByName(const RigSkeleton& clip, const RigSkeleton& rig, Matching& m)
{
    for (std::size_t c = 0; c < clip.joints.size(); ++c) {
        const auto it = std::find(rig.joints.begin(), rig.joints.end(), clip.joints[c]);
        if (it != rig.joints.end()) m.match(static_cast<int>(c), static_cast<int>(it - rig.joints.begin()), "same");
    }
    // Keys that name one unmatched joint on each side.
    const auto keys = [](const RigSkeleton& s, const std::vector<int>& matched) {
        const std::string prefix = commonPrefix(s.joints);
        std::map<std::string, std::vector<int>> out;
        for (std::size_t j = 0; j < s.joints.size(); ++j)
            if (matched[j] < 0) out[jointKey(s.joints[j], prefix)].push_back(static_cast<int>(j));
        return out;
    };
    const auto clipKeys = keys(clip, m.rigOf);
    const auto rigKeys = keys(rig, m.clipOf);
    for (const auto& [key, joints] : clipKeys) {
        const auto it = rigKeys.find(key);
        if (joints.size() == 1 && it != rigKeys.end() && it->second.size() == 1)
            m.match(joints[0], it->second[0], "by name (case, prefix or side convention)");
    }
}

// The unmatched joints whose parent is `parent` (-1: the roots).
std::vector<int> unmatchedChildren(const RigSkeleton& s, const std::vector<int>& matched, int parent)
{
    std::vector<int> out;
    for (std::size_t j = 0; j < s.parents.size(); ++j)
        if (s.parents[j] == parent && matched[j] < 0) out.push_back(static_cast<int>(j));
    return out;
}

void matchByHierarchy(const RigSkeleton& clip, const RigSkeleton& rig, Matching& m)
{
    // Roots are matched by hierarchy only between skeletons that names already relate.
    const bool related = std::any_of(m.rigOf.begin(), m.rigOf.end(), [](int r) { return r >= 0; });
    for (bool more = true; more;) {
        more = false;
        for (std::size_t c = 0; c < clip.joints.size(); ++c) {
            const int parent = clip.parents[c];
            if (m.rigOf[c] >= 0 || (parent < 0 && !related) ||
                (parent >= 0 && m.rigOf[static_cast<std::size_t>(parent)] < 0))
                continue;
            const int rigParent = parent < 0 ? -1 : m.rigOf[static_cast<std::size_t>(parent)];
            const auto clipSiblings = unmatchedChildren(clip, m.rigOf, parent);
            const auto rigChildren = unmatchedChildren(rig, m.clipOf, rigParent);
            if (clipSiblings.size() != 1 || rigChildren.size() != 1) continue;
            m.match(static_cast<int>(c), rigChildren[0],
                    parent < 0 ? "by hierarchy: the only unmatched root"
                               : fmt::format("by hierarchy: the only unmatched child of {}", clip.joints[parent]));
            more = true;
        }
    }
}

Eigen::Vector3d position(const RigSkeleton& s, int j) { return s.rest[static_cast<std::size_t>(j)].block<3, 1>(0, 3); }

// The scale (clip units to cm: the median over the matched bones of the rig's length over the clip's) and what
// tells the proportions or rest orientations apart (empty when they agree).
std::pair<double, std::string> measureScale(const RigSkeleton& clip, const RigSkeleton& rig, const Matching& m,
                                            int& bones)
{
    struct Bone {
        int joint;
        double ratio;
        double angle;  // between the bone's rest directions, degrees
    };
    std::vector<Bone> all;
    for (std::size_t c = 0; c < clip.joints.size(); ++c) {
        const int p = clip.parents[c];
        if (p < 0 || m.rigOf[c] < 0 || m.rigOf[static_cast<std::size_t>(p)] < 0) continue;
        const Eigen::Vector3d a = position(clip, static_cast<int>(c)) - position(clip, p);
        const Eigen::Vector3d b = position(rig, m.rigOf[c]) - position(rig, m.rigOf[static_cast<std::size_t>(p)]);
        if (a.norm() < 1e-9 || b.norm() < 1e-9) continue;
        const double cosine = std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0);
        all.push_back({static_cast<int>(c), b.norm() / a.norm(), std::acos(cosine) * 180.0 / std::numbers::pi});
    }
    bones = static_cast<int>(all.size());
    if (all.empty()) return {1.0, ""};
    std::vector<double> ratios;
    for (const auto& b : all) ratios.push_back(b.ratio);
    std::nth_element(ratios.begin(), ratios.begin() + static_cast<long>(ratios.size() / 2), ratios.end());
    const double scale = ratios[ratios.size() / 2];
    // Two per cent of a bone's length, or five degrees of its direction or of a joint's rest orientation.
    for (const auto& b : all)
        if (std::abs(b.ratio / scale - 1.0) > 0.02 || b.angle > 5.0)
            return {scale, fmt::format("{}'s bone is {:.3g} times the scale, {:.2g} degrees off",
                                       clip.joints[static_cast<std::size_t>(b.joint)], b.ratio / scale, b.angle)};
    for (std::size_t c = 0; c < clip.joints.size(); ++c)
        if (m.rigOf[c] >= 0 && orientationAngle(clip.rest[c].block<3, 3>(0, 0),
                                                rig.rest[static_cast<std::size_t>(m.rigOf[c])].block<3, 3>(0, 0)) >
                                   5.0 * std::numbers::pi / 180.0)
            return {scale, fmt::format("{}'s rest orientation is not the rig's", clip.joints[c])};
    return {scale, ""};
}

// A leg for rootScale auto: a matched rig joint named as a foot or ankle (the left one first) and its two parents,
// all matched; empty for none.
std::vector<std::string> findLeg(const RigSkeleton& rig, const Matching& m)
{
    for (const char side : {'l', 'r', '\0'})
        for (std::size_t r = 0; r < rig.joints.size(); ++r) {
            const std::string key = jointKey(rig.joints[r], commonPrefix(rig.joints));
            const bool sided = key.size() > 2 && key[1] == ':';
            if ((side ? !sided || key[0] != side : sided) || m.clipOf[r] < 0) continue;
            if (key.find("toe") != std::string::npos ||
                (key.find("foot") == std::string::npos && key.find("ankle") == std::string::npos))
                continue;
            const int knee = rig.parents[r];
            const int hip = knee < 0 ? -1 : rig.parents[static_cast<std::size_t>(knee)];
            if (hip < 0 || m.clipOf[static_cast<std::size_t>(knee)] < 0 || m.clipOf[static_cast<std::size_t>(hip)] < 0)
                continue;
            return {rig.joints[static_cast<std::size_t>(hip)], rig.joints[static_cast<std::size_t>(knee)],
                    rig.joints[r]};
        }
    return {};
}

}  // namespace

std::string jointKey(const std::string& name, const std::string& prefix)
{
    std::string n = withoutNamespace(name);
    if (!prefix.empty() && n.starts_with(prefix) && n.size() > prefix.size()) n.erase(0, prefix.size());
    const char side = takeSide(n);
    std::string key = side ? std::string{side, ':'} : std::string();
    for (const char c : n)
        if (!isSeparator(c)) key += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return key;
}

RigSkeleton rigFileSkeleton(const std::filesystem::path& rigFile)
{
    GraphRigOptions options;
    options.parameterGlobs = {"*.*"};
    GraphRigFunction function(rigFile, options);
    RigSkeleton rig;
    rig.joints = function.outputs();
    rig.parents = function.outputParents();
    std::vector<double> values;
    for (const auto& p : function.parameters()) values.push_back(p.defaultValue);
    function.evaluate(values, rig.rest);
    return rig;
}

FirstMap firstMap(const RigSkeleton& clip, const std::string& clipFile, const RigSkeleton& rig,
                  const std::string& rigFile)
{
    Matching m{std::vector<int>(clip.joints.size(), -1), std::vector<int>(rig.joints.size(), -1),
               std::vector<std::string>(clip.joints.size())};
    matchByName(clip, rig, m);
    matchByHierarchy(clip, rig, m);
    FirstMap out;
    std::string renames;
    std::vector<std::string> same, rigLeft;
    for (std::size_t c = 0; c < clip.joints.size(); ++c) {
        if (m.rigOf[c] < 0) {
            out.unmatched.push_back(clip.joints[c]);
        } else if (m.how[c] == "same") {
            ++out.sameName;
            same.push_back(clip.joints[c]);
        } else {
            ++(m.how[c].starts_with("by name") ? out.byName : out.byHierarchy);
            renames += fmt::format("  {}: {}  # {}\n", yamlName(clip.joints[c]),
                                   yamlName(rig.joints[static_cast<std::size_t>(m.rigOf[c])]), m.how[c]);
        }
    }
    for (std::size_t r = 0; r < rig.joints.size(); ++r)
        if (m.clipOf[r] < 0) rigLeft.push_back(rig.joints[r]);
    int bones = 0;
    const auto [scale, differs] = measureScale(clip, rig, m, bones);
    out.scale = scale;
    std::string& text = out.text;
    text = fmt::format(
        "# A first map, written by skel2rig --map-for for a person to edit (docs/retargeting.md)\n"
        "#   from the skeleton of {}\n#   to the joints of {}\n"
        "# {} joints by the same name, {} by name up to case, prefix and side, {} by hierarchy, {} left for a "
        "person.\n",
        clipFile, rigFile, out.sameName, out.byName, out.byHierarchy, out.unmatched.size());
    text += fmt::format(
        "scale: {:.10g}  # clip units to cm: the median of the rig's bone lengths over the clip's "
        "({} bones)\n",
        scale, bones);
    if (!same.empty()) text += commentList("# the same name:", same);
    if (!renames.empty()) text += "joints:\n" + renames;
    if (!out.unmatched.empty())
        text += commentList("# left for a person (no rig joint by name or hierarchy: not targets unless renamed):",
                            out.unmatched);
    if (!rigLeft.empty()) text += commentList("# rig joints no clip joint matched:", rigLeft);
    if (differs.empty()) return out;
    out.retarget = true;
    text += fmt::format("# the proportions or rest poses differ: {}\nretarget:\n", differs);
    const auto leg = findLeg(rig, m);
    if (leg.empty())
        text +=
            "  rootScale: 1  # no foot or ankle with two matched parents: give the rig's leg length over the "
            "clip's, or name a leg and say auto\n";
    else
        text += fmt::format(
            "  rootScale: auto  # the rig's leg length over the clip's, along the leg\n"
            "  leg: [{}, {}, {}]\n",
            yamlName(leg[0]), yamlName(leg[1]), yamlName(leg[2]));
    return out;
}

}  // namespace rig

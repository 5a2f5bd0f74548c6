#include "nodes/clips/target_clip.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "graph/error.h"
#include "nodes/clips/bvh.h"

namespace rig {
namespace {

std::string where(const std::string& file, const YAML::Node& node)
{
    const auto mark = node.Mark();
    if (mark.line < 0) return file;
    return formatMark({file, mark.line + 1, mark.column + 1});
}

std::string readText(const std::filesystem::path& file, std::string_view what)
{
    std::error_code ec;
    if (!std::filesystem::exists(file, ec))
        throw Error(fmt::format("{}: no such {}; check the path", file.string(), what));
    if (std::filesystem::is_directory(file, ec))
        throw Error(fmt::format("{}: is a folder, not a {}", file.string(), what));
    if (std::filesystem::file_size(file, ec) > bvhMaxFileBytes)
        throw Error(fmt::format("{}: more than the {} MB a {} may have; cut it into shorter files", file.string(),
                                bvhMaxFileBytes >> 20, what));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(fmt::format("{}: cannot be read; check its permissions", file.string()));
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

YAML::Node parseYaml(const std::string& text, const std::string& file)
{
    try {
        return YAML::Load(text);
    }
    catch (const YAML::ParserException& e) {
        throw Error(fmt::format("{}: {}", formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.msg));
    }
}

double finiteNumber(const YAML::Node& node, const std::string& file, std::string_view what)
{
    double value = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, value))
        throw Error(fmt::format("{}: {} must be a number, got '{}'", where(file, node), what,
                                node.IsScalar() ? messageExcerpt(node.Scalar()) : std::string("a list or map")));
    if (!std::isfinite(value))
        throw Error(fmt::format("{}: {} is not a finite number", where(file, node), what));
    return value;
}

std::string rigName(const std::string& joint, const TargetMap& map)
{
    const auto it = map.rename.find(joint);
    return it == map.rename.end() ? joint : it->second;
}

// Keeps the joints the map does not ignore, renamed; checks that every name the map gives is in the clip.
std::vector<int> applyMap(const std::vector<std::string>& fileJoints, const std::string& clipFile,
                          const TargetMap& map, std::vector<std::string>& names)
{
    const std::set<std::string> present(fileJoints.begin(), fileJoints.end());
    for (const auto& [from, to] : map.rename)
        if (!present.count(from))
            throw Error(fmt::format("{}:{}: the map renames '{}', which {} does not have; check the joint name",
                                    map.file, map.renameLines.at(from), from, clipFile));
    for (const auto& joint : map.ignore)
        if (!present.count(joint))
            throw Error(fmt::format("{}: the map ignores '{}', which {} does not have; check the joint name", map.file,
                                    joint, clipFile));
    std::vector<int> kept;
    std::set<std::string> seen;
    for (int j = 0; j < static_cast<int>(fileJoints.size()); ++j) {
        if (std::find(map.ignore.begin(), map.ignore.end(), fileJoints[j]) != map.ignore.end()) continue;
        const std::string name = rigName(fileJoints[j], map);
        if (!seen.insert(name).second)
            throw Error(fmt::format("{}: two target joints become '{}'; rename or ignore one of them in the map",
                                    clipFile, name));
        kept.push_back(j);
        names.push_back(name);
    }
    return kept;
}

TargetClip readBvhTargets(const std::filesystem::path& file, const TargetMap& map)
{
    const BvhClip bvh = readBvhFile(file);
    std::vector<std::string> fileJoints;
    for (const auto& joint : bvh.joints) fileJoints.push_back(joint.name);
    TargetClip clip;
    clip.file = file.string();
    const auto kept = applyMap(fileJoints, clip.file, map, clip.joints);
    for (int f = 0; f < bvh.frameCount; ++f) {
        const auto worlds = bvhWorldMatrices(bvh, f);
        auto& frame = clip.worlds.emplace_back();
        for (const int j : kept) {
            Eigen::Matrix4d m = worlds[j];
            m.block<3, 1>(0, 3) *= map.scale;
            frame.push_back(m);
        }
        clip.frameNumbers.push_back(f + 1);
    }
    return clip;
}

Eigen::Matrix4d readMatrix(const YAML::Node& node, const std::string& file, const std::string& what)
{
    if (!node.IsSequence() || node.size() != 4)
        throw Error(fmt::format("{}: {} must be a matrix as four rows of four numbers", where(file, node), what));
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
        if (!node[r].IsSequence() || node[r].size() != 4)
            throw Error(fmt::format("{}: {} must be a matrix as four rows of four numbers", where(file, node[r]), what));
        for (int c = 0; c < 4; ++c)
            // null is how graph-eval writes a number that is not finite: a target the solver reports
            // as invalid for that frame, not a broken file.
            m(r, c) = node[r][c].IsNull() ? std::numeric_limits<double>::quiet_NaN()
                                          : finiteNumber(node[r][c], file, what);
    }
    return m;
}

TargetClip readJsonTargets(const std::filesystem::path& file, const TargetMap& map)
{
    TargetClip clip;
    clip.file = file.string();
    const YAML::Node root = parseYaml(readText(file, "JSON clip"), clip.file);
    if (!root.IsSequence() || root.size() == 0)
        throw Error(fmt::format("{}: expected a list of frames as graph-eval writes them ([{{\"frame\": 1, "
                                "\"hips.worldMatrix\": [[...], ...]}}, ...])",
                                where(clip.file, root)));
    static constexpr std::string_view suffix = ".worldMatrix";
    std::vector<std::string> fileJoints;
    for (const auto& entry : root[0]) {
        const auto key = entry.first.as<std::string>();
        if (key == "frame") continue;
        if (!key.ends_with(suffix))
            throw Error(fmt::format("{}: '{}' is not a joint's world matrix (NODE.worldMatrix); ask graph-eval for "
                                    "--get '*.worldMatrix' only",
                                    where(clip.file, entry.first), key));
        fileJoints.push_back(key.substr(0, key.size() - suffix.size()));
    }
    if (fileJoints.empty())
        throw Error(fmt::format("{}: the first frame has no NODE.worldMatrix entries", where(clip.file, root[0])));
    const auto kept = applyMap(fileJoints, clip.file, map, clip.joints);
    for (const auto& frameNode : root) {
        if (!frameNode.IsMap())
            throw Error(fmt::format("{}: a frame must be a map with \"frame\" and the joints' world matrices",
                                    where(clip.file, frameNode)));
        if (!frameNode["frame"])
            throw Error(fmt::format("{}: this frame has no \"frame\" number", where(clip.file, frameNode)));
        const double number = finiteNumber(frameNode["frame"], clip.file, "frame");
        if (!clip.frameNumbers.empty() && number <= clip.frameNumbers.back())
            throw Error(fmt::format("{}: frame {} comes after frame {}; frames must increase",
                                    where(clip.file, frameNode["frame"]), number, clip.frameNumbers.back()));
        clip.frameNumbers.push_back(number);
        auto& frame = clip.worlds.emplace_back();
        for (const int j : kept) {
            const std::string key = fileJoints[j] + std::string(suffix);
            const YAML::Node m = frameNode[key];
            if (!m)
                throw Error(fmt::format("{}: frame {} has no \"{}\"; every frame needs the joints of the first",
                                        where(clip.file, frameNode), number, key));
            Eigen::Matrix4d world = readMatrix(m, clip.file, key);
            world.block<3, 1>(0, 3) *= map.scale;
            frame.push_back(world);
        }
    }
    return clip;
}

}  // namespace

TargetMap readTargetMap(const std::filesystem::path& file)
{
    TargetMap map;
    map.file = file.string();
    const YAML::Node root = parseYaml(readText(file, "map file"), map.file);
    if (!root.IsMap())
        throw Error(fmt::format("{}: a map file is a map with 'scale:', 'joints:' and 'ignore:' (docs/rig-invert.md)",
                                where(map.file, root)));
    for (const auto& entry : root) {
        const auto key = entry.first.as<std::string>();
        const YAML::Node& value = entry.second;
        if (key == "scale") {
            map.scale = finiteNumber(value, map.file, "scale");
            if (map.scale <= 0.0)
                throw Error(fmt::format("{}: scale must be positive (target units to cm), got {}", where(map.file, value),
                                        map.scale));
        }
        else if (key == "joints") {
            if (!value.IsMap())
                throw Error(fmt::format("{}: 'joints' must map target joints to rig joints (Hips: pelvis)",
                                        where(map.file, value)));
            for (const auto& rename : value) {
                if (!rename.second.IsScalar() || rename.second.Scalar().empty())
                    throw Error(fmt::format("{}: '{}' must be renamed to a rig joint's name", where(map.file, rename.second),
                                            rename.first.as<std::string>()));
                map.rename[rename.first.as<std::string>()] = rename.second.Scalar();
                map.renameLines[rename.first.as<std::string>()] = rename.first.Mark().line + 1;
            }
        }
        else if (key == "ignore") {
            if (!value.IsSequence())
                throw Error(fmt::format("{}: 'ignore' must be a list of target joints", where(map.file, value)));
            for (const auto& joint : value) map.ignore.push_back(joint.as<std::string>());
        }
        else {
            throw Error(fmt::format("{}: unknown key '{}'; a map file has 'scale:', 'joints:' and 'ignore:'",
                                    where(map.file, entry.first), messageExcerpt(key)));
        }
    }
    return map;
}

TargetClip readTargetClip(const std::filesystem::path& file, const TargetMap& map)
{
    const auto extension = file.extension().string();
    if (extension == ".bvh" || extension == ".BVH") return readBvhTargets(file, map);
    if (extension == ".json") return readJsonTargets(file, map);
    throw Error(fmt::format("{}: a clip is a .bvh file or a .json file of world matrices (graph-eval's JSON); "
                            "rename it or convert it",
                            file.string()));
}

}  // namespace rig

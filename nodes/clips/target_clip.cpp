#include "nodes/clips/target_clip.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/input_file.h"
#include "graph/rig_file.h"
#include "nodes/clips/assimp_clip.h"
#include "nodes/clips/bvh.h"
#include "nodes/clips/maya_clip.h"

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
    const auto status = std::filesystem::status(file, ec);
    if (!std::filesystem::exists(status))
        throw Error(fmt::format("{}: no such {}; check the path", file.string(), what));
    if (std::filesystem::is_directory(status))
        throw Error(fmt::format("{}: is a folder, not a {}", file.string(), what));
    // A device or a pipe never ends (or has no size): refuse it before reading.
    if (!std::filesystem::is_regular_file(status))
        throw Error(
            fmt::format("{}: is not a regular file (a device or a pipe?); give the path of a {}", file.string(), what));
    if (std::filesystem::file_size(file, ec) > bvhMaxFileBytes)
        throw Error(fmt::format("{}: more than the {} MB a {} may have; cut it into shorter files", file.string(),
                                bvhMaxFileBytes >> 20, what));
    std::ifstream in(file, std::ios::binary);
    if (!in) throw Error(fmt::format("{}: cannot be read; check its permissions", file.string()));
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// `syntax` names the language in messages: YAML for a map file, JSON for a clip (read as YAML, which
// JSON is a part of).
YAML::Node parseYaml(const std::string& text, const std::string& file, std::string_view syntax, std::string_view what)
{
    try {
        return YAML::Load(text);
    }
    catch (const YAML::DeepRecursion& e) {
        throw Error(
            fmt::format("{}: lists and maps nested more than {} levels deep; a {} nests a few levels, so the "
                        "file is damaged",
                        formatMark({file, e.mark.line + 1, e.mark.column + 1}), e.depth() - 1, what));
    }
    catch (const YAML::ParserException& e) {
        throw Error(fmt::format("{}: {} syntax error: {}", formatMark({file, e.mark.line + 1, e.mark.column + 1}),
                                syntax, e.msg));
    }
}

// A map's key as text; a key that is a list or a map (YAML allows them) is an error at its place.
std::string keyText(const YAML::Node& key, const std::string& file, std::string_view what)
{
    if (!key.IsScalar())
        throw Error(fmt::format("{}: a key of {} is a list or a map; keys are names", where(file, key), what));
    return key.Scalar();
}

double finiteNumber(const YAML::Node& node, const std::string& file, std::string_view what)
{
    double value = 0.0;
    if (!node.IsScalar() || !YAML::convert<double>::decode(node, value))
        throw Error(fmt::format("{}: {} must be a number, got '{}'", where(file, node), what,
                                node.IsScalar() ? messageExcerpt(node.Scalar()) : std::string("a list or map")));
    if (!std::isfinite(value)) throw Error(fmt::format("{}: {} is not a finite number", where(file, node), what));
    return value;
}

std::string rigName(const std::string& joint, const TargetMap& map)
{
    const auto it = map.rename.find(joint);
    return it == map.rename.end() ? joint : it->second;
}

// Keeps the joints the map does not ignore, renamed; checks that every name the map gives is in the clip.
std::vector<int> applyMap(const std::vector<std::string>& fileJoints, const std::string& clipFile, const TargetMap& map,
                          std::vector<std::string>& names)
{
    const std::set<std::string> present(fileJoints.begin(), fileJoints.end());
    // file:line of an entry of the map (a map made in code has no lines).
    const auto at = [&](const std::map<std::string, int>& lines, const std::string& joint) {
        const auto it = lines.find(joint);
        return it == lines.end() ? map.file : fmt::format("{}:{}", map.file, it->second);
    };
    for (const auto& [from, to] : map.rename)
        if (!present.count(from))
            throw Error(fmt::format("{}: the map renames '{}', which {} does not have; check the joint name",
                                    at(map.renameLines, from), from, clipFile));
    for (const auto& joint : map.ignore)
        if (!present.count(joint))
            throw Error(fmt::format("{}: the map ignores '{}', which {} does not have; check the joint name",
                                    at(map.ignoreLines, joint), joint, clipFile));
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
    if (kept.empty() && !fileJoints.empty())
        throw Error(fmt::format("{}: the map ignores every joint of {}, so nothing is left to invert; ignore fewer",
                                at(map.ignoreLines, map.ignore.front()), clipFile));
    return kept;
}

// Each kept joint's nearest ancestor among the kept ones (an index into `kept`), -1 for none; `parents`: the
// file's joints' parents (-1 for a root), or empty when the file does not say.
std::vector<int> keptParents(const std::vector<int>& parents, const std::vector<int>& kept)
{
    const auto parentOf = [&](int joint) {
        return static_cast<std::size_t>(joint) < parents.size() ? parents[static_cast<std::size_t>(joint)] : -1;
    };
    std::vector<int> out;
    for (const int j : kept) {
        int parent = parentOf(j);
        auto found = kept.end();
        while (parent >= 0 && (found = std::find(kept.begin(), kept.end(), parent)) == kept.end())
            parent = parentOf(parent);
        out.push_back(parent >= 0 ? static_cast<int>(found - kept.begin()) : -1);
    }
    return out;
}

// A skeletal clip's joints' world matrices by forward kinematics, the map applied.
TargetClip skeletalTargets(const SkeletalClip& skeleton, const std::string& file, const TargetMap& map)
{
    const BvhClip& bvh = skeleton.clip;
    std::vector<std::string> fileJoints;
    for (const auto& joint : bvh.joints) fileJoints.push_back(joint.name);
    TargetClip clip;
    clip.file = file;
    clip.source = skeleton.source.describe(map.scale, map.file);
    const auto kept = applyMap(fileJoints, clip.file, map, clip.joints);
    clip.frameTime = bvh.frameTime;
    std::vector<int> parents;
    for (const auto& joint : bvh.joints) parents.push_back(joint.parent);
    clip.parents = keptParents(parents, kept);
    // The rest pose: offsets down the hierarchy, no rotation (parents come before their children).
    std::vector<Eigen::Matrix4d> rest(bvh.joints.size(), Eigen::Matrix4d::Identity());
    for (std::size_t j = 0; j < bvh.joints.size(); ++j) {
        Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
        local.block<3, 1>(0, 3) = bvh.joints[j].offset;
        rest[j] = bvh.joints[j].parent < 0 ? local : rest[static_cast<std::size_t>(bvh.joints[j].parent)] * local;
    }
    for (const int j : kept) {
        Eigen::Matrix4d m = rest[static_cast<std::size_t>(j)];
        m.block<3, 1>(0, 3) *= map.scale;
        clip.restWorlds.push_back(m);
    }
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
            throw Error(
                fmt::format("{}: {} must be a matrix as four rows of four numbers", where(file, node[r]), what));
        for (int c = 0; c < 4; ++c)
            // null is how graph-eval writes a number that is not finite: a target the solver reports
            // as invalid for that frame, not a broken file.
            m(r, c) =
                node[r][c].IsNull() ? std::numeric_limits<double>::quiet_NaN() : finiteNumber(node[r][c], file, what);
    }
    return m;
}

}  // namespace

// Duplicate keys are checked where the frames are read. Memory stays small: the SAX handler keeps nothing.
void checkStrictJson(std::string_view text, const std::string& file, std::string_view shape)
{
    struct Checker : nlohmann::json_sax<nlohmann::json> {
        std::size_t errorAt = 0;
        std::string message;
        bool null() override { return true; }
        bool boolean(bool) override { return true; }
        bool number_integer(number_integer_t) override { return true; }
        bool number_unsigned(number_unsigned_t) override { return true; }
        bool number_float(number_float_t, const string_t&) override { return true; }
        bool string(string_t&) override { return true; }
        bool binary(binary_t&) override { return true; }
        bool start_object(std::size_t) override { return true; }
        bool key(string_t&) override { return true; }
        bool end_object() override { return true; }
        bool start_array(std::size_t) override { return true; }
        bool end_array() override { return true; }
        bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) override
        {
            errorAt = position;
            message = e.what();
            return false;
        }
    } checker;
    if (nlohmann::json::sax_parse(text, &checker)) return;
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line L, column C: WHAT".
    std::string what = checker.message;
    if (const auto colon = what.find(": ", what.find("parse error")); colon != std::string::npos)
        what.erase(0, colon + 2);
    int line = 1, column = 1;
    for (std::size_t i = 0; i + 1 < checker.errorAt && i < text.size(); ++i) {
        if (text[i] == '\n') {
            ++line;
            column = 1;
        } else {
            ++column;
        }
    }
    throw Error(
        fmt::format("{}: JSON syntax error: {}; {}", formatMark({file, line, column}), oneLine(what, 200), shape));
}

namespace {

// A frame's keys, each once: YAML keeps both of a duplicated key and would read the first.
void checkUniqueKeys(const YAML::Node& frame, const std::string& file)
{
    std::set<std::string> keys;
    for (const auto& entry : frame)
        if (entry.first.IsScalar() && !keys.insert(entry.first.Scalar()).second)
            throw Error(fmt::format("{}: \"{}\" appears twice in this frame; each key once", where(file, entry.first),
                                    entry.first.Scalar()));
}

}  // namespace

TargetClip parseJsonTargetClip(std::string_view text, const std::string& fileName, const TargetMap& map)
{
    TargetClip clip;
    clip.file = fileName;
    checkStrictJson(text, clip.file, "a JSON clip is one list of frames, as graph-eval writes it");
    const YAML::Node root = parseYaml(std::string(text), clip.file, "JSON", "JSON clip");
    if (!root.IsSequence() || root.size() == 0)
        throw Error(
            fmt::format("{}: expected a list of frames as graph-eval writes them ([{{\"frame\": 1, "
                        "\"hips.worldMatrix\": [[...], ...]}}, ...])",
                        where(clip.file, root)));
    static constexpr std::string_view suffix = ".worldMatrix";
    // (Iterating a list as if it were a map throws yaml-cpp's own exception.)
    if (!root[0].IsMap())
        throw Error(fmt::format("{}: a frame must be a map with \"frame\" and the joints' world matrices",
                                where(clip.file, root[0])));
    std::vector<std::string> fileJoints;
    for (const auto& entry : root[0]) {
        const auto key = keyText(entry.first, clip.file, "a frame");
        if (key == "frame") continue;
        if (!key.ends_with(suffix))
            throw Error(
                fmt::format("{}: '{}' is not a joint's world matrix (NODE.worldMatrix); ask graph-eval for "
                            "--get '*.worldMatrix' only",
                            where(clip.file, entry.first), key));
        fileJoints.push_back(key.substr(0, key.size() - suffix.size()));
    }
    if (fileJoints.empty())
        throw Error(fmt::format("{}: the first frame has no NODE.worldMatrix entries", where(clip.file, root[0])));
    const auto kept = applyMap(fileJoints, clip.file, map, clip.joints);
    clip.parents = keptParents({}, kept);
    for (const auto& frameNode : root) {
        if (!frameNode.IsMap())
            throw Error(fmt::format("{}: a frame must be a map with \"frame\" and the joints' world matrices",
                                    where(clip.file, frameNode)));
        checkUniqueKeys(frameNode, clip.file);
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

TargetMap readTargetMap(const std::filesystem::path& file)
{
    return parseTargetMap(readText(file, "map file"), file.string());
}

namespace {

constexpr std::string_view mapKeys = "'scale:', 'joints:', 'ignore:', 'retarget:' and 'weights:'";

void parseRenames(const YAML::Node& value, TargetMap& map)
{
    if (!value.IsMap())
        throw Error(
            fmt::format("{}: 'joints' must map target joints to rig joints (Hips: pelvis)", where(map.file, value)));
    for (const auto& rename : value) {
        const std::string from = keyText(rename.first, map.file, "'joints'");
        // A missing name (null) has its place after the key: point at the key.
        if (!rename.second.IsScalar() || rename.second.Scalar().empty())
            throw Error(fmt::format("{}: '{}' must be renamed to a rig joint's name (clip joint: rig joint)",
                                    where(map.file, rename.second.IsNull() ? rename.first : rename.second),
                                    messageExcerpt(from)));
        // YAML keeps both of a key given twice, and the later would win unseen.
        if (map.rename.contains(from))
            throw Error(fmt::format("{}: '{}' is renamed twice in 'joints'; rename each clip joint once",
                                    where(map.file, rename.first), messageExcerpt(from)));
        map.rename[from] = rename.second.Scalar();
        map.renameLines[from] = rename.first.Mark().line + 1;
    }
}

void parseIgnore(const YAML::Node& value, TargetMap& map)
{
    if (!value.IsSequence())
        throw Error(fmt::format("{}: 'ignore' must be a list of target joints", where(map.file, value)));
    for (const auto& joint : value) {
        if (!joint.IsScalar() || joint.Scalar().empty())
            throw Error(fmt::format("{}: 'ignore' must be a list of target joints' names", where(map.file, joint)));
        map.ignore.push_back(joint.Scalar());
        map.ignoreLines[joint.Scalar()] = joint.Mark().line + 1;
    }
}

// A rig joint's name in a list or as a key: a non-empty scalar.
std::string jointName(const YAML::Node& node, const std::string& file, std::string_view what)
{
    if (!node.IsScalar() || node.Scalar().empty())
        throw Error(fmt::format("{}: {} must be a rig joint's name", where(file, node), what));
    return node.Scalar();
}

void parseAlign(const YAML::Node& value, const std::string& file, RetargetSpec& spec)
{
    if (!value.IsMap())
        throw Error(fmt::format("{}: 'align' must map rig joints to three angles in degrees (LeftArm: [0, 0, -45])",
                                where(file, value)));
    for (const auto& entry : value) {
        const std::string joint = jointName(entry.first, file, "a key of 'align'");
        const YAML::Node& angles = entry.second;
        if (!angles.IsSequence() || angles.size() != 3)
            throw Error(fmt::format("{}: align of '{}' must be three angles in degrees, X Y Z ([0, 0, -45])",
                                    where(file, angles.IsNull() ? entry.first : angles), messageExcerpt(joint)));
        Eigen::Vector3d degrees;
        for (int i = 0; i < 3; ++i)
            degrees[i] = finiteNumber(angles[i], file, fmt::format("align of '{}'", messageExcerpt(joint)));
        if (spec.align.contains(joint))
            throw Error(fmt::format("{}: '{}' is given twice in 'align'; give each joint's angles once",
                                    where(file, entry.first), messageExcerpt(joint)));
        spec.align[joint] = degrees;
        spec.alignWhere[joint] = where(file, entry.first);
    }
}

void parseRetarget(const YAML::Node& value, const std::string& file, RetargetSpec& spec)
{
    spec.enabled = true;
    spec.where = where(file, value);
    spec.rootScale = 1.0;        // unless given
    if (value.IsNull()) return;  // `retarget:` alone: every default
    if (!value.IsMap())
        throw Error(
            fmt::format("{}: 'retarget' must be a map with 'rootScale:', 'leg:' and 'align:' "
                        "(docs/retargeting.md)",
                        where(file, value)));
    bool autoScale = false;
    for (const auto& entry : value) {
        const auto key = keyText(entry.first, file, "'retarget'");
        const YAML::Node& v = entry.second;
        if (key == "rootScale") {
            spec.rootScaleWhere = where(file, v.IsNull() ? entry.first : v);
            autoScale = v.IsScalar() && v.Scalar() == "auto";
            double number = 0.0;
            if (autoScale) {
                spec.rootScale.reset();
            } else if (v.IsScalar() && YAML::convert<double>::decode(v, number) && std::isfinite(number) &&
                       number > 0.0) {
                spec.rootScale = number;
            } else {
                throw Error(fmt::format("{}: rootScale must be 'auto' or a positive number, got {}",
                                        spec.rootScaleWhere,
                                        v.IsScalar() ? "'" + messageExcerpt(v.Scalar()) + "'"
                                        : v.IsNull() ? std::string("nothing")
                                                     : std::string("a list or map")));
            }
        } else if (key == "leg") {
            if (!v.IsSequence() || v.size() < 2)
                throw Error(
                    fmt::format("{}: 'leg' must list two or more rig joints from hip to ankle "
                                "([LeftUpLeg, LeftLeg, LeftFoot])",
                                where(file, v.IsNull() ? entry.first : v)));
            for (const auto& joint : v) {
                spec.leg.push_back(jointName(joint, file, "each entry of 'leg'"));
                spec.legWhere.push_back(where(file, joint));
            }
        } else if (key == "align") {
            parseAlign(v, file, spec);
        } else {
            throw Error(fmt::format("{}: unknown key '{}' in 'retarget'; it has 'rootScale:', 'leg:' and 'align:'",
                                    where(file, entry.first), messageExcerpt(key)));
        }
    }
    if (autoScale && spec.leg.empty())
        throw Error(
            fmt::format("{}: rootScale auto needs 'leg:' in 'retarget' (the rig's joints from hip to ankle, "
                        "[LeftUpLeg, LeftLeg, LeftFoot]); add it or give rootScale as a number",
                        spec.rootScaleWhere));
}

void parseWeights(const YAML::Node& value, TargetMap& map)
{
    if (!value.IsMap())
        throw Error(
            fmt::format("{}: 'weights' must map rig joints to {{position: W, rotation: W}}", where(map.file, value)));
    for (const auto& entry : value) {
        const std::string joint = jointName(entry.first, map.file, "a key of 'weights'");
        if (map.weights.contains(joint))
            throw Error(fmt::format("{}: '{}' is given twice in 'weights'; give each joint's weights once",
                                    where(map.file, entry.first), messageExcerpt(joint)));
        if (!entry.second.IsMap())
            throw Error(fmt::format("{}: the weights of '{}' must be a map {{position: W, rotation: W}}",
                                    where(map.file, entry.second.IsNull() ? entry.first : entry.second),
                                    messageExcerpt(joint)));
        TargetWeight weight;
        weight.where = where(map.file, entry.first);
        for (const auto& w : entry.second) {
            const auto key = keyText(w.first, map.file, "a joint's weights");
            if (key != "position" && key != "rotation")
                throw Error(fmt::format("{}: unknown weight '{}'; a joint's weights are 'position:' and 'rotation:'",
                                        where(map.file, w.first), messageExcerpt(key)));
            const double number = finiteNumber(w.second, map.file, fmt::format("the {} weight", key));
            if (number < 0.0)
                throw Error(fmt::format("{}: the {} weight of '{}' must be 0 or more, got {}",
                                        where(map.file, w.second), key, messageExcerpt(joint), number));
            (key == "position" ? weight.position : weight.rotation) = number;
        }
        map.weights[joint] = weight;
    }
}

}  // namespace

TargetMap parseTargetMap(std::string_view text, const std::string& fileName)
{
    TargetMap map;
    map.file = fileName;
    const YAML::Node root = parseYaml(std::string(text), map.file, "YAML", "map file");
    if (!root.IsMap())
        throw Error(
            fmt::format("{}: a map file is a map with {} (docs/retargeting.md)", where(map.file, root), mapKeys));
    for (const auto& entry : root) {
        const auto key = keyText(entry.first, map.file, "a map file");
        const YAML::Node& value = entry.second;
        if (key == "scale") {
            map.scale = finiteNumber(value, map.file, "scale");
            if (map.scale <= 0.0)
                throw Error(fmt::format("{}: scale must be positive (target units to cm), got {}",
                                        where(map.file, value), map.scale));
        } else if (key == "joints") {
            parseRenames(value, map);
        } else if (key == "ignore") {
            parseIgnore(value, map);
        } else if (key == "retarget") {
            parseRetarget(value, map.file, map.retarget);
        } else if (key == "weights") {
            parseWeights(value, map);
        } else {
            throw Error(fmt::format("{}: unknown key '{}'; a map file has {}", where(map.file, entry.first),
                                    messageExcerpt(key), mapKeys));
        }
    }
    return map;
}

TargetClip readTargetClip(const std::filesystem::path& file, const TargetMap& map, const std::string& take)
{
    std::error_code ec;
    if (std::filesystem::is_directory(file, ec))
        throw Error(
            fmt::format("{}: is a folder; give a clip file (BVH, FBX, glTF, Collada, ..., or .json of world "
                        "matrices)",
                        file.string()));
    if (isMayaFile(file)) {
        if (!take.empty() && take != "0")
            throw Error(fmt::format("{}: no take '{}'; a Maya scene is one clip, its playback range; leave --take out",
                                    file.string(), messageExcerpt(take, 60)));
        return readMayaClip(file, map);
    }
    // A JSON clip's file is read as before BVH and assimp came to share this path (its messages name it).
    const bool jsonByName = file.extension() == ".json";
    const std::string text = jsonByName ? readText(file, "JSON clip") : readInputFile(file, clipFileKind(file));
    switch (clipReaderFor(text, file)) {
        case ClipReader::bvh:
            return skeletalTargets(parseBvhSkeletalClip(text, file.string(), take), file.string(), map);
        case ClipReader::json: {
            if (!take.empty() && take != "0")
                throw Error(fmt::format("{}: no take '{}'; a JSON clip has one take, 0; leave --take out",
                                        file.string(), messageExcerpt(take, 60)));
            TargetClip clip = parseJsonTargetClip(text, file.string(), map);
            clip.source = map.scale == 1.0 ? std::string("JSON world matrices (cm, Y up, as graph-eval writes them)")
                                           : fmt::format(
                                                 "JSON world matrices (Y up, as graph-eval writes them), units "
                                                 "x{:.6g} to cm (by the map {})",
                                                 map.scale, map.file);
            return clip;
        }
        case ClipReader::assimp:
            break;
    }
    return skeletalTargets(readAssimpClip(file, take), file.string(), map);
}

TargetClip applyTargetMap(const TargetClip& clip, const TargetMap& map)
{
    TargetClip out;
    out.file = clip.file;
    out.frameNumbers = clip.frameNumbers;
    out.frameTime = clip.frameTime;
    out.source = clip.source;
    out.scene = clip.scene;
    const auto kept = applyMap(clip.joints, clip.file, map, out.joints);
    out.parents = keptParents(clip.parents, kept);
    if (!clip.restWorlds.empty())
        for (const int j : kept) {
            Eigen::Matrix4d m = clip.restWorlds[static_cast<std::size_t>(j)];
            m.block<3, 1>(0, 3) *= map.scale;
            out.restWorlds.push_back(m);
        }
    for (const auto& worlds : clip.worlds) {
        auto& frame = out.worlds.emplace_back();
        for (const int j : kept) {
            Eigen::Matrix4d m = worlds[static_cast<std::size_t>(j)];
            m.block<3, 1>(0, 3) *= map.scale;
            frame.push_back(m);
        }
    }
    return out;
}

}  // namespace rig

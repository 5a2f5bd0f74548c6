#include "nodes/clips/assimp_clip.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <map>
#include <new>
#include <numbers>
#include <regex>
#include <set>

#include <assimp/commonMetaData.h>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <Eigen/Geometry>
#include <assimp/Importer.hpp>

#include "core/error.h"
#include "core/input_file.h"
#include "core/parse_number.h"
#include "core/rotation_math.h"
#include "nodes/clips/bvh_rig.h"
#include "nodes/clips/clip_isolation.h"
#include "nodes/transform_math.h"

namespace rig {
namespace {

constexpr double defaultFramesPerSecond = 30.0;
constexpr double translationNoise = 1e-5;  // relative; see poseClip
constexpr InputFileKind animationFileKind{"an animation file", "an animation file (FBX, glTF, Collada, X, BVH, ...)",
                                          bvhMaxFileBytes, "cut the clip into shorter ones"};

struct PositionKey {
    double time;
    Eigen::Vector3d value;
};
struct RotationKey {
    double time;
    Eigen::Quaterniond value;
};

// One node of the scene, in depth-first order (a parent before its children).
struct SceneNode {
    const aiNode* node = nullptr;
    std::string name;
    int parent = -1;
    int depth = 0;
    Eigen::Matrix4d rest;                 // the node's own transformation
    const aiNodeAnim* channel = nullptr;  // the take's channel moving it, if any
    std::vector<PositionKey> positions, scalings;
    std::vector<RotationKey> rotations;
    Eigen::Vector3d restPosition, restScale;  // what a channel without keys of a kind holds
    Eigen::Quaterniond restRotation;
    bool marked = false;  // animated or a mesh's bone
    bool joint = false;
};

Eigen::Matrix4d toEigen(const aiMatrix4x4& m)
{
    Eigen::Matrix4d out;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) out(r, c) = m[static_cast<unsigned>(r)][static_cast<unsigned>(c)];
    return out;
}

std::string formatName(const aiScene& scene, const std::string& fallback)
{
    std::string importer;
    if (scene.mMetaData) {
        aiString value;
        if (scene.mMetaData->Get(AI_METADATA_SOURCE_FORMAT, value)) importer = value.C_Str();
    }
    static const std::pair<const char*, const char*> names[] = {
        {"FBX", "FBX"}, {"glTF", "glTF"}, {"Collada", "Collada"}, {"BVH", "BVH"},        {"XFile", "X"},
        {"SMD", "SMD"}, {"MD5", "MD5"},   {"Quake", "MDL"},       {"OpenGEX", "OpenGEX"}};
    for (const auto& [key, name] : names)
        if (importer.find(key) != std::string::npos) return name;
    return importer.empty() ? fallback : importer;
}

double metadataNumber(const aiScene& scene, const char* key, double fallback)
{
    if (!scene.mMetaData) return fallback;
    for (unsigned k = 0; k < scene.mMetaData->mNumProperties; ++k) {
        if (std::string_view(scene.mMetaData->mKeys[k].C_Str()) != key) continue;
        const aiMetadataEntry& entry = scene.mMetaData->mValues[k];
        switch (entry.mType) {
            case AI_INT32:
                return *static_cast<const int32_t*>(entry.mData);
            case AI_UINT64:
                return static_cast<double>(*static_cast<const uint64_t*>(entry.mData));
            case AI_FLOAT:
                // A float's shortest decimal (2.54f is 2.54, not 2.5399999618...): what the file wrote.
                return parseFiniteNumber(fmt::format("{}", *static_cast<const float*>(entry.mData))).value_or(fallback);
            case AI_DOUBLE:
                return *static_cast<const double*>(entry.mData);
            default:
                return fallback;
        }
    }
    return fallback;
}

std::string axisName(int axis, int sign) { return fmt::format("{}{}", sign < 0 ? "-" : "", "XYZ"[axis]); }

// FBX's axis triple (the file's right, up and front axes) as the rotation onto X right, Y up, Z front. A
// left-handed triple keeps right and up, its front following from them (the one rotation nearest to it).
Eigen::Matrix3d fbxAxes(const aiScene& scene, const std::string& file, ClipSource& source)
{
    const int up = static_cast<int>(metadataNumber(scene, "UpAxis", 1));
    const int front = static_cast<int>(metadataNumber(scene, "FrontAxis", 2));
    const int coord = static_cast<int>(metadataNumber(scene, "CoordAxis", 0));
    const double upSign = metadataNumber(scene, "UpAxisSign", 1) < 0 ? -1.0 : 1.0;
    const double frontSign = metadataNumber(scene, "FrontAxisSign", 1) < 0 ? -1.0 : 1.0;
    const double coordSign = metadataNumber(scene, "CoordAxisSign", 1) < 0 ? -1.0 : 1.0;
    const auto valid = [](int axis) { return axis >= 0 && axis <= 2; };
    if (!valid(up) || !valid(front) || !valid(coord) || up == front || up == coord || front == coord)
        throw Error(
            fmt::format("{}: its axis settings (UpAxis {}, FrontAxis {}, CoordAxis {}) are not three distinct "
                        "axes 0, 1, 2; the file is damaged, export it again",
                        file, up, front, coord));
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    c(0, coord) = coordSign;
    c(1, up) = upSign;
    c(2, front) = frontSign;
    if (c.determinant() < 0) c.row(2) = c.row(0).cross(c.row(1));
    source.upAxis = axisName(up, upSign < 0 ? -1 : 1);
    return c;
}

// Collada's <unit> and <up_axis>, which assimp applies to the scene's root itself, read back for the report.
void colladaAsset(std::string_view head, ClipSource& source)
{
    const std::string text(head.substr(0, 65536));
    std::smatch m;
    if (std::regex_search(text, m, std::regex(R"(<up_axis>\s*([XYZ])_UP\s*</up_axis>)"))) source.upAxis = m[1];
    source.units = "Collada metres (assimp applies <unit>)";
    if (std::regex_search(text, m, std::regex(R"re(<unit[^>]*meter\s*=\s*"([^"]*)")re")))
        source.units = fmt::format("Collada <unit meter=\"{}\">, applied by assimp: metres", std::string(m[1]));
}

// The conversion of the scene's lengths and axes to cm and Y up (applied before the root's transformation).
Eigen::Matrix4d normalisation(const aiScene& scene, const std::string& file, std::string_view head, ClipSource& source)
{
    Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
    if (source.format == "FBX") {
        source.unitsToCm = metadataNumber(scene, "UnitScaleFactor", 1.0);
        if (!std::isfinite(source.unitsToCm) || source.unitsToCm <= 0.0)
            throw Error(fmt::format("{}: its UnitScaleFactor is {}, not a positive number; export it again", file,
                                    source.unitsToCm));
        source.units = fmt::format("FBX UnitScaleFactor {}", source.unitsToCm);
        axes = fbxAxes(scene, file, source);
    } else if (source.format == "glTF") {
        source.unitsToCm = 100.0;
        source.units = "glTF metres";
    } else if (source.format == "Collada") {
        source.unitsToCm = 100.0;
        colladaAsset(head, source);
    } else {
        source.units = fmt::format("{} has no unit: taken as is", source.format);
    }
    Eigen::Matrix4d c = Eigen::Matrix4d::Identity();
    c.topLeftCorner<3, 3>() = source.unitsToCm * axes;
    return c;
}

// The take named `take` (a name, else a 0-based index; "" the first). A bad one: the takes, in one line.
int chooseTake(const aiScene& scene, const std::string& take, const std::string& file)
{
    const auto name = [&](unsigned a) {
        return scene.mAnimations[a] ? std::string(scene.mAnimations[a]->mName.C_Str()) : std::string();
    };
    if (take.empty()) return 0;
    for (unsigned a = 0; a < scene.mNumAnimations; ++a)
        if (name(a) == take) return static_cast<int>(a);
    const auto digit = [](unsigned char c) { return std::isdigit(c) != 0; };
    if (take.size() < 10 && std::all_of(take.begin(), take.end(), digit)) {
        const int index = std::stoi(take);
        if (index < static_cast<int>(scene.mNumAnimations)) return index;
    }
    std::string takes;
    for (unsigned a = 0; a < scene.mNumAnimations && a < 20; ++a)
        takes += fmt::format("{}{} '{}'", a ? ", " : "", a, messageExcerpt(name(a), 60));
    if (scene.mNumAnimations > 20) takes += fmt::format(", ... ({} in all)", scene.mNumAnimations);
    throw Error(fmt::format("{}: no take '{}'; its takes are {}; give --take NAME or INDEX", file,
                            messageExcerpt(take, 60), takes));
}

// The scene's nodes, depth first, with limits: a hierarchy too deep, too big or with a node twice is refused.
std::vector<SceneNode> flattenNodes(const aiScene& scene, const std::string& file)
{
    std::vector<SceneNode> nodes;
    std::set<const aiNode*> seen;
    std::vector<std::pair<const aiNode*, int>> stack{{scene.mRootNode, -1}};
    while (!stack.empty()) {
        const auto [node, parent] = stack.back();
        stack.pop_back();
        if (!seen.insert(node).second)
            throw Error(fmt::format("{}: node '{}' appears twice in the hierarchy (a cycle); the file is damaged", file,
                                    messageExcerpt(node->mName.C_Str(), 60)));
        SceneNode& n = nodes.emplace_back();
        n.node = node;
        n.name = node->mName.C_Str();
        n.parent = parent;
        n.depth = parent < 0 ? 0 : nodes[static_cast<std::size_t>(parent)].depth + 1;
        n.rest = toEigen(node->mTransformation);
        if (n.depth > bvhMaxDepth || nodes.size() > static_cast<std::size_t>(4 * bvhMaxJoints))
            throw Error(
                fmt::format("{}: its hierarchy is deeper than {} or has more than {} nodes; a skeleton is "
                            "smaller, so the file is damaged",
                            file, bvhMaxDepth, 4 * bvhMaxJoints));
        if (!n.rest.allFinite())
            throw Error(fmt::format("{}: node '{}' has a transformation that is not finite; the file is damaged", file,
                                    messageExcerpt(n.name, 60)));
        const int self = static_cast<int>(nodes.size()) - 1;
        for (unsigned c = node->mChildren ? node->mNumChildren : 0; c-- > 0;)
            if (node->mChildren[c]) stack.emplace_back(node->mChildren[c], self);
    }
    return nodes;
}

bool allFinite(const Eigen::Vector3d& v) { return v.allFinite(); }
bool allFinite(const Eigen::Quaterniond& q) { return q.coeffs().allFinite() && q.norm() > 1e-6; }

template <class Key, class Source, class Convert>
std::vector<Key> readKeys(const Source* keys, unsigned count, Convert convert, const std::string& where)
{
    if (count > 0 && !keys)
        throw Error(fmt::format("{}: {} keys without their values; the file is damaged", where, count));
    std::vector<Key> out;
    for (unsigned k = 0; k < count; ++k) {
        Key key{keys[k].mTime, convert(keys[k].mValue)};
        if (!std::isfinite(key.time) || !allFinite(key.value))
            throw Error(
                fmt::format("{}: key {} is not a finite number (or a zero rotation); the file is damaged", where, k));
        if (!out.empty() && key.time < out.back().time)
            throw Error(
                fmt::format("{}: key {} at {} comes before the key before it ({}); keys must not go back in "
                            "time",
                            where, k, key.time, out.back().time));
        out.push_back(key);
    }
    return out;
}

std::string lowerExtension(const std::filesystem::path& file)
{
    std::string extension = file.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return extension;
}

Eigen::Vector3d toVector(const aiVector3D& v) { return {v.x, v.y, v.z}; }
Eigen::Quaterniond toQuaternion(const aiQuaternion& q) { return Eigen::Quaterniond(q.w, q.x, q.y, q.z); }

// The take's keys on the node they move ("FILE: take T, node N position").
void readChannel(SceneNode& n, const aiNodeAnim& channel, const std::string& where)
{
    if (n.channel)
        throw Error(
            fmt::format("{}: the take moves node '{}' twice; the file is damaged", where, messageExcerpt(n.name, 60)));
    n.channel = &channel;
    n.marked = true;
    const std::string at = fmt::format("{}, node '{}'", where, messageExcerpt(n.name, 60));
    n.positions = readKeys<PositionKey>(channel.mPositionKeys, channel.mNumPositionKeys, toVector, at + " position");
    n.rotations =
        readKeys<RotationKey>(channel.mRotationKeys, channel.mNumRotationKeys, toQuaternion, at + " rotation");
    n.scalings = readKeys<PositionKey>(channel.mScalingKeys, channel.mNumScalingKeys, toVector, at + " scaling");
    for (auto& key : n.rotations) key.value.normalize();
    aiVector3D scale, position;
    aiQuaternion rotation;
    n.node->mTransformation.Decompose(scale, rotation, position);
    n.restPosition = toVector(position);
    n.restScale = toVector(scale);
    n.restRotation = toQuaternion(rotation).normalized();
}

// The joints: the nodes the take moves or a mesh's bone names, with their ancestors below the scene's root and
// their descendants (a skeleton's fixed root and its leaves; the scene's root is the fixed frame the roots hang
// from, side branches without a joint are left out). Returns how many.
int markJoints(const aiScene& scene, const aiAnimation& take, std::vector<SceneNode>& nodes, const std::string& where)
{
    std::map<std::string, int> byName;  // -1: two nodes have the name
    for (std::size_t i = 0; i < nodes.size(); ++i)
        if (const auto [it, inserted] = byName.emplace(nodes[i].name, static_cast<int>(i)); !inserted) it->second = -1;
    const auto node = [&](const std::string& name) -> SceneNode* {
        const auto it = byName.find(name);
        if (it == byName.end()) return nullptr;  // assimp too ignores a channel or bone naming no node
        if (it->second < 0)
            throw Error(fmt::format("{}: two nodes are named '{}' and the skeleton uses the name; rename them apart",
                                    where, messageExcerpt(name, 60)));
        return &nodes[static_cast<std::size_t>(it->second)];
    };
    for (unsigned c = 0; take.mChannels && c < take.mNumChannels; ++c)
        if (take.mChannels[c])
            if (SceneNode* n = node(take.mChannels[c]->mNodeName.C_Str())) readChannel(*n, *take.mChannels[c], where);
    for (unsigned m = 0; scene.mMeshes && m < scene.mNumMeshes; ++m)
        for (unsigned b = 0; scene.mMeshes[m] && scene.mMeshes[m]->mBones && b < scene.mMeshes[m]->mNumBones; ++b)
            if (const aiBone* bone = scene.mMeshes[m]->mBones[b])
                if (SceneNode* n = node(bone->mName.C_Str())) n->marked = true;
    std::vector<char> above(nodes.size(), 0), below(nodes.size(), 0);
    for (std::size_t i = 0; i < nodes.size(); ++i)
        if (const int p = nodes[i].parent; p >= 0) above[i] = nodes[p].marked || above[p];
    for (std::size_t i = nodes.size(); i-- > 0;)
        if (const int p = nodes[i].parent; p >= 0 && (nodes[i].marked || below[i])) below[p] = 1;
    int joints = 0;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        nodes[i].joint = nodes[i].marked || (nodes[i].parent >= 0 && (above[i] || below[i]));
        joints += nodes[i].joint;
    }
    if (joints == 0)
        throw Error(
            fmt::format("{}: no channel of the take moves a node of the scene; a clip needs an animated "
                        "skeleton",
                        where));
    if (joints > bvhMaxJoints)
        throw Error(fmt::format("{}: {} joints, more than the {} a skeleton may have", where, joints, bvhMaxJoints));
    return joints;
}

// Frame numbering: a uniform step in ticks from the first key to the last.
struct FrameGrid {
    double first = 0.0;
    double step = 1.0;
    long long count = 1;
    double ticksPerSecond = defaultFramesPerSecond;
};

// The times of a take's channels that change: a channel of one key is a constant, whatever its time (assimp's glTF
// importer gives a node's unanimated translation, rotation or scale one key at time 0), so a take whose keys are
// all at one time is one pose, not two frames from 0 to that time. `earliest`: the first key of any channel.
std::vector<double> changingTimes(const std::vector<SceneNode>& nodes, double& earliest)
{
    std::vector<double> times;
    earliest = std::numeric_limits<double>::infinity();
    const auto add = [&](const auto& keys) {
        if (!keys.empty()) earliest = std::min(earliest, keys.front().time);
        if (keys.size() > 1)
            for (const auto& k : keys) times.push_back(k.time);
    };
    for (const SceneNode& n : nodes) {
        add(n.positions);
        add(n.rotations);
        add(n.scalings);
    }
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    return times;
}

// The step is the keys' spacing when every key of the take lies on it (exported and baked clips), otherwise
// 1/30 s; a take without ticks per second has its ticks read as frames at 30 per second.
FrameGrid frameGrid(const std::vector<SceneNode>& nodes, const aiAnimation& take, int joints, const std::string& where)
{
    FrameGrid grid;
    if (std::isfinite(take.mTicksPerSecond) && take.mTicksPerSecond > 0.0) grid.ticksPerSecond = take.mTicksPerSecond;
    double earliest = 0.0;
    const std::vector<double> times = changingTimes(nodes, earliest);
    if (times.size() < 2) {
        grid.step = grid.ticksPerSecond / defaultFramesPerSecond;
        grid.first = times.empty() ? (std::isfinite(earliest) ? earliest : 0.0) : times.front();
        return grid;
    }
    const double span = times.back() - times.front();
    double spacing = span;
    for (std::size_t i = 1; i < times.size(); ++i)
        if (times[i] - times[i - 1] > 1e-9 * span) spacing = std::min(spacing, times[i] - times[i - 1]);
    const bool onGrid = std::all_of(times.begin(), times.end(), [&](double t) {
        const double k = (t - times.front()) / spacing;
        return std::abs(k - std::round(k)) < 1e-3;
    });
    grid.first = times.front();
    grid.step = onGrid ? spacing : grid.ticksPerSecond / defaultFramesPerSecond;
    const double count = std::ceil(span / grid.step - 1e-6) + 1.0;
    if (count > static_cast<double>(assimpMaxFrames) || count * joints > static_cast<double>(assimpMaxJointFrames))
        throw Error(
            fmt::format("{}: {:.0f} frames of {} joints at the step of its keys, more than the {} frames or {} "
                        "joint-frames a take may have; cut the take shorter",
                        where, count, joints, assimpMaxFrames, assimpMaxJointFrames));
    grid.count = static_cast<long long>(count);
    return grid;
}

template <class Key, class Value, class Blend>
Value sampleKeys(const std::vector<Key>& keys, double time, const Value& rest, Blend blend)
{
    if (keys.empty()) return rest;
    if (time <= keys.front().time) return keys.front().value;
    if (time >= keys.back().time) return keys.back().value;
    const auto next =
        std::upper_bound(keys.begin(), keys.end(), time, [](double t, const Key& k) { return t < k.time; });
    const auto& b = *next;
    const auto& a = *(next - 1);
    const double span = b.time - a.time;
    return span > 0.0 ? blend(a.value, b.value, (time - a.time) / span) : b.value;
}

// A node's own transformation at a time: its channel's keys (translation, rotation, scaling, each held by the
// node's own value when the channel has no key of it), else its fixed transformation.
Eigen::Matrix4d localAt(const SceneNode& n, double time)
{
    if (!n.channel) return n.rest;
    const auto lerp = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b, double u) { return a + u * (b - a); };
    const auto slerp = [](const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double u) { return a.slerp(u, b); };
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 3>(0, 0) = sampleKeys(n.rotations, time, n.restRotation, slerp).matrix() *
                          sampleKeys(n.scalings, time, n.restScale, lerp).asDiagonal();
    m.block<3, 1>(0, 3) = sampleKeys(n.positions, time, n.restPosition, lerp);
    return m;
}

// Each joint's rigid local pose per frame: the polar rotation and the position of its world matrix (cm, Y
// up), relative to its parent joint's.
struct Poses {
    std::vector<int> joints;                                 // node index per joint, parents first
    std::vector<int> parents;                                // per joint, the parent joint (-1: a root)
    std::vector<std::vector<Eigen::Vector3d>> translations;  // [joint][frame]
    std::vector<std::vector<Eigen::Quaterniond>> rotations;  // [joint][frame]
};

Poses jointPoses(const std::vector<SceneNode>& nodes, const FrameGrid& grid, const Eigen::Matrix4d& normalise)
{
    Poses poses;
    std::vector<int> jointOf(nodes.size(), -1);
    std::vector<Eigen::Matrix4d> fixed(nodes.size(), Eigen::Matrix4d::Identity());  // nodes above the roots
    for (std::size_t i = 0; i < nodes.size(); ++i) {
        const int p = nodes[i].parent;
        const Eigen::Matrix4d parentWorld = p < 0 ? normalise : fixed[static_cast<std::size_t>(p)];
        if (!nodes[i].joint) {
            fixed[i] = parentWorld * nodes[i].rest;
            continue;
        }
        jointOf[i] = static_cast<int>(poses.joints.size());
        poses.joints.push_back(static_cast<int>(i));
        poses.parents.push_back(p < 0 ? -1 : jointOf[static_cast<std::size_t>(p)]);
        fixed[i] = parentWorld;  // what a root hangs from; unused below a joint
    }
    const std::size_t count = poses.joints.size();
    poses.translations.assign(count, std::vector<Eigen::Vector3d>(static_cast<std::size_t>(grid.count)));
    poses.rotations.assign(count, std::vector<Eigen::Quaterniond>(static_cast<std::size_t>(grid.count)));
    std::vector<Eigen::Matrix4d> world(count), rigid(count);
    for (long long f = 0; f < grid.count; ++f) {
        const double time = grid.first + static_cast<double>(f) * grid.step;
        for (std::size_t j = 0; j < count; ++j) {
            const auto node = static_cast<std::size_t>(poses.joints[j]);
            const int parent = poses.parents[j];
            world[j] =
                (parent < 0 ? fixed[node] : world[static_cast<std::size_t>(parent)]) * localAt(nodes[node], time);
            rigid[j].setIdentity();
            rigid[j].block<3, 3>(0, 0) = polarRotation(world[j].block<3, 3>(0, 0));
            rigid[j].block<3, 1>(0, 3) = world[j].block<3, 1>(0, 3);
            const Eigen::Matrix4d local =
                parent < 0 ? rigid[j] : Eigen::Matrix4d(rigid[static_cast<std::size_t>(parent)].inverse() * rigid[j]);
            poses.translations[j][static_cast<std::size_t>(f)] = local.block<3, 1>(0, 3);
            poses.rotations[j][static_cast<std::size_t>(f)] =
                Eigen::Quaterniond(Eigen::Matrix3d(local.block<3, 3>(0, 0)));
        }
    }
    return poses;
}

// The rotation order whose middle angle stays furthest from +-90 degrees (gimbal lock) over the frames.
RotateOrder steadiestOrder(const std::vector<Eigen::Quaterniond>& rotations)
{
    RotateOrder best = RotateOrder::xyz;
    double bestWorst = std::numeric_limits<double>::infinity();
    for (int o = 0; o < 6; ++o) {
        const RotateOrder order = *rotateOrderFromIndex(o);
        const int middle = rotateOrderName(order)[1] - 'x';
        double worst = 0.0;
        for (const auto& q : rotations) worst = std::max(worst, std::abs(matrixToEuler(q.matrix(), order)[middle]));
        if (worst < bestWorst - 1e-12) {
            bestWorst = worst;
            best = order;
        }
    }
    return best;
}

constexpr BvhChannel positionChannels[] = {BvhChannel::Xposition, BvhChannel::Yposition, BvhChannel::Zposition};
constexpr BvhChannel rotationChannels[] = {BvhChannel::Xrotation, BvhChannel::Yrotation, BvhChannel::Zrotation};

// The poses as a BvhClip: position channels where a joint's translation moves (the whole local translation),
// rotation channels where its rotation is not the identity, Euler angles continuous from frame to frame.
BvhClip poseClip(const std::vector<SceneNode>& nodes, const Poses& poses, const FrameGrid& grid,
                 const std::string& file)
{
    BvhClip clip;
    clip.file = file;
    clip.frameCount = static_cast<int>(grid.count);
    clip.frameTime = grid.step / grid.ticksPerSecond;
    std::vector<std::vector<std::vector<double>>> columns;  // [joint][channel][frame]
    for (std::size_t j = 0; j < poses.joints.size(); ++j) {
        BvhJoint& joint = clip.joints.emplace_back();
        joint.name = nodes[static_cast<std::size_t>(poses.joints[j])].name;
        joint.parent = poses.parents[j];
        joint.depth = joint.parent < 0 ? 0 : clip.joints[static_cast<std::size_t>(joint.parent)].depth + 1;
        joint.firstChannel = clip.channelCount;
        const auto& ts = poses.translations[j];
        const auto& qs = poses.rotations[j];
        joint.offset = ts.front();
        auto& values = columns.emplace_back();
        // Files store floats: a scale decomposed from a key's matrix moves a child's translation by ~1e-7 of
        // its length; what moves less than translationNoise of it is held at the first frame's.
        const double still = translationNoise * (1.0 + ts.front().norm());
        const bool moves =
            std::any_of(ts.begin(), ts.end(), [&](const auto& t) { return (t - ts.front()).norm() > still; });
        if (moves) {
            joint.positionReplacesOffset = true;
            for (int axis = 0; axis < 3; ++axis) {
                joint.channels.push_back(positionChannels[axis]);
                auto& column = values.emplace_back();
                for (const auto& t : ts) column.push_back(t[axis]);
            }
        }
        const bool turns = std::any_of(qs.begin(), qs.end(), [](const auto& q) {
            return q.angularDistance(Eigen::Quaterniond::Identity()) > 1e-9;
        });
        if (turns) {
            const RotateOrder order = steadiestOrder(qs);
            const std::string_view letters = rotateOrderName(order);
            std::vector<Eigen::Vector3d> angles;
            for (const auto& q : qs) {
                const Eigen::Vector3d euler = matrixToEuler(q.matrix(), order);
                angles.push_back(angles.empty() ? euler : closestEuler(euler, angles.back(), order));
            }
            // R = R(letters[2]) R(letters[1]) R(letters[0]): BVH lists the rotations in that product's order.
            for (int k = 2; k >= 0; --k) {
                const int axis = letters[static_cast<std::size_t>(k)] - 'x';
                joint.channels.push_back(rotationChannels[axis]);
                auto& column = values.emplace_back();
                for (const auto& a : angles) column.push_back(a[axis] * 180.0 / std::numbers::pi);
            }
        }
        clip.channelCount += static_cast<int>(joint.channels.size());
    }
    clip.values.reserve(static_cast<std::size_t>(clip.frameCount) * static_cast<std::size_t>(clip.channelCount));
    for (int f = 0; f < clip.frameCount; ++f)
        for (const auto& joint : columns)
            for (const auto& column : joint) clip.values.push_back(column[static_cast<std::size_t>(f)]);
    return clip;
}

// The take of an imported scene as a clip; `head`: the file's first bytes (Collada's asset, for the report).
SkeletalClip sceneClip(const aiScene& scene, const std::string& file, std::string_view head, const std::string& take)
{
    if (scene.mNumAnimations == 0 || !scene.mAnimations || !scene.mRootNode)
        throw Error(fmt::format("{}: has no animation; a clip needs a skeleton and its motion", file));
    SkeletalClip out;
    ClipSource& source = out.source;
    source.format = formatName(scene, std::filesystem::path(file).extension().string());
    source.takeIndex = chooseTake(scene, take, file);
    source.takeCount = static_cast<int>(scene.mNumAnimations);
    if (!scene.mAnimations[source.takeIndex])
        throw Error(fmt::format("{}: take {} is empty; the file is damaged", file, source.takeIndex));
    const aiAnimation& animation = *scene.mAnimations[source.takeIndex];
    source.take = animation.mName.C_Str();
    const std::string where = source.take.empty() ? fmt::format("{}: take {}", file, source.takeIndex)
                                                  : fmt::format("{}: take '{}'", file, messageExcerpt(source.take, 60));
    const Eigen::Matrix4d normalise = normalisation(scene, file, head, source);
    std::vector<SceneNode> nodes = flattenNodes(scene, file);
    const int joints = markJoints(scene, animation, nodes, where);
    const FrameGrid grid = frameGrid(nodes, animation, joints, where);
    source.framesPerSecond = grid.ticksPerSecond / grid.step;
    out.clip = poseClip(nodes, jointPoses(nodes, grid, normalise), grid, file);
    const std::vector<std::string> names = bvhRigJointNames(out.clip);
    for (std::size_t j = 0; j < names.size(); ++j) out.clip.joints[j].name = names[j];
    return out;
}

// No post-processing, not even aiProcess_ValidateDataStructure: it refuses a scene without a mesh (a BVH file, a
// bare skeleton). What is read here (nodes, channels, keys, bones) is checked here instead.
void configure(Assimp::Importer& importer)
{
    // FBX pivots folded into their nodes, not helper nodes between the joints.
    importer.SetPropertyBool(AI_CONFIG_IMPORT_FBX_PRESERVE_PIVOTS, false);
    // No stand-in mesh for a file without one (BVH, Collada): its bones would name every node a joint.
    importer.SetPropertyBool(AI_CONFIG_IMPORT_NO_SKELETON_MESHES, true);
}

// The scene assimp imported, or its reason in one line. (assimp catches its importers' exceptions; what
// escapes it is the child's to report, clip_isolation.h.)
const aiScene& imported(const Assimp::Importer& importer, const aiScene* scene, const std::string& file)
{
    // assimp reports the child's memory limit (clip_isolation.h) as its reason: said as the limit, not as a format.
    if (!scene && std::string_view(importer.GetErrorString()).find("bad_alloc") != std::string_view::npos)
        throw std::bad_alloc();
    if (!scene)
        throw Error(fmt::format("{}: assimp cannot read it: {}; give a file of a format assimp reads (docs/clips.md)",
                                file, oneLine(importer.GetErrorString(), 200)));
    return *scene;
}

}  // namespace

std::string ClipSource::describe(double mapScale, const std::string& mapFile) const
{
    const std::string takeText = take.empty() ? fmt::format("take {}", takeIndex)
                                              : fmt::format("take {} '{}'", takeIndex, messageExcerpt(take, 60));
    const std::string byMap = mapScale == 1.0 ? "" : fmt::format("; x{:.6g} by the map {}", mapScale, mapFile);
    return fmt::format("{}, units x{:.6g} to cm ({}{}), up axis {}, {} of {}, {:.6g} fps", format, unitsToCm * mapScale,
                       units, byMap, upAxis, takeText, takeCount, framesPerSecond);
}

SkeletalClip readAssimpClip(const std::filesystem::path& file, const std::string& take)
{
    // The limits on the file in this process; assimp in a child (clip_isolation.h).
    const std::string bytes = readInputFile(file, animationFileKind);
    return readClipIsolated(
        [&] {
            Assimp::Importer importer;
            configure(importer);
            return sceneClip(imported(importer, importer.ReadFile(file.string(), 0), file.string()), file.string(),
                             bytes, take);
        },
        file.string(), childLimitsFor(bytes.size()));
}

SkeletalClip parseAssimpClip(std::string_view bytes, const std::string& hint, const std::string& fileName,
                             const std::string& take)
{
    return readClipIsolated(
        [&] {
            Assimp::Importer importer;
            configure(importer);
            const aiScene* scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(), 0, hint.c_str());
            return sceneClip(imported(importer, scene, fileName), fileName, bytes, take);
        },
        fileName, childLimitsFor(bytes.size()));
}

ClipReader clipReaderFor(std::string_view text, const std::filesystem::path& file)
{
    if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
    const auto start = text.find_first_not_of(" \t\r\n");
    const std::string_view content = start == std::string_view::npos ? std::string_view() : text.substr(start);
    if (content.starts_with("HIERARCHY")) return ClipReader::bvh;
    if (content.starts_with("[")) return ClipReader::json;
    const bool gltf = text.substr(0, 65536).find("\"asset\"") != std::string_view::npos;
    if (content.starts_with("{") && !gltf) return ClipReader::json;
    const std::string extension = lowerExtension(file);
    if (extension == ".bvh") return ClipReader::bvh;
    if (extension == ".json" && !gltf) return ClipReader::json;
    return ClipReader::assimp;
}

InputFileKind clipFileKind(const std::filesystem::path& file)
{
    const std::string extension = lowerExtension(file);
    if (extension == ".bvh") return {"a BVH file", "a .bvh file", bvhMaxFileBytes, "cut the clip into shorter ones"};
    if (extension == ".json") return {"a JSON clip", "a JSON clip", bvhMaxFileBytes, "cut it into shorter files"};
    return animationFileKind;
}

SkeletalClip parseBvhSkeletalClip(std::string_view text, const std::string& fileName, const std::string& take)
{
    if (!take.empty() && take != "0")
        throw Error(fmt::format("{}: no take '{}'; a BVH file has one take, 0; leave --take out", fileName,
                                messageExcerpt(take, 60)));
    SkeletalClip out;
    out.clip = parseBvh(text, fileName);
    out.source.format = "BVH";
    out.source.units = "BVH has no unit: taken as is";
    out.source.framesPerSecond = 1.0 / out.clip.frameTime;
    return out;
}

SkeletalClip readSkeletalClip(const std::filesystem::path& file, const std::string& take)
{
    const std::string bytes = readInputFile(file, clipFileKind(file));
    switch (clipReaderFor(bytes, file)) {
        case ClipReader::bvh:
            return parseBvhSkeletalClip(bytes, file.string(), take);
        case ClipReader::json:
            throw Error(
                fmt::format("{}: a JSON clip of world matrices has no skeleton; give a BVH file or an animation "
                            "assimp reads (FBX, glTF, Collada, X, ...)",
                            file.string()));
        case ClipReader::assimp:
            break;
    }
    return readAssimpClip(file, take);
}

bool isClipFile(const std::filesystem::path& file)
{
    const std::string extension = lowerExtension(file);
    return extension == ".bvh" || extension == ".json" ||
           (extension.size() > 1 && Assimp::Importer().IsExtensionSupported(extension));
}

}  // namespace rig

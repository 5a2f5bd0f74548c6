// bvhClip: plays a BVH motion file (nodes/clips/bvh.h, docs/bvh.md); skeletonClip: a take of any skeletal
// animation file, BVH or one assimp reads (nodes/clips/assimp_clip.h, docs/clips.md), as the same channels.
// Both output every joint's world matrix by plain forward kinematics and every channel as a number to drive a
// rig with.
#include <memory>
#include <string>

#include <fmt/format.h>

#include "core/shared_file.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/assimp_clip.h"
#include "nodes/clips/bvh.h"

namespace rig {
namespace {

// take and source last: bvhClip declares the attributes before them only.
enum Attr : AttrId { file, time, worldMatrix, channel, jointNames, channelNames, frameCount, frameTime, take, source };

std::string joinLines(const std::vector<std::string>& lines)
{
    std::string out;
    for (const auto& line : lines) {
        if (!out.empty()) out += '\n';
        out += line;
    }
    return out;
}

// A clip as the nodes play it, shared by every node that plays the same file and take (core/shared_file.h):
// a crowd's members each play the one clip.
struct PlayedClip {
    SkeletalClip clip;
    std::string jointNames;
    std::string channelNames;
};

PlayedClip played(SkeletalClip clip)
{
    std::vector<std::string> joints;
    std::vector<std::string> channels;
    for (const BvhJoint& j : clip.clip.joints) {
        joints.push_back(j.name);
        for (BvhChannel ch : j.channels) channels.push_back(fmt::format("{}.{}", j.name, bvhChannelName(ch)));
    }
    return PlayedClip{std::move(clip), joinLines(joints), joinLines(channels)};
}

// `General`: skeletonClip (any format, a take), else bvhClip (BVH only).
template <bool General>
class ClipNode : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const std::string& path = c.getString(file);
        static const std::string noTake;
        const std::string& takeName = General ? c.getString(take) : noTake;
        // The parsed file is kept: it is read again only when `file` (or `take`) names another one, and so are
        // the outputs that only the file decides (the names, the frame count). A failed read leaves the node
        // as it was, so the next evaluation tries again.
        if (!clip_ || path != loadedPath_ || takeName != loadedTake_) {
            clip_ = load(path, takeName);
            loadedPath_ = path;
            loadedTake_ = takeName;
            if constexpr (General)
                c.setOutput(source, clip_->clip.source.format.empty() ? "" : clip_->clip.source.describe());
            c.setOutput(jointNames, clip_->jointNames);
            c.setOutput(channelNames, clip_->channelNames);
            c.setOutput(frameCount, clip_->clip.clip.frameCount);
            c.setOutput(frameTime, clip_->clip.clip.frameTime);
        }
        const BvhClip& clip = clip_->clip.clip;
        if (clip.frameCount == 0) {
            c.setOutputElements(worldMatrix, {});
            c.setOutputElements(channel, {});
            return;
        }
        // The frame's motion line, worlds and channels, on the computing thread's buffers: they are copied into the
        // outputs at once, so a crowd's members reuse one set, warm in the cache, and a frame allocates nothing.
        thread_local FrameScratch scratch;
        bvhSample(clip, c.getDouble(time), scratch.values);
        bvhWorldMatrices(clip, scratch.values, scratch.worlds);
        c.assignOutputElements(worldMatrix, scratch.worlds);
        bvhRigChannels(clip, scratch.values, scratch.channels);
        c.assignOutputElements(channel, scratch.channels);
    }

private:
    struct FrameScratch {
        std::vector<double> values, channels;
        std::vector<Eigen::Matrix4d> worlds;
    };

    static std::shared_ptr<const PlayedClip> load(const std::string& path, const std::string& takeName)
    {
        if (path.empty()) return std::make_shared<const PlayedClip>();
        return sharedFileValue<PlayedClip>(path, fmt::format("{}\n{}", General ? "take" : "bvh", takeName), [&] {
            return played(General ? readSkeletalClip(path, takeName) : SkeletalClip{readBvhFile(path), {}});
        });
    }

    std::string loadedPath_;
    std::string loadedTake_;
    std::shared_ptr<const PlayedClip> clip_;
};

// The attributes the two types share; `what` names the file in the docs.
void declareClip(NodeTypeBuilder& b, std::string_view what)
{
    b.input(file, "file", ValueType::String)
        .filePath()
        .doc(fmt::format("Path of the {}; in a rig file a relative path is read from the rig file's folder. Empty: "
                         "no joints.",
                         what));
    b.input(time, "time", ValueType::Double).unit(Unit::Time).sceneTime().doc("Frame to play (1 = the first frame).");
    b.output(worldMatrix, "worldMatrix", ValueType::Matrix4)
        .array()
        .doc("World matrix of each joint, file order (End Sites excluded).");
    b.output(channel, "channel", ValueType::Double)
        .array()
        .doc(
            "Each channel, file order: rotations in degrees as unitless numbers (connected to an angle they "
            "become radians), positions as the joint's whole local translation in cm (OFFSET included).");
    b.output(jointNames, "jointNames", ValueType::String).doc("Joint names, file order, one per line.");
    b.output(channelNames, "channelNames", ValueType::String)
        .doc("Channel names as JOINT.Xrotation, file order, one per line.");
    b.output(frameCount, "frameCount", ValueType::Int).doc("Number of frames.");
    b.output(frameTime, "frameTime", ValueType::Double).doc("Seconds per frame.");
}

}  // namespace

std::shared_ptr<const NodeType> makeBvhClipType()
{
    NodeTypeBuilder b("bvhClip");
    b.description(
        "Plays a BVH motion file (docs/bvh.md): worldMatrix[j] is joint j's world matrix by forward "
        "kinematics and channel[k] channel k's value, both in file order. Frame 1 is the first motion "
        "line; times outside 1..frameCount hold the end frames, and between frames every channel is "
        "interpolated linearly (rotations the shorter way round), worldMatrix being the kinematics of "
        "those channels. The file is read once and cached until `file` changes. skeletonClip reads "
        "other formats too.");
    declareClip(b, ".bvh file");
    b.affects(file, {worldMatrix, channel, jointNames, channelNames, frameCount, frameTime});
    b.affects(time, {worldMatrix, channel});
    return b.factory<ClipNode<false>>().build();
}

std::shared_ptr<const NodeType> makeSkeletonClipType()
{
    NodeTypeBuilder b("skeletonClip");
    b.description(
        "Plays a take of any skeletal animation file, by its content: BVH through the BVH reader, FBX, glTF, "
        "Collada, X, SMD, MD5 and the other formats assimp reads through assimp, in cm and Y up "
        "(docs/clips.md). The file becomes joints and channels as a BVH clip does (a frame per key step, "
        "rotation channels in the steadiest order), so the outputs are bvhClip's: worldMatrix[j] joint j's "
        "world matrix, channel[k] channel k's value, frame 1 the first frame, the ends held, channels "
        "interpolated linearly between frames. The file is read once and cached until `file` or `take` "
        "changes.");
    declareClip(b, "animation file (BVH, FBX, glTF, Collada, X, ...)");
    b.input(take, "take", ValueType::String)
        .doc("The take (animation) to play: its name or 0-based index; empty: the first.");
    b.output(source, "source", ValueType::String)
        .doc("The file's format, unit factor to cm, up axis, take and frame rate, as rig-invert reports them.");
    b.affects(file, {worldMatrix, channel, jointNames, channelNames, frameCount, frameTime, source});
    b.affects(take, {worldMatrix, channel, jointNames, channelNames, frameCount, frameTime, source});
    b.affects(time, {worldMatrix, channel});
    return b.factory<ClipNode<true>>().build();
}

}  // namespace rig

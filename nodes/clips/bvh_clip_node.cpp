// bvhClip: plays a BVH motion file (nodes/clips/bvh.h, docs/bvh.md). Outputs every joint's world
// matrix by plain forward kinematics and every channel as a number to drive a rig with.
#include <memory>
#include <string>

#include <fmt/format.h>

#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"

namespace rig {
namespace {

enum Attr : AttrId { file, time, worldMatrix, channel, jointNames, channelNames, frameCount, frameTime };

std::string joinLines(const std::vector<std::string>& lines)
{
    std::string out;
    for (const auto& line : lines) {
        if (!out.empty()) out += '\n';
        out += line;
    }
    return out;
}

class BvhClipNode : public Node {
public:
    void compute(ComputeContext& c) override
    {
        const std::string& path = c.getString(file);
        // The parsed file is cached: it is read again only when `file` names another file. A failed
        // read leaves the cache as it was, so the next evaluation tries again.
        if (!loaded_ || path != loadedPath_) {
            clip_ =
                path.empty() ? std::make_shared<const BvhClip>() : std::make_shared<const BvhClip>(readBvhFile(path));
            loadedPath_ = path;
            loaded_ = true;
        }
        const BvhClip& clip = *clip_;

        std::vector<std::string> joints;
        std::vector<std::string> channels;
        for (const BvhJoint& j : clip.joints) {
            joints.push_back(j.name);
            for (BvhChannel ch : j.channels) channels.push_back(fmt::format("{}.{}", j.name, bvhChannelName(ch)));
        }
        c.setOutput(jointNames, joinLines(joints));
        c.setOutput(channelNames, joinLines(channels));
        c.setOutput(frameCount, clip.frameCount);
        c.setOutput(frameTime, clip.frameTime);
        if (clip.frameCount == 0) {
            c.setOutputElements(worldMatrix, {});
            c.setOutputElements(channel, {});
            return;
        }
        const std::vector<double> values = bvhSample(clip, c.getDouble(time));
        std::vector<Value> matrices;
        for (const Eigen::Matrix4d& m : bvhWorldMatrices(clip, values)) matrices.emplace_back(m);
        c.setOutputElements(worldMatrix, std::move(matrices));
        std::vector<Value> numbers;
        for (double x : bvhRigChannels(clip, values)) numbers.emplace_back(x);
        c.setOutputElements(channel, std::move(numbers));
    }

private:
    bool loaded_ = false;
    std::string loadedPath_;
    std::shared_ptr<const BvhClip> clip_;
};

}  // namespace

std::shared_ptr<const NodeType> makeBvhClipType()
{
    NodeTypeBuilder b("bvhClip");
    b.description(
        "Plays a BVH motion file (docs/bvh.md): worldMatrix[j] is joint j's world matrix by forward "
        "kinematics and channel[k] channel k's value, both in file order. Frame 1 is the first motion "
        "line; times outside 1..frameCount hold the end frames, and between frames every channel is "
        "interpolated linearly (rotations the shorter way round), worldMatrix being the kinematics of "
        "those channels. The file is read once and cached until `file` changes.");
    b.input(file, "file", ValueType::String)
        .filePath()
        .doc(
            "Path of the .bvh file; in a rig file a relative path is read from the rig file's folder. Empty: no "
            "joints.");
    b.input(time, "time", ValueType::Double).unit(Unit::Time).sceneTime().doc("Frame to play (1 = first motion line).");
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
    b.output(frameCount, "frameCount", ValueType::Int).doc("Number of motion lines.");
    b.output(frameTime, "frameTime", ValueType::Double).doc("Seconds per frame.");
    b.affects(file, {worldMatrix, channel, jointNames, channelNames, frameCount, frameTime});
    b.affects(time, {worldMatrix, channel});
    return b.factory<BvhClipNode>().build();
}

}  // namespace rig

#pragma once
// BVH (Biovision Hierarchy) motion files: a reader producing a plain immutable BvhClip, and a plain
// forward-kinematics evaluation of it written independently of the graph (the reference the tests
// compare rigs against). docs/bvh.md describes what is supported.
//
// Channels. Each joint lists its channels in file order; a motion line holds every joint's channel
// values in that order, joint after joint (file order). Rotations are degrees. Any order of the
// rotation channels is accepted, repeated axes and fewer than three rotations included.
//
// Local matrix of a joint (column vectors, world = parentWorld * local):
//     local = T(translation) * R1 * R2 * ... * Rn
// where R1..Rn are the joint's rotation channels in file order: "Zrotation Xrotation Yrotation" gives
// R = Rz * Rx * Ry (Y is applied first). Position channels always form the translation, whatever
// their place in the channel list (as every BVH reader does).
//
// Position channels: the rule. Exporters disagree on what a joint's position channels hold: an offset
// added to OFFSET (CMU, most readers), or the whole local translation, replacing OFFSET (e.g. files
// where every joint has six channels). The reader detects it from the data: over every frame and
// every position channel of a group of joints, it compares
//     sumReplace = sum of (value - OFFSET[axis])^2     with     sumAdd = sum of value^2
// and decides "replace" when sumReplace < sumAdd (the values lie nearer OFFSET than zero), otherwise
// "add" (ties, e.g. OFFSET = 0, give "add"; both conventions then give the same matrices). Each root
// joint is one group on its own; all non-root joints with position channels form one group (an
// exporter writes them all the same way). The decision is stored per joint in
// BvhJoint::positionReplacesOffset. A position axis without a channel keeps OFFSET's value in both
// conventions.
//
// Errors: readBvhFile and parseBvh throw rig::Error with "FILE:LINE: what is wrong; what to do".

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace rig {

enum class BvhChannel { Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation };

// "Xposition" ... "Zrotation", as files write them.
std::string_view bvhChannelName(BvhChannel channel);
// 0, 1, 2 for X, Y, Z.
int bvhChannelAxis(BvhChannel channel);
bool bvhIsRotation(BvhChannel channel);

struct BvhJoint {
    std::string name;  // as in the file (colons and spaces kept)
    int parent = -1;   // index in BvhClip::joints, -1 for a root
    int depth = 0;     // 0 for a root
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    std::vector<BvhChannel> channels;        // file order
    int firstChannel = 0;                    // column of channels[0] in a motion line
    std::optional<Eigen::Vector3d> endSite;  // the End Site's OFFSET, relative to this joint
    bool positionReplacesOffset = false;     // see "Position channels" above
    int line = 0;                            // line of its ROOT/JOINT keyword
};

struct BvhClip {
    std::string file;                   // as given to the reader, for messages
    std::vector<BvhJoint> joints;       // file order: a parent comes before its children
    int channelCount = 0;               // values per motion line
    int frameCount = 0;                 // motion lines read (not necessarily the "Frames:" count)
    double frameTime = 0.0;             // seconds per frame, > 0
    std::vector<double> values;         // frameCount x channelCount, row by row
    std::vector<std::string> warnings;  // "FILE:LINE: ..." for oddities that did not stop the reader

    // Motion line `index` (0-based: index 0 is the first line after "Frame Time").
    std::span<const double> frame(int index) const;
};

// Sane limits: beyond them the file is refused (it is not a skeleton, or it is damaged).
inline constexpr int bvhMaxJoints = 10000;
inline constexpr int bvhMaxDepth = 256;
inline constexpr int bvhMaxChannelsPerJoint = 64;
inline constexpr int bvhMaxNameLength = 500;  // bvh2rig adds a prefix and suffixes within the rig name limit
// Files larger than this are refused before reading (the parsed clip costs about as much memory as the
// file again, or up to four times for one-character values).
inline constexpr std::uintmax_t bvhMaxFileBytes = std::uintmax_t{512} << 20;

// Parses BVH text; `fileName` names it in messages. CRLF, CR or LF line ends, tabs, a UTF-8 BOM and
// blank lines are accepted. A "Frames:" count that disagrees with the motion lines adds a warning and
// the lines win.
BvhClip parseBvh(std::string_view text, const std::string& fileName);
// Reads and parses a file.
BvhClip readBvhFile(const std::filesystem::path& file);

// The joint's local translation for one motion line: OFFSET with its position channels added or
// substituted (positionReplacesOffset).
Eigen::Vector3d bvhTranslation(const BvhClip& clip, int joint, std::span<const double> frame);

// A motion line as rig parameters: rotations unchanged (degrees), position channels turned into the
// component of the whole local translation (cm), so that a joint with translate = that value and
// rotate = the rotation channels reproduces the BVH joint.
std::vector<double> bvhRigChannels(const BvhClip& clip, std::span<const double> frame);
void bvhRigChannels(const BvhClip& clip, std::span<const double> frame, std::vector<double>& out);

// The motion line at a scene time in frames (1 = the first motion line). Times before 1 or after
// frameCount clamp to the ends. Between two lines each channel is interpolated linearly; rotation
// channels go the shorter way round (the difference is wrapped into [-180, 180) degrees) so that an
// angle passing from 179 to -179 does not spin the other way. NaN gives frame 1. Needs frameCount >= 1
// (every clip the reader returns has it).
std::vector<double> bvhSample(const BvhClip& clip, double time);
void bvhSample(const BvhClip& clip, double time, std::vector<double>& out);

// Forward kinematics: the world matrix of every joint (file order) for one motion line, as
// world = parentWorld * T(translation) * R1 * ... * Rn. An End Site's world position is
// world[joint] * (endSite, 1). The forms with `out` resize it in place (a player's frame allocates nothing).
std::vector<Eigen::Matrix4d> bvhWorldMatrices(const BvhClip& clip, std::span<const double> frame);
void bvhWorldMatrices(const BvhClip& clip, std::span<const double> frame, std::vector<Eigen::Matrix4d>& out);
std::vector<Eigen::Matrix4d> bvhWorldMatrices(const BvhClip& clip, int frameIndex);

}  // namespace rig

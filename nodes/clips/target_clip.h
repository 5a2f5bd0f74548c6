#pragma once
// Target joints for an inversion: world matrices per frame by joint name, read from (by the file's content)
//   - a BVH file (its joints' world matrices by the reference forward kinematics, nodes/clips/bvh.h), or
//   - a take of any skeletal animation assimp reads (FBX, glTF, Collada, X, ...: nodes/clips/assimp_clip.h,
//     in cm and Y up, joints named as skel2rig names its rig's; docs/clips.md), or
//   - a JSON file of matrices as graph-eval writes them: a list of frames, each {"frame": F,
//     "JOINT.worldMatrix": [[4 numbers] x 4 rows], ...} (column-vector convention, cm; null, graph-eval's
//     number that is not finite, reads as NaN: the solver reports that frame's target as invalid),
// renamed and scaled by an optional map file (docs/retargeting.md; its `retarget:` and `weights:` need the
// approximation, and adapter/retarget.h applies them):
//
//   scale: 5.644444444          # target units -> cm (a CMU clip: 2.54 / 0.45); 1 by default
//   joints:                     # target joint -> rig joint; joints not listed keep their names
//     LeftUpLeg: L_thigh
//   ignore: [LHipJoint]         # target joints that must not be targets
//   retarget:                   # a clip of other proportions onto the rig's (adapter/retarget.h)
//     rootScale: auto           # or a number; auto: the rig's leg length over the clip's, along `leg`
//     leg: [LeftUpLeg, LeftLeg, LeftFoot]
//     align: {LeftArm: [0, 0, -45]}   # degrees; default: the rest orientations' difference
//   weights:                    # per rig joint; 1 by default
//     LeftHand: {position: 1, rotation: 0.2}
//
// Errors (missing or malformed files, a map naming joints the clip does not have) throw rig::Error with
// file:line:col where known.

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "graph/maya/maya_loader.h"

namespace rig {

// The map's `retarget:` key (docs/retargeting.md). Each entry keeps its place in the map file (file:line:col) for
// messages; names are the rig's (after `joints:`).
struct RetargetSpec {
    bool enabled = false;  // the map has `retarget:`
    std::string where;     // the key's place
    // The root's translation factor; none: auto, from `leg`.
    std::optional<double> rootScale;
    std::string rootScaleWhere;
    std::vector<std::string> leg;       // hip to ankle, for rootScale auto
    std::vector<std::string> legWhere;  // each entry's place
    // Per rig joint, its rest orientation in the clip joint's rest frame: XYZ Euler angles in degrees.
    std::map<std::string, Eigen::Vector3d> align;
    std::map<std::string, std::string> alignWhere;
};

struct TargetWeight {
    double position = 1.0;  // JointTarget::positionWeight
    double rotation = 1.0;  // JointTarget::rotationWeight
    std::string where;      // the entry's place in the map file
};

struct TargetMap {
    std::string file;                           // the map file, for messages ("" for none)
    double scale = 1.0;                         // multiplies translations: target units -> cm
    std::map<std::string, std::string> rename;  // target joint -> rig joint
    std::map<std::string, int> renameLines;     // the line of each entry, for messages
    std::vector<std::string> ignore;            // target joints left out
    std::map<std::string, int> ignoreLines;     // the line of each, for messages
    RetargetSpec retarget;
    std::map<std::string, TargetWeight> weights;  // by rig joint
};

TargetMap readTargetMap(const std::filesystem::path& file);
// The same from a map file's text; `fileName` is used in messages.
TargetMap parseTargetMap(std::string_view text, const std::string& fileName);

// What a clip read from a Maya scene holds beside its joints (nodes/clips/maya_clip.h).
struct ClipScene {
    MayaSceneInfo info;  // the scene's units, frame rate, references and time curves
    // Per entry of info.timeCurves, the value the curve gives its plug at each frame of the clip, in internal units
    // (radians, cm); empty where it drives no plug of the graph.
    std::vector<std::vector<double>> curveValues;
};

struct TargetClip {
    std::string file;                                  // as given, for messages
    std::vector<std::string> joints;                   // rig joint names (after the map), file order
    std::vector<double> frameNumbers;                  // as the file numbers its frames (BVH: 1 = first line)
    std::vector<std::vector<Eigen::Matrix4d>> worlds;  // [frame][joint], world matrices, cm
    // Per joint its parent (its nearest ancestor the map kept), -1 for a root or when the file does not say
    // (JSON clips): for drawing the skeleton (rig-invert --html).
    std::vector<int> parents;
    // Per joint its world matrix in the clip's rest pose (the skeleton's offsets without rotation: BVH's zero
    // pose), scaled as the frames; empty when the file has no skeleton (JSON clips, targets made in memory).
    std::vector<Eigen::Matrix4d> restWorlds;
    double frameTime = 0.0;  // seconds per frame (a BVH file's Frame Time), 0 when the file does not say
    // What the file is and how it was normalised (ClipSource::describe: format, unit factor, up axis, take), for
    // reports; "" for targets made in memory.
    std::string source;
    std::shared_ptr<const ClipScene> scene;  // a Maya scene's clip: what the scene holds beside its joints; else null
};

// Reads a target clip and applies the map. What the file is comes from its content: a Maya ASCII scene
// ("//Maya ASCII": nodes/clips/maya_clip.h), BVH text ("HIERARCHY"), a JSON list of frames ('[', or '{' without glTF's
// "asset"), anything else through assimp. `take`: the animation to read from a file that has several (a name or 0-based
// index; "": the first); a BVH or JSON file has one, 0.
TargetClip readTargetClip(const std::filesystem::path& file, const TargetMap& map, const std::string& take = "");
// A .json clip from its text; `fileName` is used in messages.
TargetClip parseJsonTargetClip(std::string_view text, const std::string& fileName, const TargetMap& map);

// JSON, strictly: one value and nothing after it (YAML, which reads JSON files here, would take a second value or
// trailing text as more of the file, or ignore them). Throws rig::Error "FILE:LINE:COL: JSON syntax error: WHAT;
// SHAPE", SHAPE saying what the file holds ("a JSON clip is one list of frames, as graph-eval writes it").
void checkStrictJson(std::string_view text, const std::string& file, std::string_view shape);
// Targets made in memory (the Python module's arrays, a Maya scene's joints), with the map applied as to a file's
// joints: `clip.joints` and `clip.worlds` are the given names and matrices, `clip.file` names them in messages; the
// rest of `clip` is kept.
TargetClip applyTargetMap(const TargetClip& clip, const TargetMap& map);

}  // namespace rig

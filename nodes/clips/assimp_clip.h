#pragma once
// Skeletal animation from any file the Open Asset Import Library (assimp) reads: FBX, glTF/GLB, Collada, X,
// SMD, MD5, HL1 MDL, BVH, ... (docs/clips.md). A take (one of the file's animations) becomes a BvhClip, the
// project's plain skeleton-and-channels clip, so that everything built on BVH clips (target clips, bvh2rig's
// rigs, the clip nodes) reads these files the same way:
//   - joints: the nodes an animation channel moves or a mesh's bone names, their ancestors below the scene's
//     root and their descendants; the scene's root (where assimp puts unit and axis conversions) is folded
//     into the roots;
//   - each joint's world matrix at a frame is made rigid (its polar rotation, scale removed; positions exact),
//     then expressed in its parent's: translation channels where the translation moves (the whole local
//     translation, positionReplacesOffset), three rotation channels where the rotation is not the identity,
//     in the rotation order whose middle angle stays furthest from gimbal lock over the take;
//   - joint names: as skel2rig names the rig's joints (legal node names, unique: bvhRigJointNames), so that the
//     targets match that rig without a map;
//   - units and axes: centimetres, Y up, from the file's own metadata (FBX: UnitScaleFactor and the axis
//     triple; glTF: metres; Collada: metres once assimp applied <unit> and <up_axis>; other formats as is);
//   - frames: a uniform step, the spacing of the take's key times when every key lies on it, else 30 per
//     second; keys interpolated linearly (rotations by slerp), held before the first and after the last.
// Errors are rig::Error (userInput) with the file and what to do, in one line.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/input_file.h"
#include "nodes/clips/bvh.h"

namespace rig {

// What a clip's file is and how it was normalised, for reports.
struct ClipSource {
    std::string format;        // "BVH", "FBX", "glTF", "Collada", ... or assimp's importer name
    double unitsToCm = 1.0;    // applied to the file's lengths
    std::string units;         // how unitsToCm was decided ("FBX UnitScaleFactor 2.54", "glTF metres")
    std::string upAxis = "Y";  // the file's up axis ("Y", "-Z", ...) before conversion
    std::string take;          // the take's name ("" when unnamed)
    int takeIndex = 0;         // 0-based
    int takeCount = 1;
    double framesPerSecond = 0.0;  // the sampling rate (0 for a file that does not say)

    // "FBX, units x1 to cm (FBX UnitScaleFactor 1), up axis Y, take 0 'Run' of 3, 30 fps". A map's scale
    // (`mapScale`, read from `mapFile`) is part of the factor said, and named: "BVH, units x5.644 to cm (BVH has no
    // unit: taken as is; x5.644 by the map rigs/maps/cmu_to_biped.yaml), ...".
    std::string describe(double mapScale = 1.0, const std::string& mapFile = "") const;
};

struct SkeletalClip {
    BvhClip clip;
    ClipSource source;
};

// Beyond these a take is refused (a damaged file, or one that is no skeleton).
inline constexpr long long assimpMaxFrames = 1000000;
inline constexpr long long assimpMaxJointFrames = 4000000;  // joints x frames: ~0.5 GB of target matrices

// Reads a take with assimp, whatever the file is. `take`: a take's name, or its 0-based index, or "" for the
// first. A file larger than bvhMaxFileBytes, one assimp cannot read, one without an animation or a skeleton,
// a bad take (the message lists the takes), non-finite keys or transforms, duplicate joint names, a hierarchy
// deeper than bvhMaxDepth or over the limits above are refused.
SkeletalClip readAssimpClip(const std::filesystem::path& file, const std::string& take);
// The same from bytes in memory (the fuzzer); `hint` is the file's extension without the dot, used only
// where the bytes do not say their format.
SkeletalClip parseAssimpClip(std::string_view bytes, const std::string& hint, const std::string& fileName,
                             const std::string& take);

// What reads a clip file, from its content first: BVH text ("HIERARCHY" after a BOM and blank space), a JSON
// clip ('[', or '{' without glTF's "asset"); then, for content that says neither, its extension (.bvh, .json: their
// readers say what is wrong); anything else assimp.
enum class ClipReader { bvh, json, assimp };
ClipReader clipReaderFor(std::string_view text, const std::filesystem::path& file);
// The file kind for readInputFile's messages: a BVH file, a JSON clip or an animation file, by extension.
InputFileKind clipFileKind(const std::filesystem::path& file);
// A BVH file's text as a skeletal clip (the BVH reader's, its one take 0).
SkeletalClip parseBvhSkeletalClip(std::string_view text, const std::string& fileName, const std::string& take);
// Any skeletal clip, by clipReaderFor: BVH through the project's BVH reader (the reference, docs/bvh.md), the
// others through assimp; a JSON clip (world matrices, no skeleton) is refused. A BVH file has one take, 0.
SkeletalClip readSkeletalClip(const std::filesystem::path& file, const std::string& take);

// A file a folder of clips holds (rig-batch --clips FOLDER): .bvh, .json, or an extension assimp reads.
bool isClipFile(const std::filesystem::path& file);

}  // namespace rig

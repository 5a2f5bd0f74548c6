#pragma once
// Maya's .anim files, the format of its animImportExport plugin (docs/keys-anim-report.md): a header
// (animVersion, mayaVersion, timeUnit, linearUnit, angularUnit, startTime, endTime), then per animated
// plug an `anim` line naming it and an `animData { ... keys { ... } }` block with Maya's tangent names.
//
//   animVersion 1.1;
//   mayaVersion 2024;
//   timeUnit film;
//   linearUnit cm;
//   angularUnit deg;
//   startTime 1;
//   endTime 240;
//   anim rotate.rotateX rotateX L_arm_fk_ctrl 0 0 0;
//   animData {
//     input time;
//     output angular;
//     weighted 0;
//     preInfinity constant;
//     postInfinity constant;
//     keys {
//       1 12.5 auto auto 1 1 0;
//       17 40 auto auto 1 1 0;
//     }
//   }
//
// Keys go through AnimCurve (nodes/anim_curve_math.h), so the tangent names mean what they mean for
// animCurve nodes. Not read: `fixed` tangents (explicit angles and weights) and weighted curves, which
// AnimCurve does not model, and clock time units (hour, min, sec, millisec): key times are frames.
// Every error is a rig::Error "file:line:col: what; what to do".

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "nodes/anim_curve_math.h"

namespace rig {

// What a curve's input or output is (animData's `input` and `output`).
enum class AnimQuantity { time, linear, angular, unitless };
std::string_view animQuantityName(AnimQuantity quantity);

struct AnimFileCurve {
    std::string node;       // the node it drives
    std::string attribute;  // the attribute's path as Maya writes it: "rotate.rotateX", "fist"
    std::string leaf;       // the attribute itself: "rotateX", "fist"
    AnimQuantity input = AnimQuantity::time;
    AnimQuantity output = AnimQuantity::unitless;
    // Keys: x in frames (a time input) or in cm / degrees; y in cm, degrees or unitless.
    std::vector<AnimKey> keys;
    Infinity pre = Infinity::constant;
    Infinity post = Infinity::constant;
    SourceMark mark;  // its anim line

    // "node.leaf", the plug as rig files and graph-eval name it.
    std::string plugName() const { return node + "." + leaf; }
    // The animCurve node type that plays it: animCurveT or U, then L, A or U.
    std::string nodeTypeName() const;
};

struct AnimFile {
    std::string file;                 // for messages
    std::string timeUnit = "film";    // Maya's name of the frame rate the key times count
    std::optional<double> startTime;  // the header's range, when it gives one
    std::optional<double> endTime;
    std::vector<AnimFileCurve> curves;

    // The curve of `plug` ("node.leaf"), or null.
    const AnimFileCurve* find(std::string_view plug) const;
};

// Past this a file is refused before it is read.
inline constexpr std::uintmax_t animMaxFileBytes = std::uintmax_t{256} << 20;

// Called on each curve as soon as it is read (its keys in cm and degrees), to refuse it by throwing before the
// rest of the file is read: a caller that applies the curves reports the first wrong one at once.
using AnimCurveCheck = std::function<void(const AnimFileCurve&)>;

// Throws rig::Error naming `fileName`, the line and the column, at the first error: keys that are not finite
// numbers, that overflow in cm or degrees, or whose curve overflows (anim_curve_math.h: AnimCurve::tryBuild),
// a second curve for one plug; or the error `check` throws. Linear in the file's size.
AnimFile parseAnimFile(std::string_view text, const std::string& fileName, const AnimCurveCheck& check = {});
AnimFile readAnimFile(const std::filesystem::path& file, const AnimCurveCheck& check = {});

// The text of `file`, lengths in cm and angles in degrees, numbers that read back to the same bits.
std::string formatAnimFile(const AnimFile& file);

// Maya's name of a frame rate within 0.1% (24: film, 30: ntsc, 120: 120fps, ...), or none.
std::optional<std::string> mayaTimeUnit(double framesPerSecond);

}  // namespace rig

// The BVH reader (nodes/clips/bvh.h) on small files written here: every rotation channel order,
// End Sites, six-channel joints in both position conventions, colon and spaced names, line ends and
// tabs, a wrong "Frames:" count, every malformed case with its exact message; the independent forward
// kinematics against hand-computed positions; and the bvhClip node (outputs, units, time mapping,
// caching, errors, checked mode). Expected matrices are written out from cos/sin here.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>

#include "allocation_counter.h"
#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;

namespace {

constexpr double pi = std::numbers::pi;

Eigen::Matrix4d rx(double degrees)
{
    const double c = std::cos(degrees * pi / 180), s = std::sin(degrees * pi / 180);
    Eigen::Matrix4d m;
    m << 1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d ry(double degrees)
{
    const double c = std::cos(degrees * pi / 180), s = std::sin(degrees * pi / 180);
    Eigen::Matrix4d m;
    m << c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d rz(double degrees)
{
    const double c = std::cos(degrees * pi / 180), s = std::sin(degrees * pi / 180);
    Eigen::Matrix4d m;
    m << c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d translation(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.col(3) << x, y, z, 1;
    return m;
}

double maxDiff(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) { return (a - b).cwiseAbs().maxCoeff(); }

// Two joints, an End Site, two frames. Line numbers matter to the error tests:
//  1 HIERARCHY, 2 ROOT, 6 JOINT Chest, 10 End Site, 16 MOTION, 17 Frames, 18 Frame Time, 19-20 data.
const std::string base = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Chest
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 0 0 0 0 0 0 0 0
1 2 3 10 20 30 40 50 60
)";

std::string replaced(std::string text, const std::string& from, const std::string& to)
{
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    return text.replace(at, from.size(), to);
}

// The first `n` lines of `text`.
std::string firstLines(const std::string& text, int n)
{
    std::size_t at = 0;
    for (int i = 0; i < n; ++i) at = text.find('\n', at) + 1;
    return text.substr(0, at);
}

std::string errorOf(const std::string& text)
{
    try {
        parseBvh(text, "t.bvh");
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

std::string rootClip(const std::string& channels, const std::string& values)
{
    return fmt::format(
        "HIERARCHY\nROOT R\n{{\n OFFSET 1 2 3\n CHANNELS {}\n End Site\n {{\n  OFFSET 0 0 1\n }}\n}}\n"
        "MOTION\nFrames: 1\nFrame Time: 0.1\n{}\n",
        channels, values);
}

}  // namespace

TEST_CASE("bvh reader: joints, offsets, channels, End Sites, frames")
{
    const BvhClip clip = parseBvh(base, "t.bvh");
    CHECK(clip.file == "t.bvh");
    REQUIRE(clip.joints.size() == 2);
    CHECK(clip.joints[0].name == "Hips");
    CHECK(clip.joints[0].parent == -1);
    CHECK(clip.joints[0].line == 2);
    CHECK(clip.joints[1].name == "Chest");
    CHECK(clip.joints[1].parent == 0);
    CHECK(clip.joints[1].depth == 1);
    CHECK(clip.joints[1].offset == Eigen::Vector3d(0, 10, 0));
    CHECK_FALSE(clip.joints[0].endSite.has_value());
    REQUIRE(clip.joints[1].endSite.has_value());
    CHECK(*clip.joints[1].endSite == Eigen::Vector3d(0, 5, 0));
    CHECK(clip.joints[0].channels == std::vector<BvhChannel>{BvhChannel::Xposition, BvhChannel::Yposition,
                                                             BvhChannel::Zposition, BvhChannel::Zrotation,
                                                             BvhChannel::Xrotation, BvhChannel::Yrotation});
    CHECK(clip.joints[1].firstChannel == 6);
    CHECK(clip.channelCount == 9);
    CHECK(clip.frameCount == 2);
    CHECK(clip.frameTime == 0.04);
    CHECK(clip.warnings.empty());
    const auto second = clip.frame(1);
    CHECK(std::vector<double>(second.begin(), second.end()) == std::vector<double>{1, 2, 3, 10, 20, 30, 40, 50, 60});
    CHECK(bvhChannelName(BvhChannel::Yrotation) == "Yrotation");
}

TEST_CASE("bvh reader: every rotation channel order, partial and repeated axes, matches the file-order product")
{
    struct Case {
        const char* channels;
        std::vector<char> axes;
    };
    const std::vector<Case> cases{
        {"3 Xrotation Yrotation Zrotation", {'x', 'y', 'z'}},
        {"3 Xrotation Zrotation Yrotation", {'x', 'z', 'y'}},
        {"3 Yrotation Xrotation Zrotation", {'y', 'x', 'z'}},
        {"3 Yrotation Zrotation Xrotation", {'y', 'z', 'x'}},
        {"3 Zrotation Xrotation Yrotation", {'z', 'x', 'y'}},
        {"3 Zrotation Yrotation Xrotation", {'z', 'y', 'x'}},
        {"2 Zrotation Xrotation", {'z', 'x'}},
        {"1 Yrotation", {'y'}},
        {"3 Zrotation Xrotation Zrotation", {'z', 'x', 'z'}},
        {"4 Xrotation Xrotation Yrotation Xrotation", {'x', 'x', 'y', 'x'}},
        {"0", {}},
    };
    const std::vector<double> angles{23, -71, 142, 9};
    for (const Case& c : cases) {
        CAPTURE(c.channels);
        std::string values;
        Eigen::Matrix4d expected = translation(1, 2, 3);
        for (std::size_t k = 0; k < c.axes.size(); ++k) {
            values += fmt::format("{} ", angles[k]);
            expected = expected * (c.axes[k] == 'x' ? rx(angles[k]) : c.axes[k] == 'y' ? ry(angles[k]) : rz(angles[k]));
        }
        if (c.axes.empty()) {
            CHECK(errorOf(rootClip(c.channels, values)) ==
                  "t.bvh:11: the hierarchy has no channels (every CHANNELS count is 0); there is no motion to read");
            continue;
        }
        const BvhClip clip = parseBvh(rootClip(c.channels, values), "t.bvh");
        REQUIRE(clip.joints[0].channels.size() == c.axes.size());
        for (std::size_t k = 0; k < c.axes.size(); ++k) {
            CHECK(bvhIsRotation(clip.joints[0].channels[k]));
            CHECK(bvhChannelAxis(clip.joints[0].channels[k]) == c.axes[k] - 'x');
        }
        CHECK(maxDiff(bvhWorldMatrices(clip, 0)[0], expected) < 1e-14);
    }
}

TEST_CASE("bvh reader: the independent forward kinematics against hand-computed positions")
{
    // Root moved to (1, 2, 3) and turned 90 degrees about Z; the child, 10 cm along the root's X, turned
    // 90 degrees about X; its End Site 5 cm along the child's Y.
    const BvhClip clip = parseBvh(R"(HIERARCHY
ROOT A
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT B
  {
    OFFSET 10 0 0
    CHANNELS 3 Zrotation Yrotation Xrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.1
1 2 3 90 0 0 0 0 90
)",
                                  "t.bvh");
    const auto world = bvhWorldMatrices(clip, 0);
    // Root: at (1, 2, 3), its X axis along world Y.
    CHECK(maxDiff(world[0].col(3).head<3>(), Eigen::Vector3d(1, 2, 3)) < 1e-12);
    CHECK(maxDiff(world[0].col(0).head<3>(), Eigen::Vector3d(0, 1, 0)) < 1e-12);
    // Child: (1, 2, 3) + 10 along the root's X = (1, 12, 3).
    CHECK(maxDiff(world[1].col(3).head<3>(), Eigen::Vector3d(1, 12, 3)) < 1e-12);
    // The child's Y axis: Rz(90) * Rx(90) * (0, 1, 0) = Rz(90) * (0, 0, 1) = (0, 0, 1).
    CHECK(maxDiff(world[1].col(1).head<3>(), Eigen::Vector3d(0, 0, 1)) < 1e-12);
    // End Site: 5 along the child's Y from (1, 12, 3) = (1, 12, 8).
    const Eigen::Vector3d end = *clip.joints[1].endSite;
    const Eigen::Vector4d tip = world[1] * Eigen::Vector4d(end.x(), end.y(), end.z(), 1.0);
    CHECK(maxDiff(tip.head<3>(), Eigen::Vector3d(1, 12, 8)) < 1e-12);
}

TEST_CASE("bvh reader: six-channel joints, position channels as offsets or as the whole translation")
{
    // Chest has OFFSET (0, 10, 0). Added-to-OFFSET files hold small values; whole-translation files hold
    // values near OFFSET. Both describe Chest at (0.5, 10.5, 0) in frame 2.
    const std::string six = replaced(base, "CHANNELS 3 Zrotation Xrotation Yrotation",
                                     "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation");
    const std::string motion = "0 0 0 0 0 0 0 0 0\n1 2 3 10 20 30 40 50 60\n";
    const BvhClip added =
        parseBvh(replaced(six, motion, "0 0 0 0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 0.5 0.5 0 0 0 0\n"), "t.bvh");
    const BvhClip whole =
        parseBvh(replaced(six, motion, "0 0 0 0 0 0 0 10 0 0 0 0\n0 0 0 0 0 0 0.5 10.5 0 0 0 0\n"), "t.bvh");
    CHECK_FALSE(added.joints[1].positionReplacesOffset);
    CHECK(whole.joints[1].positionReplacesOffset);
    for (const BvhClip* clip : {&added, &whole}) {
        CHECK(bvhTranslation(*clip, 1, clip->frame(0)) == Eigen::Vector3d(0, 10, 0));
        CHECK(bvhTranslation(*clip, 1, clip->frame(1)) == Eigen::Vector3d(0.5, 10.5, 0));
        CHECK(bvhWorldMatrices(*clip, 1)[1].col(3).head<3>() == Eigen::Vector3d(0.5, 10.5, 0));
        // As rig parameters the position channels are the whole translation in both conventions.
        const auto rigValues = bvhRigChannels(*clip, clip->frame(1));
        CHECK(rigValues[6] == 0.5);
        CHECK(rigValues[7] == 10.5);
        CHECK(rigValues[8] == 0.0);
    }
    // The root is decided on its own: a root OFFSET of (0, 90, 0) with values near 90 is replaced...
    const std::string rooted = replaced(base, "  OFFSET 0 0 0\n", "  OFFSET 0 90 0\n");
    const BvhClip near = parseBvh(replaced(rooted, motion, "0 91 0 0 0 0 0 0 0\n1 92 3 0 0 0 0 0 0\n"), "t.bvh");
    CHECK(near.joints[0].positionReplacesOffset);
    CHECK(bvhTranslation(near, 0, near.frame(1)) == Eigen::Vector3d(1, 92, 3));
    // ... and values near zero are added to it.
    const BvhClip far = parseBvh(replaced(rooted, motion, "0 1 0 0 0 0 0 0 0\n1 2 3 0 0 0 0 0 0\n"), "t.bvh");
    CHECK_FALSE(far.joints[0].positionReplacesOffset);
    CHECK(bvhTranslation(far, 0, far.frame(1)) == Eigen::Vector3d(1, 92, 3));
    // A single position channel replaces or adds to its own axis only.
    const BvhClip one = parseBvh(replaced(replaced(base, "CHANNELS 3 Zrotation Xrotation Yrotation",
                                                   "CHANNELS 4 Yposition Zrotation Xrotation Yrotation"),
                                          motion, "0 0 0 0 0 0 0 0 0 0\n0 0 0 0 0 0 2 0 0 0\n"),
                                 "t.bvh");
    CHECK_FALSE(one.joints[1].positionReplacesOffset);
    CHECK(bvhTranslation(one, 1, one.frame(1)) == Eigen::Vector3d(0, 12, 0));
}

TEST_CASE("bvh reader: names with colons and spaces, CRLF, CR, tabs, a byte-order mark, blank lines")
{
    std::string text =
        replaced(replaced(base, "ROOT Hips", "ROOT mixamorig:Hips"), "JOINT Chest\n  {", "JOINT Left Hand {");
    const BvhClip lf = parseBvh(text, "t.bvh");
    CHECK(lf.joints[0].name == "mixamorig:Hips");
    CHECK(lf.joints[1].name == "Left Hand");

    std::string crlf;
    for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    std::string cr;
    for (char c : text) cr += c == '\n' ? '\r' : c;
    std::string tabs;
    for (char c : text) tabs += c == ' ' ? '\t' : c;
    const std::string blank =
        "\xEF\xBB\xBF\n" +
        replaced(replaced(text, "MOTION\n", "\nMOTION\n\n"), "0 0 0 0 0 0 0 0 0\n", "0 0 0 0 0 0 0 0 0\n   \n") +
        "\n\n";
    for (const std::string* variant : std::vector<const std::string*>{&crlf, &cr, &tabs, &blank}) {
        const BvhClip clip = parseBvh(*variant, "t.bvh");
        CHECK(clip.joints[0].name == "mixamorig:Hips");
        CHECK(clip.joints[1].name == "Left Hand");
        CHECK(clip.frameCount == 2);
        CHECK(clip.values == lf.values);
        CHECK(clip.warnings.empty());
    }
    // Line numbers count CRLF and CR line ends once.
    CHECK(errorOf(replaced(crlf, "Frame Time: 0.04", "Frame Time: 0")) ==
          "t.bvh:17: 'Frame Time: 0' must be a positive number of seconds per frame (e.g. 0.0333333 for 30 fps)");
    CHECK(errorOf(replaced(cr, "Frame Time: 0.04", "Frame Time: 0")) ==
          "t.bvh:17: 'Frame Time: 0' must be a positive number of seconds per frame (e.g. 0.0333333 for 30 fps)");
    // Header spellings: "Frames:3", "Frame Time :" and "Frame   Time:" read the same.
    const BvhClip spaced =
        parseBvh(replaced(replaced(base, "Frames: 2", "Frames:2"), "Frame Time: 0.04", "Frame\tTime :  .04"), "t.bvh");
    CHECK(spaced.frameTime == 0.04);
    CHECK(spaced.warnings.empty());
}

TEST_CASE("bvh reader: a Frames count that disagrees with the data is a warning, and the data wins")
{
    const BvhClip more = parseBvh(replaced(base, "Frames: 2", "Frames: 3"), "t.bvh");
    CHECK(more.frameCount == 2);
    CHECK(more.warnings ==
          std::vector<std::string>{"t.bvh:17: 'Frames: 3' but the file has 2 motion lines; using the 2 lines"});
    const BvhClip fewer = parseBvh(replaced(base, "Frames: 2", "Frames: 1"), "t.bvh");
    CHECK(fewer.frameCount == 2);
    CHECK(fewer.warnings ==
          std::vector<std::string>{"t.bvh:17: 'Frames: 1' but the file has 2 motion lines; using the 2 lines"});
}

TEST_CASE("bvh reader: every malformed file has its exact one-line message")
{
    const std::string joint = "  JOINT Chest\n";
    // Empty, not a BVH file, truncated header.
    CHECK(errorOf("") == "t.bvh:1: the file is empty; a BVH file starts with HIERARCHY");
    CHECK(errorOf(" \n\t\r\n") == "t.bvh:1: the file is empty; a BVH file starts with HIERARCHY");
    CHECK(errorOf(replaced(base, "HIERARCHY", "HIERARCHIE")) ==
          "t.bvh:1: expected HIERARCHY, found 'HIERARCHIE'; a BVH file starts with HIERARCHY");
    CHECK(errorOf("HIERARCHY\n") ==
          "t.bvh:1: the file ends after HIERARCHY; the skeleton (ROOT NAME {...}) is missing, the file is truncated");
    CHECK(errorOf("HIERARCHY\nJOINT A\n") ==
          "t.bvh:2: expected ROOT, found 'JOINT'; the hierarchy starts with ROOT NAME");
    CHECK(errorOf(firstLines(base, 9)) ==
          "t.bvh:9: the file ends inside joint 'Chest' (2 '{' still open); the file is truncated or a '}' is missing");
    CHECK(errorOf(firstLines(base, 11)) ==
          "t.bvh:11: the file ends inside joint 'Chest' (2 '{' still open); the file is truncated or a '}' is missing");
    CHECK(
        errorOf(firstLines(base, 15)) ==
        "t.bvh:15: the file ends after the hierarchy without a MOTION section; the file is truncated, export it again");
    // Missing MOTION.
    CHECK(errorOf(replaced(base, "MOTION", "MOTON")) ==
          "t.bvh:16: expected MOTION after the hierarchy, found 'MOTON'; add a MOTION line before 'Frames:'");
    CHECK(errorOf(replaced(base, "MOTION\n", "")) ==
          "t.bvh:16: expected MOTION after the hierarchy, found 'Frames:'; add a MOTION line before 'Frames:'");
    // Truncated motion header and data.
    CHECK(errorOf(firstLines(base, 16)) ==
          "t.bvh:16: the file ends after MOTION; 'Frames: N', 'Frame Time: SECONDS' and the motion data are missing, "
          "the file is truncated");
    CHECK(errorOf(firstLines(base, 17)) ==
          "t.bvh:17: the file ends before 'Frame Time: SECONDS' and the motion data; the file is truncated");
    CHECK(errorOf(firstLines(base, 18)) ==
          "t.bvh:18: no motion data after 'Frame Time' (the file announces 2 frames); the file is truncated");
    CHECK(errorOf(replaced(base, "MOTION", "MOTION Frames: 2")) ==
          "t.bvh:16: unexpected 'Frames:' after MOTION; 'Frames: N' goes on the next line");
    CHECK(errorOf(replaced(base, "Frames: 2\n", "")) ==
          "t.bvh:17: expected 'Frames: N', found 'Frame Time: 0.04'; the MOTION header is 'Frames: N' then 'Frame "
          "Time: SECONDS'");
    CHECK(errorOf(replaced(base, "Frame Time: 0.04\n", "")) ==
          "t.bvh:18: expected 'Frame Time: SECONDS', found '0 0 0 0 0 0 0 0 0'; the MOTION header is 'Frames: N' then "
          "'Frame Time: SECONDS'");
    CHECK(errorOf(replaced(base, "Frames: 2", "Frames: two")) ==
          "t.bvh:17: 'Frames: two' is not a frame count; write a whole number of frames");
    CHECK(errorOf(replaced(base, "Frames: 2", "Frames: -2")) ==
          "t.bvh:17: 'Frames: -2' is not a frame count; write a whole number of frames");
    CHECK(errorOf(replaced(base, "Frames: 2", "Framesx: 2")) ==
          "t.bvh:17: expected 'Frames: N', found 'Framesx: 2'; the MOTION header is 'Frames: N' then 'Frame Time: "
          "SECONDS'");
    // Frame time: zero, negative, not a number.
    for (const char* bad : {"0", "-0.04", "fast", "inf"})
        CHECK(errorOf(replaced(base, "Frame Time: 0.04", fmt::format("Frame Time: {}", bad))) ==
              fmt::format("t.bvh:18: 'Frame Time: {}' must be a positive number of seconds per frame (e.g. 0.0333333 "
                          "for 30 fps)",
                          bad));
    // Motion lines: too few values (a truncated last line), too many, not numbers.
    CHECK(errorOf(replaced(base, "1 2 3 10 20 30 40 50 60", "1 2 3 10 20 30 40")) ==
          "t.bvh:20: motion line 2 has 7 values but the hierarchy has 9 channels; the line is truncated or does not "
          "belong to this hierarchy");
    CHECK(errorOf(replaced(base, "1 2 3 10 20 30 40 50 60", "1 2 3 10 20 30 40 50 60 70")) ==
          "t.bvh:20: motion line 2 has 10 values but the hierarchy has 9 channels; the line is truncated or does not "
          "belong to this hierarchy");
    for (const char* bad : {"abc", "nan", "1.5.2", "1,5", "0x10", "--1"})
        CHECK(errorOf(replaced(base, "1 2 3 10 20", fmt::format("1 2 3 10 {}", bad))) ==
              fmt::format("t.bvh:20: value 5 of motion line 2 is '{}', not a number; motion lines hold only numbers",
                          bad));
    // Numbers as exporters write them.
    CHECK(errorOf(replaced(base, "1 2 3 10 20 30 40 50 60", "+1 -2 .5 -.5 1e2 1E-2 00 -0 7.")) == "(no error)");
    // Braces that do not match.
    CHECK(errorOf(replaced(base, "}\nMOTION", "}\n}\nMOTION")) ==
          "t.bvh:16: '}' closes nothing (the braces do not match); remove it or add the missing '{'");
    CHECK(errorOf(replaced(base, "    }\n  }\n}\n", "    }\n  }\n")) ==
          "t.bvh:15: MOTION inside joint 'Hips' (1 '{' still open); the braces do not match: a '}' is missing above");
    CHECK(errorOf(replaced(base, "  }\n}\n", "}\n")) ==
          "t.bvh:15: MOTION inside joint 'Hips' (1 '{' still open); the braces do not match: a '}' is missing above");
    CHECK(errorOf(replaced(base, joint + "  {\n", joint)) ==
          "t.bvh:7: expected '{' after JOINT Chest, found 'OFFSET'; open the joint's block with '{'");
    CHECK(errorOf(replaced(base, "  JOINT Chest", "  JOINT Chest\n  ROOT B")) ==
          "t.bvh:7: expected '{' after JOINT Chest, found 'ROOT'; open the joint's block with '{'");
    CHECK(errorOf(replaced(base, "    {\n      OFFSET 0 5 0", "    OFFSET 0 5 0")) ==
          "t.bvh:11: expected '{' after End Site of joint 'Chest', found 'OFFSET'; open the End Site with '{'");
    // Joint contents.
    CHECK(errorOf(replaced(base, "ROOT Hips", "ROOT")) == "t.bvh:2: ROOT without a name; write ROOT NAME");
    CHECK(errorOf(replaced(base, "JOINT Chest", "JOINT {")) == "t.bvh:6: JOINT without a name; write JOINT NAME");
    CHECK(errorOf(replaced(base, "    OFFSET 0 10 0\n", "")) ==
          "t.bvh:9: joint 'Chest' has no OFFSET before its children; add OFFSET X Y Z after its '{'");
    CHECK(errorOf(replaced(base,
                           "  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n "
                           " JOINT Chest\n  {\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    "
                           "End Site\n    {\n      OFFSET 0 5 0\n    }\n  }\n",
                           "")) == "t.bvh:4: joint 'Hips' has no OFFSET; add OFFSET X Y Z after its '{'");
    CHECK(errorOf(replaced(base, "OFFSET 0 10 0", "OFFSET 0 10")) ==
          "t.bvh:9: OFFSET of joint 'Chest' needs three numbers, found 'CHANNELS'; write OFFSET X Y Z");
    CHECK(errorOf(replaced(base, "OFFSET 0 10 0", "OFFSET 0 ten 0")) ==
          "t.bvh:8: OFFSET of joint 'Chest' needs three numbers, found 'ten'; write OFFSET X Y Z");
    CHECK(errorOf(replaced(base, "OFFSET 0 5 0", "OFFSET 0 5")) ==
          "t.bvh:13: OFFSET of the End Site of joint 'Chest' needs three numbers, found '}'; write OFFSET X Y Z");
    CHECK(errorOf(replaced(base, "OFFSET 0 10 0", "OFFSET 0 10 0\n    OFFSET 0 10 0")) ==
          "t.bvh:9: joint 'Chest' has a second OFFSET; give one OFFSET per joint");
    CHECK(errorOf(replaced(base, "CHANNELS 3 Zrotation Xrotation Yrotation",
                           "CHANNELS 3 Zrotation Xrotation Yrotation\n    CHANNELS 0")) ==
          "t.bvh:10: joint 'Chest' has a second CHANNELS line; list all its channels once");
    CHECK(errorOf(replaced(replaced(base, "    CHANNELS 3 Zrotation Xrotation Yrotation\n", ""), "  }\n}\n",
                           "    CHANNELS 3 Zrotation Xrotation Yrotation\n  }\n}\n")) ==
          "t.bvh:13: CHANNELS of joint 'Chest' comes after its children; write it before the first child");
    CHECK(errorOf(replaced(base, "  }\n}\n", "    OFFSET 1 2 3\n  }\n}\n")) ==
          "t.bvh:14: joint 'Chest' has a second OFFSET; give one OFFSET per joint");
    CHECK(errorOf(replaced(base, "Yrotation\n    End", "Wrotation\n    End")) ==
          "t.bvh:9: unknown channel 'Wrotation' in joint 'Chest'; channels are Xposition, Yposition, Zposition, "
          "Xrotation, Yrotation, Zrotation");
    CHECK(errorOf(replaced(base, "CHANNELS 3 Zrotation", "CHANNELS 4 Zrotation")) ==
          "t.bvh:10: CHANNELS 4 of joint 'Chest' lists only 3 channel names, then 'End'; list as many names as the "
          "count says");
    for (const char* bad : {"1000", "-1", "three"})
        CHECK(errorOf(replaced(base, "CHANNELS 3 Zrotation", fmt::format("CHANNELS {} Zrotation", bad))) ==
              fmt::format("t.bvh:9: CHANNELS of joint 'Chest' needs a count from 0 to 64, found '{}'; write CHANNELS N "
                          "followed by N channel names",
                          bad));
    CHECK(errorOf(
              replaced(base, "CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 3 Xposition Zrotation Xposition")) ==
          "t.bvh:9: joint 'Chest' lists Xposition twice; a position channel may appear once per joint");
    CHECK(errorOf(replaced(base, "    End Site", "    Scale 2\n    End Site")) ==
          "t.bvh:10: unexpected 'Scale' in joint 'Chest'; expected OFFSET, CHANNELS, JOINT, End Site or '}'");
    CHECK(errorOf(replaced(base, "    End Site", "    End Point")) ==
          "t.bvh:10: expected 'Site' after 'End' in joint 'Chest', found 'Point'; write End Site");
    CHECK(errorOf(replaced(base, "    }\n  }", "    }\n    End Site\n    {\n      OFFSET 0 1 0\n    }\n  }")) ==
          "t.bvh:14: joint 'Chest' has a second End Site; a joint ends in at most one");
    CHECK(errorOf(replaced(base, "      OFFSET 0 5 0\n", "")) ==
          "t.bvh:12: expected OFFSET in the End Site of joint 'Chest', found '}'; an End Site holds one OFFSET X Y Z");
    CHECK(errorOf(replaced(base, "      OFFSET 0 5 0\n", "      OFFSET 0 5 0\n      JOINT X\n")) ==
          "t.bvh:13: expected '}' closing the End Site of joint 'Chest', found 'JOINT'; an End Site holds only an "
          "OFFSET");
    CHECK(errorOf(replaced(
              replaced(base, "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation", "CHANNELS 0"),
              "CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 0")) ==
          "t.bvh:16: the hierarchy has no channels (every CHANNELS count is 0); there is no motion to read");
}

TEST_CASE("bvh reader: absurd joint counts and depths are refused")
{
    std::string wide = "HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\n";
    for (int i = 0; i < bvhMaxJoints; ++i) wide += fmt::format("JOINT j{} {{ OFFSET 0 0 0 }}\n", i);
    wide += "}\nMOTION\nFrames: 0\nFrame Time: 1\n";
    CHECK(errorOf(wide) == "t.bvh:10004: more than 10000 joints; this is not a skeleton (or the file is damaged)");

    std::string deep = "HIERARCHY\nROOT j0 { OFFSET 0 0 0\n";
    for (int i = 1; i <= bvhMaxDepth; ++i) deep += fmt::format("JOINT j{} {{ OFFSET 0 0 0\n", i);
    CHECK(errorOf(deep) ==
          "t.bvh:258: joints nested more than 256 levels deep; real skeletons stay far below that, check the braces");
    // Just inside the limits: fine.
    std::string ok = "HIERARCHY\nROOT j0 { OFFSET 0 0 0 CHANNELS 1 Xrotation\n";
    for (int i = 1; i < bvhMaxDepth; ++i) ok += fmt::format("JOINT j{} {{ OFFSET 0 0 0\n", i);
    for (int i = 0; i < bvhMaxDepth; ++i) ok += "}\n";
    ok += "MOTION\nFrames: 1\nFrame Time: 1\n5\n";
    CHECK(parseBvh(ok, "t.bvh").joints.size() == static_cast<std::size_t>(bvhMaxDepth));
}

TEST_CASE("bvh reader: files that cannot be read")
{
    const auto dir = test::scratchDir("bvh-reader-files");
    CHECK_THROWS_WITH_AS(readBvhFile(dir / "missing.bvh"),
                         fmt::format("{}: cannot open (No such file or directory); check the path (a relative path is "
                                     "read from the current folder)",
                                     (dir / "missing.bvh").string())
                             .c_str(),
                         Error);
    CHECK_THROWS_WITH_AS(
        readBvhFile(dir),
        fmt::format("{}: is a folder, not a BVH file; give the path of a .bvh file", dir.string()).c_str(), Error);
    test::writeFile(dir / "bad.bvh", firstLines(base, 9));
    CHECK_THROWS_WITH_AS(
        readBvhFile(dir / "bad.bvh"),
        fmt::format("{}:9: the file ends inside joint 'Chest' (2 '{{' still open); the file is truncated "
                    "or a '}}' is missing",
                    (dir / "bad.bvh").string())
            .c_str(),
        Error);
}

TEST_CASE("bvh sampling: frame 1 is the first line, ends clamp, fractions interpolate the shorter way round")
{
    const BvhClip clip = parseBvh(
        replaced(base, "1 2 3 10 20 30 40 50 60", "1 2 3 10 20 30 179 -170 360\n2 4 6 -179 -150 0 0 0 0"), "t.bvh");
    REQUIRE(clip.frameCount == 3);
    auto at = [&](double t) { return bvhSample(clip, t); };
    const auto line = [&](int i) {
        const auto f = clip.frame(i);
        return std::vector<double>(f.begin(), f.end());
    };
    CHECK(at(1) == line(0));
    CHECK(at(2) == line(1));
    CHECK(at(3) == line(2));
    CHECK(at(-5) == line(0));
    CHECK(at(0.5) == line(0));
    CHECK(at(3.5) == line(2));
    CHECK(at(1e9) == line(2));
    CHECK(at(std::nan("")) == line(0));
    const auto half = at(2.5);
    CHECK(half[0] == 1.5);  // positions: linear
    CHECK(half[2] == 4.5);
    CHECK(half[3] == doctest::Approx(95.5));  // 10 -> -179: the short way is +171 (through 180)
    CHECK(half[4] == doctest::Approx(-65));   // 20 -> -150: -170
    CHECK(half[6] == doctest::Approx(89.5));  // 179 -> 0: -179
    CHECK(half[7] == doctest::Approx(-85));   // -170 -> 0: +170
    CHECK(half[8] == doctest::Approx(360));   // 360 -> 0 is no turn at all
    const auto quarter = at(1.25);
    CHECK(quarter[6] == doctest::Approx(44.75));
    CHECK(quarter[7] == doctest::Approx(-42.5));
    // Exactly half a turn apart: the difference wraps to -180.
    const BvhClip turn = parseBvh(replaced(base, "1 2 3 10 20 30 40 50 60", "0 0 0 0 0 0 180 0 0"), "t.bvh");
    CHECK(bvhSample(turn, 1.5)[6] == doctest::Approx(-90));
}

TEST_CASE("bvhClip node: outputs, units, names, time, caching, errors and checked mode")
{
    const auto dir = test::scratchDir("bvh-clip-node");
    const std::string six = replaced(base, "CHANNELS 3 Zrotation Xrotation Yrotation",
                                     "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation");
    const auto first = test::writeFile(
        dir / "a.bvh",
        replaced(six, "0 0 0 0 0 0 0 0 0\n1 2 3 10 20 30 40 50 60\n",
                 "0 0 0 0 0 0 0 0 0 0 0 0\n1 2 3 10 20 30 0.5 0.5 0 40 50 60\n2 4 6 20 40 60 1 1 0 80 100 120\n"));
    const auto second = test::writeFile(dir / "b.bvh", replaced(base, "ROOT Hips", "ROOT mixamorig:Hips"));
    auto graph = loadGraphText(fmt::format(R"(
nodes:
  - {{name: clip, type: bvhClip, file: '{}'}}
  - {{name: j, type: joint}}
connections:
  - clip.channel[3] -> j.rotateZ
  - clip.channel[7] -> j.translateY
)",
                                           first.string()),
                               "t.yaml", makeBuiltinRegistry());
    auto get = [&](const std::string& plug) { return graph->getValue(graph->plug(plug)); };
    graph->setTime(2);
    CHECK(std::get<int>(get("clip.frameCount")) == 3);
    CHECK(std::get<double>(get("clip.frameTime")) == 0.04);
    CHECK(std::get<std::string>(get("clip.jointNames")) == "Hips\nChest");
    CHECK(std::get<std::string>(get("clip.channelNames")) ==
          "Hips.Xposition\nHips.Yposition\nHips.Zposition\nHips.Zrotation\nHips.Xrotation\nHips.Yrotation\n"
          "Chest.Xposition\nChest.Yposition\nChest.Zposition\nChest.Zrotation\nChest.Xrotation\nChest.Yrotation");
    // Rotations in degrees as plain numbers; Chest's positions are added to OFFSET (0, 10, 0), and come
    // out as the whole translation.
    CHECK(std::get<double>(get("clip.channel[3]")) == 10);
    CHECK(std::get<double>(get("clip.channel[6]")) == 0.5);
    CHECK(std::get<double>(get("clip.channel[7]")) == 10.5);
    CHECK(std::get<double>(get("clip.channel[11]")) == 60);
    CHECK(graph->elementIndices(graph->node("clip"), graph->plug("clip.channel[0]").attr).size() == 12);
    // Connected to an angle, degrees become radians.
    CHECK(std::get<double>(get("j.rotateZ")) == doctest::Approx(10 * pi / 180).epsilon(1e-15));
    CHECK(std::get<double>(get("j.translateY")) == 10.5);
    // worldMatrix[j] is the kinematics of the line.
    const BvhClip clip = readBvhFile(first);
    const auto expected = bvhWorldMatrices(clip, 1);
    CHECK(std::get<Eigen::Matrix4d>(get("clip.worldMatrix[0]")) == expected[0]);
    CHECK(std::get<Eigen::Matrix4d>(get("clip.worldMatrix[1]")) == expected[1]);
    CHECK(maxDiff(expected[0], translation(1, 2, 3) * rz(10) * rx(20) * ry(30)) < 1e-12);
    // Time: the scene time, clamped, interpolated.
    graph->setTime(-4);
    CHECK(std::get<double>(get("clip.channel[3]")) == 0);
    graph->setTime(99);
    CHECK(std::get<double>(get("clip.channel[3]")) == 20);
    graph->setTime(2.5);
    CHECK(std::get<double>(get("clip.channel[3]")) == 15);
    CHECK(std::get<double>(get("clip.channel[7]")) == 10.75);
    CHECK(maxDiff(std::get<Eigen::Matrix4d>(get("clip.worldMatrix[1]")),
                  bvhWorldMatrices(clip, bvhSample(clip, 2.5))[1]) == 0);
    CHECK(graph->checkEvaluation().empty());

    // The parsed file is cached: changing the file on disk changes nothing until `file` changes.
    test::writeFile(first, base);
    graph->setTime(3);
    CHECK(std::get<int>(get("clip.frameCount")) == 3);
    CHECK(std::get<double>(get("clip.channel[3]")) == 20);
    CHECK(graph->checkEvaluation().empty());
    graph->setValue(graph->plug("clip.file"), second.string());
    CHECK(std::get<int>(get("clip.frameCount")) == 2);
    CHECK(std::get<std::string>(get("clip.jointNames")) == "mixamorig:Hips\nChest");
    CHECK(graph->elementIndices(graph->node("clip"), graph->plug("clip.channel[0]").attr).size() == 9);
    CHECK(std::get<double>(get("clip.channel[3]")) == 10);
    CHECK(graph->checkEvaluation().empty());
    graph->setTime(1.5);
    CHECK(graph->checkEvaluation().empty());
    CHECK(std::get<double>(get("clip.channel[3]")) == 5);

    // A missing or malformed file: the reader's error, from compute; the next good file works again.
    graph->setValue(graph->plug("clip.file"), (dir / "none.bvh").string());
    CHECK_THROWS_WITH_AS(get("clip.channel[3]"),
                         fmt::format("{}: cannot open (No such file or directory); check the path (a relative path is "
                                     "read from the current folder)",
                                     (dir / "none.bvh").string())
                             .c_str(),
                         Error);
    const auto bad = test::writeFile(dir / "bad.bvh", replaced(base, "Frame Time: 0.04", "Frame Time: 0"));
    graph->setValue(graph->plug("clip.file"), bad.string());
    CHECK_THROWS_WITH_AS(get("clip.frameCount"),
                         fmt::format("{}:18: 'Frame Time: 0' must be a positive number of seconds per frame (e.g. "
                                     "0.0333333 for 30 fps)",
                                     bad.string())
                             .c_str(),
                         Error);
    graph->setValue(graph->plug("clip.file"), second.string());
    CHECK(std::get<int>(get("clip.frameCount")) == 2);
    CHECK(graph->checkEvaluation().empty());

    // No file: no joints, no channels, no error.
    graph->setValue(graph->plug("clip.file"), std::string());
    CHECK(std::get<int>(get("clip.frameCount")) == 0);
    CHECK(std::get<std::string>(get("clip.jointNames")).empty());
    CHECK(graph->elementIndices(graph->node("clip"), graph->plug("clip.channel[0]").attr).empty());
    CHECK(std::get<double>(get("j.rotateZ")) == 0);
    CHECK(graph->checkEvaluation().empty());
}

TEST_CASE("bvhClip node: a relative path is read from the current folder")
{
    const auto dir = test::scratchDir("bvh-clip-relative");
    test::writeFile(dir / "r.bvh", base);
    const auto before = std::filesystem::current_path();
    std::filesystem::current_path(dir);
    int frames = -1;
    try {
        auto graph =
            loadGraphText("nodes:\n  - {name: clip, type: bvhClip, file: r.bvh}\n", "t.yaml", makeBuiltinRegistry());
        frames = std::get<int>(graph->getValue(graph->plug("clip.frameCount")));
    }
    catch (...) {
        std::filesystem::current_path(before);
        throw;
    }
    std::filesystem::current_path(before);
    CHECK(frames == 2);
}

TEST_CASE("bvhClip nodes that play one file share its parsed frames: a crowd holds the clip once")
{
    // 4,000 frames of three joints (12 channels): about 400 KB parsed, which eight nodes would each have held.
    std::string text =
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation "
        "Xrotation Yrotation\n  JOINT Chest\n  {\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation "
        "Yrotation\n    JOINT Neck\n    {\n      OFFSET 0 5 0\n      CHANNELS 3 Zrotation Xrotation "
        "Yrotation\n      End Site\n      {\n        OFFSET 0 5 0\n      }\n    }\n  }\n}\nMOTION\n"
        "Frames: 4000\nFrame Time: 0.04\n";
    for (int f = 0; f < 4000; ++f)
        text += fmt::format("{} 0 {} {} {} 0 {} 1 2 {} 3 4\n", f % 7, f % 11, f % 13, f % 17, f % 19, f % 23);
    const auto file = test::writeFile(test::scratchDir("bvh-shared") / "long.bvh", text);
    const auto heldBy = [&](int nodes) {
        std::string rig = "nodes:\n";
        for (int i = 0; i < nodes; ++i)
            rig += fmt::format("  - {{name: c{}, type: bvhClip, file: '{}'}}\n", i, file.string());
        test::startCountingAllocations();
        auto graph = loadGraphText(rig, "crowd.yaml", makeBuiltinRegistry());
        graph->setTime(2);
        graph->evaluateAll();
        test::stopCountingAllocations();
        const std::size_t peak = test::peakHeapBytes();
        // Every member plays the same frame of the same file.
        for (int i = 1; i < nodes; ++i)
            CHECK(graph->getValue(graph->plug(fmt::format("c{}.worldMatrix[2]", i))) ==
                  graph->getValue(graph->plug("c0.worldMatrix[2]")));
        return peak;
    };
    const std::size_t one = heldBy(1);
    const std::size_t eight = heldBy(8);
    INFO("heap at most: one node ", one, " bytes, eight nodes ", eight, " bytes");
    CHECK(one > 384000);
    CHECK(eight < one + one / 2);
}

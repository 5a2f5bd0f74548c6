// bvh2rig end to end: the generated rig, evaluated by the graph, reproduces the independent forward
// kinematics of nodes/clips/bvh.h at every joint and End Site: on a synthetic clip with every rotation
// order, partial and repeated axes, position channels in both conventions and names to sanitize; on
// Debian's CMU clip (assimp-testmodels) and the odd files of ../shared/motion; once through graph-eval.
// Also the command line's errors.

#include <doctest/doctest.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>

#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

constexpr double positionTolerance = 1e-6;  // cm
constexpr double rotationTolerance = 1e-9;  // matrix entries

const fs::path cmuClip = "/usr/share/assimp/models/BVH/01_01.bvh";

fs::path sharedMotion() { return test::sourceDir() / ".." / "shared" / "motion"; }

test::CommandResult bvh2rig(const std::string& args)
{
    return test::run(fmt::format("{} {}", test::tool("bvh2rig"), args));
}

// Which rig node stands for BVH joint j, and for its End Site.
struct RigNames {
    std::vector<std::string> joint;
    std::vector<std::string> endSite;  // empty when the joint has none
};

// The names bvh2rig gives files whose names already follow the rig-file rules.
RigNames plainNames(const BvhClip& clip)
{
    RigNames names;
    for (const BvhJoint& j : clip.joints) {
        names.joint.push_back(j.name);
        names.endSite.push_back(j.endSite ? j.name + "_end" : "");
    }
    return names;
}

// The frames to compare: every frame, or for long clips `spread` frames spread over the clip with
// the first and the last.
std::vector<int> framesToCheck(int frameCount, int spread)
{
    std::vector<int> frames;
    if (frameCount <= spread) {
        for (int f = 1; f <= frameCount; ++f) frames.push_back(f);
        return frames;
    }
    for (int i = 0; i < spread; ++i)
        frames.push_back(1 + static_cast<int>(std::lround(static_cast<double>(i) * (frameCount - 1) / (spread - 1))));
    return frames;
}

struct Errors {
    int frames = 0;
    int matrices = 0;
    double position = 0.0;
    double rotation = 0.0;
};

void accumulate(Errors& e, const Eigen::Matrix4d& rig, const Eigen::Matrix4d& reference)
{
    e.position = std::max(e.position, (rig.col(3).head<3>() - reference.col(3).head<3>()).cwiseAbs().maxCoeff());
    e.rotation =
        std::max(e.rotation, (rig.topLeftCorner<3, 3>() - reference.topLeftCorner<3, 3>()).cwiseAbs().maxCoeff());
    ++e.matrices;
}

Eigen::Matrix4d endSiteMatrix(const Eigen::Matrix4d& jointWorld, const Eigen::Vector3d& offset)
{
    Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
    t.col(3).head<3>() = offset;
    return jointWorld * t;
}

// Evaluates the rig at each frame and compares every joint's and End Site's world matrix with the
// reference kinematics of the clip.
Errors compareRig(Graph& graph, const BvhClip& clip, const RigNames& names, const std::vector<int>& frames)
{
    std::vector<Plug> plugs;
    for (std::size_t j = 0; j < clip.joints.size(); ++j) {
        plugs.push_back(graph.plug(names.joint[j] + ".worldMatrix"));
        if (clip.joints[j].endSite) plugs.push_back(graph.plug(names.endSite[j] + ".worldMatrix"));
    }
    Errors e;
    for (int frame : frames) {
        graph.setTime(frame);
        graph.evaluate(plugs);
        const auto reference = bvhWorldMatrices(clip, frame - 1);
        std::size_t p = 0;
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            accumulate(e, std::get<Eigen::Matrix4d>(graph.getValue(plugs[p++])), reference[j]);
            if (clip.joints[j].endSite)
                accumulate(e, std::get<Eigen::Matrix4d>(graph.getValue(plugs[p++])),
                           endSiteMatrix(reference[j], *clip.joints[j].endSite));
        }
        ++e.frames;
    }
    return e;
}

// bvh2rig --with-motion, then the graph against the reference kinematics.
Errors roundTrip(const fs::path& bvh, const std::string& tag, int spread)
{
    const auto dir = test::scratchDir("bvh2rig-" + tag);
    const auto rig = dir / "rig.yaml";
    const auto r = bvh2rig(fmt::format("'{}' -o '{}' --with-motion", bvh.string(), rig.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    const BvhClip clip = readBvhFile(bvh);
    auto graph = loadGraphFile(rig, makeBuiltinRegistry());
    return compareRig(*graph, clip, plainNames(clip), framesToCheck(clip.frameCount, spread));
}

// A synthetic clip: every rotation order, two and one rotations, repeated axes, no channels, position
// channels on a non-root joint (near zero: added to OFFSET; near OFFSET: the whole translation), and
// names to sanitize or that collide with generated names.
std::string syntheticClip(bool wholeTranslation)
{
    std::string text = R"(HIERARCHY
ROOT Hips
{
	OFFSET 1 90 -2
	CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
	JOINT a-b
	{
		OFFSET 0 10 0
		CHANNELS 3 Xrotation Yrotation Zrotation
		JOINT a_b
		{
			OFFSET 0 10 1
			CHANNELS 3 Xrotation Zrotation Yrotation
			JOINT Left Hand
			{
				OFFSET 2 8 0
				CHANNELS 3 Yrotation Xrotation Zrotation
				JOINT 3rd
				{
					OFFSET 0 7 0
					CHANNELS 3 Yrotation Zrotation Xrotation
					JOINT mixamorig:Neck
					{
						OFFSET 0 6 0
						CHANNELS 3 Zrotation Yrotation Xrotation
						End Site
						{
							OFFSET 0 4 0
						}
					}
				}
			}
		}
	}
	JOINT clip
	{
		OFFSET -5 0 0
		CHANNELS 2 Zrotation Xrotation
		JOINT Twist
		{
			OFFSET 0 -20 0
			CHANNELS 3 Zrotation Xrotation Zrotation
			JOINT Quad
			{
				OFFSET 0 -20 0
				CHANNELS 4 Xrotation Xrotation Yrotation Xrotation
				JOINT Slide
				{
					OFFSET 0 -5 3
					CHANNELS 4 Yposition Yrotation Xposition Zposition
					JOINT Fixed
					{
						OFFSET 1 1 1
						CHANNELS 0
						End Site
						{
							OFFSET 0 0 2
						}
					}
				}
			}
		}
	}
	JOINT Fixed_end
	{
		OFFSET 0 0 -3
		CHANNELS 1 Yrotation
		End Site
		{
			OFFSET 0 0 -1
		}
	}
}
MOTION
Frames: 7
Frame Time: 0.0333333
)";
    // 35 channels; Slide's positions are channels 30, 32, 33 (Y, X, Z).
    for (int f = 0; f < 7; ++f) {
        for (int k = 0; k < 35; ++k) {
            double v = std::fmod(37.3 * k + 101.7 * f * f + 13.1, 340.0) - 170.0;
            if (k < 3) v = 0.1 * v;
            if (k == 30 || k == 32 || k == 33) v = 0.01 * v + (wholeTranslation ? (k == 30 ? -5 : k == 32 ? 0 : 3) : 0);
            text += fmt::format("{}{}", k ? " " : "", v);
        }
        text += "\r\n";
    }
    return text;
}

RigNames syntheticNames()
{
    return {{"Hips", "a_b", "a_b_2", "Left_Hand", "_3rd", "mixamorig:Neck", "clip", "Twist", "Quad", "Slide", "Fixed",
             "Fixed_end"},
            {"", "", "", "", "", "mixamorig:Neck_end", "", "", "", "", "Fixed_end_2", "Fixed_end_end"}};
}

}  // namespace

TEST_CASE("bvh2rig: every channel order, repeated axes, position channels and odd names are exact")
{
    for (bool whole : {false, true}) {
        CAPTURE(whole);
        const auto dir = test::scratchDir(fmt::format("bvh2rig-synthetic-{}", whole));
        const auto bvh = test::writeFile(dir / "synthetic.bvh", syntheticClip(whole));
        const auto rig = dir / "rig.yaml";
        const auto r = bvh2rig(fmt::format("'{}' -o '{}' --with-motion", bvh.string(), rig.string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        CHECK(r.err.empty());
        CHECK(r.out == fmt::format("wrote {}: 18 joints (12 from BVH joints, 3 End Sites, 3 helpers), 35 parameters, "
                                   "driven by bvhClip 'clip_2'\n",
                                   rig.string()));
        const BvhClip clip = readBvhFile(bvh);
        CHECK(clip.joints[9].positionReplacesOffset == whole);
        const std::string text = test::readFile(rig);
        // The header lists renamed joints and every parameter.
        CHECK(text.find("#   'a-b' -> a_b\n#   'a_b' -> a_b_2\n#   'Left Hand' -> Left_Hand\n#   '3rd' -> _3rd\n") !=
              std::string::npos);
        CHECK(text.find("# Parameters (35)") != std::string::npos);
        CHECK(text.find("#   [0] Hips.Xposition -> Hips.translateX\n") != std::string::npos);
        CHECK(text.find("#   [25] Twist.Zrotation -> Twist.rotateZ\n") != std::string::npos);
        CHECK(text.find("#   [23] Twist.Zrotation -> Twist_rot1.rotateZ\n") != std::string::npos);
        CHECK(text.find("#   [30] Slide.Yposition -> Slide.translateY\n") != std::string::npos);
        CHECK(text.find(whole ? "other joints: the whole local translation (replacing OFFSET)"
                              : "other joints: offsets added to OFFSET") != std::string::npos);
        // Rotate orders: the last channel is applied first; missing axes come last and stay at zero.
        for (const char* line : {
                 R"(  - {name: "Hips", type: joint, translate: [1, 90, -2], rotateOrder: yxz})",
                 R"(  - {name: "a_b", type: joint, parent: "Hips", translate: [0, 10, 0], rotateOrder: zyx})",
                 R"(  - {name: "a_b_2", type: joint, parent: "a_b", translate: [0, 10, 1], rotateOrder: yzx})",
                 R"(  - {name: "Left_Hand", type: joint, parent: "a_b_2", translate: [2, 8, 0], rotateOrder: zxy})",
                 R"(  - {name: "_3rd", type: joint, parent: "Left_Hand", translate: [0, 7, 0], rotateOrder: xzy})",
                 R"(  - {name: "mixamorig:Neck", type: joint, parent: "_3rd", translate: [0, 6, 0], rotateOrder: xyz})",
                 R"(  - {name: "mixamorig:Neck_end", type: joint, parent: "mixamorig:Neck", translate: [0, 4, 0]})",
                 R"(  - {name: "clip", type: joint, parent: "Hips", translate: [-5, 0, 0], rotateOrder: xzy})",
                 R"(  - {name: "Twist_rot1", type: joint, parent: "clip", translate: [0, -20, 0], rotateOrder: xzy})",
                 R"(  - {name: "Twist", type: joint, parent: "Twist_rot1", rotateOrder: zxy})",
                 R"(  - {name: "Quad_rot1", type: joint, parent: "Twist", translate: [0, -20, 0], rotateOrder: xyz})",
                 R"(  - {name: "Quad_rot2", type: joint, parent: "Quad_rot1", rotateOrder: yxz})",
                 R"(  - {name: "Quad", type: joint, parent: "Quad_rot2", rotateOrder: xyz})",
                 R"(  - {name: "Slide", type: joint, parent: "Quad", translate: [0, -5, 3], rotateOrder: yxz})",
                 R"(  - {name: "Fixed", type: joint, parent: "Slide", translate: [1, 1, 1]})",
                 R"(  - {name: "Fixed_end_2", type: joint, parent: "Fixed", translate: [0, 0, 2]})",
                 R"(  - {name: "Fixed_end", type: joint, parent: "Hips", translate: [0, 0, -3], rotateOrder: yxz})",
                 R"(  - {name: "Fixed_end_end", type: joint, parent: "Fixed_end", translate: [0, 0, -1]})",
                 R"(  - "clip_2.channel[34] -> Fixed_end.rotateY")",
             })
            CHECK_MESSAGE(text.find(std::string(line) + "\n") != std::string::npos, line);
        CHECK(text.find(fmt::format("  - {{name: \"clip_2\", type: bvhClip, file: '{}'}}\n",
                                    fs::absolute(bvh).lexically_normal().string())) != std::string::npos);

        auto graph = loadGraphFile(rig, makeBuiltinRegistry());
        const Errors e = compareRig(*graph, clip, syntheticNames(), framesToCheck(clip.frameCount, 100));
        CHECK(e.frames == 7);
        CHECK(e.matrices == 7 * 15);
        CHECK(e.position < positionTolerance);
        CHECK(e.rotation < rotationTolerance);
        // The clip node's own outputs agree with the reference too.
        graph->setTime(4);
        const auto reference = bvhWorldMatrices(clip, 3);
        for (std::size_t j = 0; j < clip.joints.size(); ++j)
            CHECK(std::get<Eigen::Matrix4d>(graph->getValue(graph->plug(fmt::format("clip_2.worldMatrix[{}]", j)))) ==
                  reference[j]);
        CHECK(graph->checkEvaluation().empty());
    }
}

TEST_CASE("bvh2rig: without --with-motion the rig is the rest pose, and --prefix names every node")
{
    const auto dir = test::scratchDir("bvh2rig-rest");
    const auto bvh = test::writeFile(dir / "synthetic.bvh", syntheticClip(false));
    const auto r = bvh2rig(fmt::format("'{}' -o '{}' --prefix mocap:", bvh.string(), (dir / "rig.yaml").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    CHECK(r.out == fmt::format("wrote {}: 18 joints (12 from BVH joints, 3 End Sites, 3 helpers), 35 parameters\n",
                               (dir / "rig.yaml").string()));
    const std::string text = test::readFile(dir / "rig.yaml");
    CHECK(text.find("bvhClip") == std::string::npos);
    CHECK(text.find("connections:") == std::string::npos);
    CHECK(text.find("#   'Left Hand' -> mocap:Left_Hand\n") != std::string::npos);
    CHECK(text.find("'3rd'") == std::string::npos);  // mocap:3rd needs no change
    auto graph = loadGraphFile(dir / "rig.yaml", makeBuiltinRegistry());
    CHECK(graph->nodeCount() == 18);
    // Rest pose: OFFSETs only.
    const Eigen::Matrix4d neck =
        std::get<Eigen::Matrix4d>(graph->getValue(graph->plug("mocap:mixamorig:Neck.worldMatrix")));
    CHECK((neck.col(3).head<3>() - Eigen::Vector3d(3, 131, -1)).cwiseAbs().maxCoeff() < 1e-12);
    CHECK(graph->findNode("mocap:Fixed_end_2") >= 0);
}

TEST_CASE("bvh2rig: errors are one line and exit code 2")
{
    const auto dir = test::scratchDir("bvh2rig-errors");
    const auto good = test::writeFile(dir / "good.bvh", syntheticClip(false));
    auto r = bvh2rig(fmt::format("'{}' -o '{}'", (dir / "none.bvh").string(), (dir / "rig.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}: cannot open (No such file or directory); check the path (a relative path is "
                               "read from the current folder)\n",
                               (dir / "none.bvh").string()));
    const auto bad = test::writeFile(dir / "bad.bvh", "HIERARCHY\nROOT A\n{\n  OFFSET 0 0\n}\n");
    r = bvh2rig(fmt::format("'{}' -o '{}'", bad.string(), (dir / "rig.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == fmt::format("error: {}:5: OFFSET of joint 'A' needs three numbers, found '}}'; write OFFSET X Y Z\n",
                               bad.string()));
    CHECK_FALSE(fs::exists(dir / "rig.yaml"));
    r = bvh2rig(fmt::format("'{}'", good.string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == "error: --output is required; run 'bvh2rig --help' for usage\n");
    r = bvh2rig(fmt::format("'{}' -o '{}' --prefix my-rig", good.string(), (dir / "rig.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == "error: --prefix 'my-rig': use letters, digits, '_' and ':' (e.g. --prefix mocap:)\n");
    r = bvh2rig(fmt::format("'{}' -o '{}' --prefix 2", good.string(), (dir / "rig.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err == "error: --prefix '2': a node name cannot start with a digit\n");
    r = bvh2rig(fmt::format("'{}' -o '{}'", good.string(), (dir / "no" / "rig.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err.starts_with(fmt::format("error: {}: cannot write here", (dir / "no" / "rig.yaml").string())));
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
    // A wrong Frames count is a warning on standard error, and in the rig's header.
    const auto odd = test::writeFile(dir / "odd.bvh",
                                     "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 1 Zrotation\n}\n"
                                     "MOTION\nFrames: 3\nFrame Time: 0.1\n1\n2\n");
    r = bvh2rig(fmt::format("'{}' -o '{}'", odd.string(), (dir / "odd.yaml").string()));
    CHECK(r.exitCode == 0);
    CHECK(r.err ==
          fmt::format("warning: {}:8: 'Frames: 3' but the file has 2 motion lines; using the 2 lines\n", odd.string()));
    CHECK(test::readFile(dir / "odd.yaml").find("# Warning: ") != std::string::npos);
}

TEST_CASE("bvh2rig round trip: CMU clip 01_01 (assimp-testmodels), every frame")
{
    if (!fs::exists(cmuClip)) {
        MESSAGE("[skipped] " << cmuClip.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    const auto start = std::chrono::steady_clock::now();
    const Errors e = roundTrip(cmuClip, "cmu", 1 << 30);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    MESSAGE(
        fmt::format("01_01.bvh: {} frames, {} matrices, max position error {:.3g} cm, max rotation error {:.3g}, "
                    "{:.2f} s",
                    e.frames, e.matrices, e.position, e.rotation, seconds));
    CHECK(e.frames == 2752);
    CHECK(e.position < positionTolerance);
    CHECK(e.rotation < rotationTolerance);
}

TEST_CASE("bvh2rig round trip: the odd files of ../shared/motion, every frame")
{
    if (!fs::is_directory(sharedMotion())) {
        MESSAGE("[skipped] " << sharedMotion().string() << " is absent (a clone without ../shared)");
        return;
    }
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(sharedMotion()))
        if (entry.path().extension() == ".bvh") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    CHECK_FALSE(files.empty());
    for (const fs::path& file : files) {
        CAPTURE(file.string());
        const auto start = std::chrono::steady_clock::now();
        const Errors e = roundTrip(file, "shared-" + file.stem().string(), 1 << 30);
        const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        MESSAGE(
            fmt::format("{}: {} frames, {} matrices, max position error {:.3g} cm, max rotation error {:.3g}, "
                        "{:.2f} s",
                        file.filename().string(), e.frames, e.matrices, e.position, e.rotation, seconds));
        CHECK(e.frames == readBvhFile(file).frameCount);
        CHECK(e.position < positionTolerance);
        CHECK(e.rotation < rotationTolerance);
    }
}

TEST_CASE("bvh2rig round trip through graph-eval: CMU clip 01_01, every frame")
{
    if (!fs::exists(cmuClip)) {
        MESSAGE("[skipped] " << cmuClip.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    const auto dir = test::scratchDir("bvh2rig-graph-eval");
    auto r = bvh2rig(fmt::format("'{}' -o '{}' --with-motion", cmuClip.string(), (dir / "rig.yaml").string()));
    REQUIRE(r.exitCode == 0);
    const BvhClip clip = readBvhFile(cmuClip);
    r = test::run(fmt::format("{} '{}' --frames 1:{} --get '*.worldMatrix' --format csv -o '{}'",
                              test::tool("graph-eval"), (dir / "rig.yaml").string(), clip.frameCount,
                              (dir / "out.csv").string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);

    // Columns NODE.worldMatrix[row][col]; the clip's own worldMatrix[j][row][col] columns are skipped.
    const RigNames names = plainNames(clip);
    std::istringstream csv(test::readFile(dir / "out.csv"));
    std::string line;
    REQUIRE(std::getline(csv, line));
    struct Column {
        int joint = -1;
        bool endSite = false;
        int row = 0;
        int col = 0;
    };
    std::vector<Column> columns;
    std::size_t at = 0;
    int found = 0;
    while (at <= line.size()) {
        const std::size_t comma = std::min(line.find(',', at), line.size());
        const std::string name = line.substr(at, comma - at);
        at = comma + 1;
        Column c;
        const auto dot = name.find(".worldMatrix[");
        if (dot != std::string::npos && name.size() == dot + 18) {
            const std::string node = name.substr(0, dot);
            for (std::size_t j = 0; j < clip.joints.size(); ++j) {
                if (names.joint[j] == node) c.joint = static_cast<int>(j);
                if (names.endSite[j] == node) {
                    c.joint = static_cast<int>(j);
                    c.endSite = true;
                }
            }
            c.row = name[dot + 13] - '0';
            c.col = name[dot + 16] - '0';
            found += c.joint >= 0;
        }
        columns.push_back(c);
    }
    CHECK(found == 16 * 38);
    Errors e;
    while (std::getline(csv, line)) {
        std::vector<double> fields;
        for (std::size_t p = 0; p <= line.size();) {
            const std::size_t comma = std::min(line.find(',', p), line.size());
            double x = 0.0;
            std::from_chars(line.data() + p, line.data() + comma, x);
            fields.push_back(x);
            p = comma + 1;
        }
        REQUIRE(fields.size() == columns.size());
        const int frame = static_cast<int>(fields[0]);
        const auto reference = bvhWorldMatrices(clip, frame - 1);
        for (std::size_t k = 1; k < fields.size(); ++k) {
            const Column& c = columns[k];
            if (c.joint < 0) continue;
            const auto j = static_cast<std::size_t>(c.joint);
            const Eigen::Matrix4d m = c.endSite ? endSiteMatrix(reference[j], *clip.joints[j].endSite) : reference[j];
            const double error = std::abs(fields[k] - m(c.row, c.col));
            if (c.col == 3) e.position = std::max(e.position, error);
            else e.rotation = std::max(e.rotation, error);
        }
        ++e.frames;
    }
    CHECK(e.frames == clip.frameCount);
    CHECK(e.position < positionTolerance);
    CHECK(e.rotation < rotationTolerance);
}

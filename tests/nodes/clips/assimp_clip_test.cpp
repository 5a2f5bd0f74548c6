// Clips through assimp (nodes/clips/assimp_clip.h): units and axes from the file's metadata on hand-written
// Z-up legs (an FBX in inches, whose conversion is ours; a Collada file in cm, which assimp converts), takes by
// name and index, the file read by its content, the skeletonClip node, and assimp's BVH import against our BVH
// reader on the CMU clips (docs/clips.md). Tests needing Debian's assimp-testmodels skip without it.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

#include <sys/resource.h>

#include <fmt/format.h>
#include <Eigen/Core>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/assimp_clip.h"
#include "nodes/clips/clip_isolation.h"
#include "nodes/clips/target_clip.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

const fs::path models = "/usr/share/assimp/models";
const fs::path legInches = test::sourceDir() / "tests/corpus/clips/leg_z_up_inches.fbx";
const fs::path legCm = test::sourceDir() / "tests/corpus/clips/leg_z_up_cm.dae";

Eigen::Vector3d position(const TargetClip& clip, int frame, const std::string& joint)
{
    const auto it = std::find(clip.joints.begin(), clip.joints.end(), joint);
    REQUIRE(it != clip.joints.end());
    return clip.worlds[static_cast<std::size_t>(frame)][static_cast<std::size_t>(it - clip.joints.begin())].block<3, 1>(
        0, 3);
}

// The leg of both files: hip 40 units up the file's Z, knee 20 below it, ankle 16 below that, the knee bending
// about the file's Y by 0, 45 and 90 degrees. In Y up, Z's up is Y and the file's Y turns into -Z: the ankle
// swings towards -X in the X-Y plane.
void checkLeg(const TargetClip& clip, double unitToCm, double tolerance)
{
    REQUIRE(clip.joints == std::vector<std::string>{"hip", "knee", "ankle"});
    REQUIRE(clip.worlds.size() == 3);
    CHECK(clip.parents == std::vector<int>{-1, 0, 1});
    const double thigh = 20 * unitToCm, shin = 16 * unitToCm;
    for (int f = 0; f < 3; ++f) {
        CAPTURE(f);
        const double bend = f * std::numbers::pi / 4;
        CHECK((position(clip, f, "hip") - Eigen::Vector3d(0, 2 * thigh, 0)).norm() < tolerance);
        CHECK((position(clip, f, "knee") - Eigen::Vector3d(0, thigh, 0)).norm() < tolerance);
        const Eigen::Vector3d ankle(-shin * std::sin(bend), thigh - shin * std::cos(bend), 0);
        CHECK((position(clip, f, "ankle") - ankle).norm() < tolerance);
    }
    CHECK(clip.frameNumbers == std::vector<double>{1, 2, 3});
    CHECK(clip.frameTime == doctest::Approx(0.5).epsilon(1e-6));
}

std::string errorOf(const std::function<void()>& f)
{
    try {
        f();
    }
    catch (const Error& e) {
        return e.what();
    }
    return "(no error)";
}

}  // namespace

TEST_CASE("assimp clips: a Z-up FBX in inches comes out in cm and Y up, from the file's own settings")
{
    const SkeletalClip skeleton = readSkeletalClip(legInches, "");
    CHECK(skeleton.source.format == "FBX");
    CHECK(skeleton.source.unitsToCm == 2.54);
    CHECK(skeleton.source.describe() ==
          "FBX, units x2.54 to cm (FBX UnitScaleFactor 2.54), up axis Z, take 0 'bend' of 1, 2 fps");
    const TargetClip clip = readTargetClip(legInches, TargetMap{});
    CHECK(clip.source == skeleton.source.describe());
    // The file's keys are floats: 90 degrees is 89.99999 and some.
    checkLeg(clip, 2.54, 1e-4);
    // The map's scale still applies, after the file's own.
    TargetMap half;
    half.scale = 0.5;
    checkLeg(readTargetClip(legInches, half), 1.27, 1e-4);
}

TEST_CASE("assimp clips: a Z-up Collada file in cm, which assimp converts, reports its <unit> and <up_axis>")
{
    const TargetClip clip = readTargetClip(legCm, TargetMap{});
    CHECK(clip.source ==
          "Collada, units x100 to cm (Collada <unit meter=\"0.01\">, applied by assimp: metres), up axis Z, take 0 "
          "'animation' of 1, 2 fps");
    // assimp scales by the float 0.01 (0.0099999998): 2e-6 cm on a metre.
    checkLeg(clip, 2.5, 1e-5);
}

TEST_CASE("assimp clips: what a file is comes from its content, not its name")
{
    const auto dir = test::scratchDir("assimp_clip_content");
    // A BVH file under another name is BVH; a Collada file under a neutral one is assimp's.
    const std::string bvh =
        "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n"
        "    OFFSET 0 5 0\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n10 20 30\n";
    const auto misnamed = test::writeFile(dir / "walk.fbx", bvh);
    CHECK(clipReaderFor(bvh, misnamed) == ClipReader::bvh);
    const TargetClip fromBvh = readTargetClip(misnamed, TargetMap{});
    CHECK(fromBvh.joints == std::vector<std::string>{"Hips"});
    CHECK(fromBvh.source == "BVH, units x1 to cm (BVH has no unit: taken as is), up axis Y, take 0 of 1, 25 fps");
    fs::copy_file(legCm, dir / "leg.data");
    CHECK(readTargetClip(dir / "leg.data", TargetMap{}).source.starts_with("Collada, "));
    CHECK(clipReaderFor("[{\"frame\": 1}]", dir / "c.dae") == ClipReader::json);
    CHECK(clipReaderFor("{\"asset\": {\"version\": \"2.0\"}}", dir / "c.json") == ClipReader::assimp);
    CHECK(clipReaderFor("{\"frames\": 1}", dir / "c.gltf") == ClipReader::json);
    CHECK(clipReaderFor("garbage", dir / "c.bvh") == ClipReader::bvh);
    CHECK(clipReaderFor("garbage", dir / "c.fbx") == ClipReader::assimp);
    // A JSON clip has no skeleton to make a rig of, and one take.
    CHECK(errorOf([&] { readSkeletalClip(test::sourceDir() / "tests/corpus/clips/arm.json", ""); }) ==
          (test::sourceDir() / "tests/corpus/clips/arm.json").string() +
              ": a JSON clip of world matrices has no skeleton; give a BVH file or an animation assimp reads (FBX, "
              "glTF, Collada, X, ...)");
    CHECK(errorOf([&] { readTargetClip(misnamed, TargetMap{}, "1"); }) ==
          misnamed.string() + ": no take '1'; a BVH file has one take, 0; leave --take out");
    CHECK(readTargetClip(misnamed, TargetMap{}, "0").joints.size() == 1);
}

TEST_CASE("assimp clips: a glTF take whose keys are all at one time is one pose, not two frames a time apart")
{
    // The knee's one rotation key (45 degrees about Z) at 1 s; assimp gives the unanimated translations a key at 0 s.
    const auto gltf = [](std::string_view times, int count) {
        return fmt::format(
            R"({{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
"nodes": [{{"name": "hip", "children": [1], "translation": [0, 1, 0]}}, {{"name": "knee", "translation": [0, 0.5, 0]}}],
"buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}],
"bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {}}},
                {{"buffer": 0, "byteOffset": {}, "byteLength": {}}}],
"accessors": [{{"bufferView": 0, "componentType": 5126, "count": {}, "type": "SCALAR", "min": [1], "max": [1]}},
              {{"bufferView": 1, "componentType": 5126, "count": {}, "type": "VEC4"}}],
"animations": [{{"name": "pose", "channels": [{{"sampler": 0, "target": {{"node": 1, "path": "rotation"}}}}],
                "samplers": [{{"input": 0, "output": 1, "interpolation": "LINEAR"}}]}}]}})",
            20 * count, times, 4 * count, 4 * count, 16 * count, count, count);
    };
    const auto dir = test::scratchDir("assimp-one-time");
    // Base64 of the float times (1.0) then the quaternions (0, 0, sin 22.5, cos 22.5): one key, then two at 1 s.
    const std::map<std::string, std::string> files{
        {"one.gltf", gltf("AACAPwAAAAAAAAAAFO/DPl6DbD8=", 1)},
        {"two.gltf", gltf("AACAPwAAgD8AAAAAAAAAABTvwz5eg2w/AAAAAAAAAAAU78M+XoNsPw==", 2)}};
    for (const auto& [name, text] : files) {
        CAPTURE(name);
        const TargetClip clip = readTargetClip(test::writeFile(dir / name, text), TargetMap{});
        CHECK(clip.worlds.size() == 1);
        CHECK(clip.frameNumbers.size() == 1);
        CHECK(clip.frameTime == doctest::Approx(1.0 / 30));
        const auto knee = std::find(clip.joints.begin(), clip.joints.end(), "knee");
        REQUIRE(knee != clip.joints.end());
        const Eigen::Matrix4d world = clip.worlds[0][static_cast<std::size_t>(knee - clip.joints.begin())];
        CHECK(std::abs(world(0, 0) - std::sqrt(0.5)) < 1e-6);
        CHECK(std::abs(world(1, 0) - std::sqrt(0.5)) < 1e-6);
    }
}

TEST_CASE("assimp clips: takes by name or index, the first by default, a bad one listing them")
{
    const fs::path wuson = models / "X/Testwuson.X";
    if (!fs::exists(wuson)) {
        MESSAGE("[skipped] " << wuson.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    CHECK(readSkeletalClip(wuson, "").source.take == "Wuson_Run");
    const SkeletalClip walk = readSkeletalClip(wuson, "Wuson_Walk");
    CHECK(walk.source.takeIndex == 1);
    CHECK(walk.source.takeCount == 3);
    CHECK(readSkeletalClip(wuson, "2").source.take == "Wuson_Bind");
    CHECK(walk.clip.frameCount == 109);
    CHECK(walk.clip.frameTime == doctest::Approx(1.0 / 30));
    CHECK(errorOf([&] { readSkeletalClip(wuson, "Wuson_Jump"); }) ==
          wuson.string() +
              ": no take 'Wuson_Jump'; its takes are 0 'Wuson_Run', 1 'Wuson_Walk', 2 'Wuson_Bind'; give --take NAME "
              "or INDEX");
    CHECK(errorOf([&] { readSkeletalClip(wuson, "3"); }).find(": no take '3'; its takes are 0 'Wuson_Run'") !=
          std::string::npos);
}

TEST_CASE("assimp clips: assimp's BVH import agrees with our BVH reader on the CMU clips, to its floats")
{
    for (const char* name : {"01_01.bvh", "01_03.bvh", "Boxing_Toes.bvh"}) {
        const fs::path file = models / "BVH" / name;
        CAPTURE(file.string());
        if (!fs::exists(file)) {
            MESSAGE("[skipped] " << file.string() << " is absent (Debian package assimp-testmodels)");
            continue;
        }
        const BvhClip ours = readBvhFile(file);
        const SkeletalClip theirs = readAssimpClip(file, "");
        // assimp makes each End Site a joint, EndSite_<joint>; ours keeps them as End Sites.
        std::map<std::string, int> index;
        int endSites = 0;
        for (std::size_t j = 0; j < theirs.clip.joints.size(); ++j) {
            index[theirs.clip.joints[j].name] = static_cast<int>(j);
            endSites += theirs.clip.joints[j].name.starts_with("EndSite_");
        }
        int ourEndSites = 0;
        for (const auto& joint : ours.joints) ourEndSites += joint.endSite.has_value();
        CHECK(endSites == ourEndSites);
        CHECK(theirs.clip.joints.size() == ours.joints.size() + static_cast<std::size_t>(endSites));
        // assimp counts the frames the header says (Boxing_Toes says 3069 of its 3070 lines); ours, the lines.
        const int frames = std::min(ours.frameCount, theirs.clip.frameCount);
        CHECK(ours.frameCount - frames <= 1);
        CHECK(theirs.clip.frameTime == doctest::Approx(ours.frameTime).epsilon(1e-6));
        double worstCm = 0, worstRelative = 0, worstDeg = 0;
        for (int f = 0; f < frames; ++f) {
            const auto a = bvhWorldMatrices(theirs.clip, f);
            const auto b = bvhWorldMatrices(ours, f);
            for (std::size_t j = 0; j < ours.joints.size(); ++j) {
                REQUIRE(index.count(ours.joints[j].name));
                const Eigen::Matrix4d& m = a[static_cast<std::size_t>(index[ours.joints[j].name])];
                const double cm = (m.block<3, 1>(0, 3) - b[j].block<3, 1>(0, 3)).norm();
                const Eigen::Matrix3d r = m.block<3, 3>(0, 0).transpose() * b[j].block<3, 3>(0, 0);
                worstCm = std::max(worstCm, cm);
                worstRelative = std::max(worstRelative, cm / (1.0 + b[j].block<3, 1>(0, 3).norm()));
                worstDeg = std::max(worstDeg, std::acos(std::min(1.0, (r.trace() - 1) / 2)) * 180 / std::numbers::pi);
            }
        }
        MESSAGE(
            fmt::format("{}: assimp against ours over {} frames: worst {:.3g} cm ({:.3g} of the distance), "
                        "{:.3g} deg",
                        name, frames, worstCm, worstRelative, worstDeg));
        CHECK(worstRelative < 1e-5);
        CHECK(worstDeg < 1e-3);
    }
}

TEST_CASE("skeletonClip node: any format's take, its source, the same outputs as bvhClip on a BVH file")
{
    auto graph = loadGraphText(fmt::format(R"(
nodes:
  - {{name: leg, type: skeletonClip, file: '{}', take: bend}}
)",
                                           legInches.string()),
                               "t.yaml", makeBuiltinRegistry());
    const auto get = [&](const std::string& plug) { return graph->getValue(graph->plug(plug)); };
    graph->setTime(3);
    CHECK(std::get<int>(get("leg.frameCount")) == 3);
    CHECK(std::get<std::string>(get("leg.jointNames")) == "hip\nknee\nankle");
    CHECK(std::get<std::string>(get("leg.source")) ==
          "FBX, units x2.54 to cm (FBX UnitScaleFactor 2.54), up axis Z, take 0 'bend' of 1, 2 fps");
    const TargetClip targets = readTargetClip(legInches, TargetMap{});
    for (int j = 0; j < 3; ++j)
        CHECK(std::get<Eigen::Matrix4d>(get(fmt::format("leg.worldMatrix[{}]", j))) == targets.worlds[2][j]);
    CHECK(graph->checkEvaluation().empty());
    graph->setValue(graph->plug("leg.take"), std::string("run"));
    CHECK(errorOf([&] { get("leg.frameCount"); }).find(": no take 'run'; its takes are 0 'bend'") != std::string::npos);

    // On a BVH file, skeletonClip is bvhClip.
    const fs::path bvh = test::sourceDir() / "tests/corpus/bvh/good.bvh";
    auto both = loadGraphText(fmt::format(R"(
nodes:
  - {{name: a, type: bvhClip, file: '{0}'}}
  - {{name: b, type: skeletonClip, file: '{0}'}}
)",
                                          bvh.string()),
                              "t.yaml", makeBuiltinRegistry());
    for (const double time : {1.0, 1.5, 2.0}) {
        both->setTime(time);
        for (const char* output : {"worldMatrix[0]", "worldMatrix[1]", "channel[0]", "channel[3]", "jointNames",
                                   "channelNames", "frameCount", "frameTime"})
            CHECK(both->getValue(both->plug(fmt::format("a.{}", output))) ==
                  both->getValue(both->plug(fmt::format("b.{}", output))));
    }
}

TEST_CASE("assimp clips: the reader's process stops at its memory and CPU limits, each in one line")
{
    // Address space is what the limit counts, so the reader reserves without touching: no memory is used.
    const rig::ChildLimits small{std::size_t{64} << 20, 1};
    // Up to 64 GB in 16 MB blocks: under the limit the first few fail; what it got says why when they do not.
    const auto greedy = [] {
        std::vector<std::unique_ptr<char[]>> blocks;
        for (int i = 0; i < 4096; ++i) blocks.emplace_back(new char[std::size_t{16} << 20]);
        rlimit memory{};
        ::getrlimit(RLIMIT_AS, &memory);
        rig::SkeletalClip clip;
        clip.source.format = fmt::format("{} blocks of 16 MB under an address-space limit of {} MB", blocks.size(),
                                         memory.rlim_cur >> 20);
        return clip;
    };
    std::string outcome;
    try {
        outcome = "read: " + rig::readClipIsolated(greedy, "greedy.dae", small).source.format;
    }
    catch (const rig::Error& e) {
        outcome = e.what();
    }
    // A sandbox whose kernel takes setrlimit but does not enforce RLIMIT_AS hands out all 64 GB untouched: the
    // limit cannot be tested there, and the reader runs without that safety net.
    if (outcome.starts_with("read: 4096 blocks"))
        MESSAGE("not tested: this system does not enforce RLIMIT_AS (" << outcome << ")");
    else
        CHECK(outcome ==
              "greedy.dae: assimp needed more than its 64 MB to read it; the file is damaged or declares "
              "more than it holds");
    const auto endless = [] {
        volatile double x = 0.0;
        for (;;) x = x + 1.0;
        return rig::SkeletalClip{};
    };
    CHECK_THROWS_WITH_AS(rig::readClipIsolated(endless, "endless.fbx", small),
                         "endless.fbx: assimp stopped while reading it (past its limit of 1 s of CPU time); the "
                         "file is damaged, or assimp cannot read it",
                         rig::Error);
    const rig::ChildLimits big = rig::childLimitsFor(std::size_t{100} << 20);
    CHECK(big.memoryBytes == (std::size_t{2} << 30) + (std::size_t{3200} << 20));
    CHECK(big.cpuSeconds == 160);
}

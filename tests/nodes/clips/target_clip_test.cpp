// Target clips for inversion: BVH and graph-eval JSON read to the same world matrices, map files
// rename and scale, and every mistake in a map or a clip is one line naming the place.
#include <doctest/doctest.h>

#include "core/error.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/clips/bvh.h"
#include "nodes/clips/target_clip.h"
#include "test_support.h"

using namespace rig;

namespace {

const char* const twoJointBvh =
    "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n"
    "  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
    "  JOINT Chest\n  {\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n"
    "    End Site\n    {\n      OFFSET 0 5 0\n    }\n  }\n}\nMOTION\nFrames: 2\n"
    "Frame Time: 0.04\n0 0 0 0 0 0 0 0 0\n1 2 3 10 20 30 40 50 60\n";

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

TEST_CASE("target clip from BVH: the reference kinematics, translations scaled by the map")
{
    const auto dir = test::scratchDir("target_clip_bvh");
    const auto bvh = test::writeFile(dir / "clip.bvh", twoJointBvh);
    const auto mapFile = test::writeFile(dir / "map.yaml", "scale: 2.5\njoints: {Chest: spine}\n");
    const TargetClip clip = readTargetClip(bvh, readTargetMap(mapFile));
    REQUIRE(clip.joints == std::vector<std::string>{"Hips", "spine"});
    REQUIRE(clip.worlds.size() == 2);
    CHECK(clip.frameNumbers == std::vector<double>{1, 2});
    const BvhClip reference = readBvhFile(bvh);
    for (int f = 0; f < 2; ++f)
        for (int j = 0; j < 2; ++j) {
            Eigen::Matrix4d expected = bvhWorldMatrices(reference, f)[j];
            expected.block<3, 1>(0, 3) *= 2.5;
            CHECK(clip.worlds[f][j] == expected);
        }

    // Ignored joints are left out.
    test::writeFile(mapFile, "ignore: [Hips]\n");
    CHECK(readTargetClip(bvh, readTargetMap(mapFile)).joints == std::vector<std::string>{"Chest"});
}

TEST_CASE("target clip from graph-eval JSON equals the rig's joints")
{
    const auto dir = test::scratchDir("target_clip_json");
    const auto json = dir / "arm.json";
    const auto r = test::run(test::tool("graph-eval") +
                             " rigs/examples/arm.yaml --frames 1:3 --get '*.worldMatrix' -o " + json.string());
    REQUIRE(r.exitCode == 0);
    const TargetClip clip = readTargetClip(json, TargetMap{});
    CHECK(clip.frameNumbers == std::vector<double>{1, 2, 3});
    auto graph = loadGraphFile(test::sourceDir() / "rigs/examples/arm.yaml", makeBuiltinRegistry());
    REQUIRE(!clip.joints.empty());
    for (int f = 0; f < 3; ++f) {
        graph->setTime(f + 1);
        for (std::size_t j = 0; j < clip.joints.size(); ++j) {
            const auto m = std::get<Eigen::Matrix4d>(graph->getValue(graph->plug(clip.joints[j] + ".worldMatrix")));
            CHECK((clip.worlds[f][j] - m).cwiseAbs().maxCoeff() == 0.0);
        }
    }
}

TEST_CASE("target clip and map mistakes are one line with the place and what to do")
{
    const auto dir = test::scratchDir("target_clip_errors");
    const auto bvh = test::writeFile(dir / "clip.bvh", twoJointBvh);
    const auto map = [&](const std::string& text) { return readTargetMap(test::writeFile(dir / "map.yaml", text)); };
    const std::string m = (dir / "map.yaml").string();
    CHECK(errorOf([&] { map("scale: -1\n"); }) == m + ":1:8: scale must be positive (target units to cm), got -1");
    CHECK(errorOf([&] { map("scale: .nan\n"); }) == m + ":1:8: scale is not a finite number");
    CHECK(errorOf([&] { map("scael: 2\n"); }) ==
          m + ":1:1: unknown key 'scael'; a map file has 'scale:', 'joints:', 'ignore:', 'retarget:' and 'weights:'");
    CHECK(errorOf([&] { map("joints: [a, b]\n"); }) ==
          m + ":1:9: 'joints' must map target joints to rig joints (Hips: pelvis)");
    CHECK(errorOf([&] { map("- 1\n"); }) == m + ":1:1: a map file is a map with 'scale:', 'joints:', 'ignore:', "
                                                "'retarget:' and 'weights:' (docs/retargeting.md)");
    CHECK(errorOf([&] { readTargetClip(bvh, map("joints:\n  Chset: spine\n")); }) ==
          m + ":2: the map renames 'Chset', which " + bvh.string() + " does not have; check the joint name");
    CHECK(errorOf([&] { readTargetClip(bvh, map("joints: {Chest: Hips}\n")); }) ==
          bvh.string() + ": two target joints become 'Hips'; rename or ignore one of them in the map");
    CHECK(errorOf([&] { readTargetMap(dir / "none.yaml"); }) ==
          (dir / "none.yaml").string() + ": no such map file; check the path");
    // Neither BVH nor JSON by content or name: assimp's, whose own reason is quoted.
    CHECK(errorOf([&] { readTargetClip(test::writeFile(dir / "clip.fbx", "not a model\n"), TargetMap{}); }) ==
          (dir / "clip.fbx").string() +
              ": assimp cannot read it: FBX-Parser (TOK_DATA, line 1, col 4) unexpected token, expected TOK_KEY; give "
              "a file of a format assimp reads (docs/clips.md)");

    const auto json = [&](const std::string& text) { return test::writeFile(dir / "clip.json", text); };
    const std::string j = (dir / "clip.json").string();
    CHECK(errorOf([&] { readTargetClip(json("{}"), TargetMap{}); }) ==
          j + ":1:1: expected a list of frames as graph-eval writes them ([{\"frame\": 1, \"hips.worldMatrix\": "
              "[[...], ...]}, ...])");
    CHECK(errorOf([&] { readTargetClip(json("[{\"frame\": 1, \"a.translate\": [1, 2, 3]}]"), TargetMap{}); }) ==
          j + ":1:15: 'a.translate' is not a joint's world matrix (NODE.worldMatrix); ask graph-eval for --get "
              "'*.worldMatrix' only");
    CHECK(errorOf([&] {
              readTargetClip(json("[{\"frame\": 1, \"a.worldMatrix\": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1]]}]"),
                             TargetMap{});
          }) == j + ":1:32: a.worldMatrix must be a matrix as four rows of four numbers");
    const std::string id = "[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]";
    CHECK(errorOf([&] {
              readTargetClip(json("[{\"frame\": 2, \"a.worldMatrix\": " + id +
                                  "},\n {\"frame\": 1, \"a.worldMatrix\": " + id + "}]"),
                             TargetMap{});
          }) == j + ":2:12: frame 1 comes after frame 2; frames must increase");
    CHECK(errorOf([&] {
              readTargetClip(json("[{\"frame\": 1, \"a.worldMatrix\": [[1, 0, 0, .nan], [0, 1, 0, 0], [0, 0, 1, 0], "
                                  "[0, 0, 0, 1]]}]"),
                             TargetMap{});
          }) == j + ":1:43: JSON syntax error: syntax error while parsing value - invalid literal; last read: '0, .'; "
                    "a JSON clip "
                    "is one list of frames, as graph-eval writes it");  // .nan is YAML, not JSON
}

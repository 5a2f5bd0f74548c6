// Files named in a rig file are read from that file's folder, as includes are, whatever the current
// folder: a bvhClip's clip and a rigInversion's approximation and map.
#include <doctest/doctest.h>

#include <filesystem>

#include <fmt/format.h>

#include "learned_fixtures.h"
#include "test_support.h"

using rig::test::run;
namespace fs = std::filesystem;

TEST_CASE("paths: a bvhClip's file in a rig file is read from the rig file's folder, from any current folder")
{
    const auto dir = rig::test::scratchDir("paths-clip");
    fs::create_directories(dir / "rigs" / "clips");
    rig::test::writeFile(
        dir / "rigs" / "clips" / "c.bvh",
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n End Site\n"
        " {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.0333\n30 0 0\n");
    const auto rigFile = rig::test::writeFile(dir / "rigs" / "play.yaml",
                                              "nodes:\n  - {name: clip, type: bvhClip, file: clips/c.bvh}\n");
    // From the source folder and from the scratch folder: the same clip.
    for (const std::string& from : {std::string("."), dir.string()}) {
        CAPTURE(from);
        const auto r = run(fmt::format("cd '{}' && {} '{}' --get 'clip.channel[0]' --format csv", from,
                                       rig::test::tool("graph-eval"), rigFile.string()));
        CHECK(r.exitCode == 0);
        CHECK(r.out == "frame,clip.channel[0]\n0,30\n");
    }
    // A missing clip is named with the path it was looked for at.
    rig::test::writeFile(dir / "rigs" / "missing.yaml", "nodes:\n  - {name: clip, type: bvhClip, file: nowhere.bvh}\n");
    const auto r = run(fmt::format("{} '{}'", rig::test::tool("graph-eval"), (dir / "rigs" / "missing.yaml").string()));
    CHECK(r.exitCode == 2);
    CHECK(r.err.find((dir / "rigs" / "nowhere.bvh").string()) != std::string::npos);
}

TEST_CASE("paths: the bundled biped_mocap example, verbatim in a tree of its own, runs from another folder")
{
    if (!fs::exists(rig::test::cmuClip)) {
        MESSAGE("[skipped] " << rig::test::cmuClip.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    // The project's layout (rigs/examples, rigs/maps, build/) rebuilt elsewhere, the example unchanged.
    const auto dir = rig::test::scratchDir("paths-mocap");
    const fs::path source = rig::test::sourceDir();
    for (const char* file : {"rigs/examples/biped_mocap.yaml", "rigs/biped.yaml", "rigs/maps/cmu_to_biped.yaml"}) {
        fs::create_directories((dir / file).parent_path());
        fs::copy_file(source / file, dir / file);
    }
    fs::create_directories(dir / "build");
    fs::copy_file(rig::test::bipedApproximation(), dir / "build" / "biped.approx.yaml");
    fs::create_directories(dir / "elsewhere");
    const auto r =
        run(fmt::format("cd '{}' && {} ../rigs/examples/biped_mocap.yaml --frames 1:2 --get 'inverter.status' "
                        "--format csv",
                        (dir / "elsewhere").string(), rig::test::tool("graph-eval")));
    CHECK(r.exitCode == 0);
    CHECK(r.err.empty());
    // Frame 1 is the clip's calibration pose, which the rig reaches; from frame 2 on the motion is out
    // of its exact reach (the spine and neck share their rotations): stationary with a residual, a best fit.
    CHECK(r.out == "frame,inverter.status\n1,reached\n2,bestFit\n");  // the enum by name, as in JSON
}

#pragma once
// Approximations the end-to-end tests share, learned once per test run with the real rig-learn:
// the CMU clip's bvh2rig rig over its channels, and the biped over rigs/biped_inversion.yaml. Each in a
// folder of the test process's own: CTest runs test cases as parallel processes, and one learning in a
// shared folder would wipe another's file.

#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "nodes/clips/bvh.h"
#include "test_support.h"

namespace rig::test {

inline const std::filesystem::path cmuClip = "/usr/share/assimp/models/BVH/01_01.bvh";

inline std::string shellWords(const std::vector<std::string>& words)
{
    std::string out;
    for (const auto& w : words) out += " '" + w + "'";
    return out;
}

struct CmuSetup {
    std::filesystem::path rig;            // bvh2rig's rig of the clip
    std::filesystem::path approximation;  // over the channels' plugs, outputs the clip's joints
    BvhClip clip;
};

// Needs cmuClip (callers skip when it is absent).
inline const CmuSetup& cmuSetup()
{
    static const CmuSetup setup = [] {
        CmuSetup s;
        const auto dir = scratchDir(fmt::format("learned_cmu.{}", ::getpid()));
        s.rig = dir / "cmu.yaml";
        s.approximation = dir / "cmu.approx.yaml";
        s.clip = readBvhFile(cmuClip);
        REQUIRE(run(fmt::format("{} {} -o {}", tool("bvh2rig"), cmuClip.string(), s.rig.string())).exitCode == 0);
        std::vector<std::string> params{"Hips.translate?"}, outputs;
        for (const auto& j : s.clip.joints) {
            outputs.push_back(j.name);
            for (const auto channel : j.channels)
                if (bvhIsRotation(channel))
                    params.push_back(fmt::format("{}.rotate{}", j.name, "XYZ"[bvhChannelAxis(channel)]));
        }
        const auto r = run(fmt::format("{} {} --params{} --outputs{} -o {}", tool("rig-learn"), s.rig.string(),
                                       shellWords(params), shellWords(outputs), s.approximation.string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return s;
    }();
    return setup;
}

// The biped's approximation over its inversion parameters and the CMU joints.
inline std::filesystem::path bipedApproximation()
{
    static const std::filesystem::path file = [] {
        const auto out = scratchDir(fmt::format("learned_biped.{}", ::getpid())) / "biped.approx.yaml";
        const auto r = run(
            fmt::format("{} rigs/biped.yaml --spec rigs/biped_inversion.yaml -o {}", tool("rig-learn"), out.string()));
        INFO(r.err);
        REQUIRE(r.exitCode == 0);
        return out;
    }();
    return file;
}

// The look-at crowd of `count` bipeds (docs/crowds.md), scripts/make_crowd.py COUNT in `dir`, with the rig,
// the learned approximation and the map named by absolute paths.
inline std::filesystem::path writeCrowd(const std::filesystem::path& dir, int count)
{
    const auto source = sourceDir();
    const std::filesystem::path file = dir / fmt::format("crowd{}.yaml", count);
    const auto r =
        run(fmt::format("python3 scripts/make_crowd.py {} --rig '{}' --approximation '{}' --map '{}' -o '{}'", count,
                        (source / "rigs/biped.yaml").string(), bipedApproximation().string(),
                        (source / "rigs/maps/cmu_to_biped_lookat.yaml").string(), file.string()));
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
    return file;
}

}  // namespace rig::test

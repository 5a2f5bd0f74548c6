// Every real skeleton at hand, with all of its controls: each BVH file of Debian's assimp-testmodels
// and of ../shared/motion, made a rig by bvh2rig, learned with every rotation and the root's
// translation listed last (the order that once broke the composition order), in parent-relative
// frames and in world space. Each must be exact with nothing discarded.
#include <doctest/doctest.h>

#include <algorithm>
#include <filesystem>

#include <fmt/format.h>

#include "adapter/graph_rig_function.h"
#include "inversion/learn/learner.h"
#include "nodes/clips/bvh.h"
#include "test_support.h"

using namespace rig;
namespace fs = std::filesystem;

namespace {

void learnSkeleton(const fs::path& clipFile, const std::string& tag)
{
    CAPTURE(clipFile.string());
    const auto dir = test::scratchDir("learn-skeleton-" + tag);
    const auto rigFile = dir / "skeleton.yaml";
    const auto made =
        test::run(fmt::format("{} '{}' -o '{}'", test::tool("bvh2rig"), clipFile.string(), rigFile.string()));
    REQUIRE(made.exitCode == 0);
    const BvhClip clip = readBvhFile(clipFile);
    REQUIRE(!clip.joints.empty());
    const std::vector<std::string> globs{"*.rotate?", clip.joints.front().name + ".translate?"};
    for (const bool relative : {true, false}) {
        CAPTURE(relative);
        GraphRigFunction rig(rigFile, {globs, {}, {}});
        LearnOptions options;
        options.relativeFrames = relative;
        const Approximation a = learnApproximation(rig, options, rigFile.string());
        MESSAGE(fmt::format(
            "{} ({}): {} parameters, {} outputs, {} rig evaluations ({} for the order), validation {:.3g} cm, "
            "{:.3g} deg",
            clipFile.filename().string(), relative ? "relative" : "world", a.parameters.size(), a.outputs.size(),
            a.training.evaluations, a.training.orderEvaluations, a.validation.maxPositionErrorCm,
            a.validation.maxRotationErrorDeg));
        CHECK(a.discarded.empty());
        CHECK(a.parameters.size() == rig.parameters().size());
        CHECK(a.validation.maxPositionErrorCm < 1e-9);
        CHECK(a.validation.maxRotationErrorDeg < 1e-9);
        CHECK(a.validation.withinEpsilon);
    }
}

std::vector<fs::path> bvhFiles(const fs::path& folder)
{
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(folder))
        if (entry.path().extension() == ".bvh") files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
}

}  // namespace

TEST_CASE("every BVH skeleton of assimp-testmodels, all rotations and the root's translation: exact, nothing discarded")
{
    const fs::path folder = "/usr/share/assimp/models/BVH";
    if (!fs::is_directory(folder)) {
        MESSAGE("[skipped] " << folder.string() << " is absent (Debian package assimp-testmodels)");
        return;
    }
    const auto files = bvhFiles(folder);
    CHECK_FALSE(files.empty());
    for (const fs::path& file : files) learnSkeleton(file, "assimp-" + file.stem().string());
}

TEST_CASE("every BVH skeleton of ../shared/motion, all rotations and the root's translation: exact, nothing discarded")
{
    const fs::path folder = test::sourceDir() / "../shared/motion";
    if (!fs::is_directory(folder)) {
        MESSAGE("[skipped] " << folder.string() << " is absent (a clone without ../shared)");
        return;
    }
    const auto files = bvhFiles(folder);
    CHECK_FALSE(files.empty());
    for (const fs::path& file : files) learnSkeleton(file, "shared-" + file.stem().string());
}

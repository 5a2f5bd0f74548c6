// The public Maya scenes of ../shared/maya (docs/maya.md; skipped where the folder is absent): each one evaluates with
// finite joints over its playback range or is refused in one line; Maya's own answers are reproduced: every IK-chain
// joint's saved rotate within 0.01 degrees at the saved time, compared as rotation matrices.

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <iostream>
#include <numbers>

#include <fmt/format.h>
#include <Eigen/LU>

#include "core/error.h"
#include "core/rotation_math.h"
#include "graph/rig_file.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

using namespace rig;
namespace fs = std::filesystem;

std::vector<fs::path> sharedScenes()
{
    std::vector<fs::path> scenes;
    const fs::path folder = test::sourceDir() / "../shared/maya";
    if (!fs::is_directory(folder)) return scenes;
    for (const auto& entry : fs::recursive_directory_iterator(folder))
        if (entry.path().extension() == ".ma") scenes.push_back(entry.path());
    std::sort(scenes.begin(), scenes.end());
    return scenes;
}

// The worst angle, in degrees, between the rotate Maya saved on an IK joint and the one evaluated.
double worstIkError(Graph& graph, const MayaSceneInfo& info, std::string& worstJoint)
{
    double worst = 0.0;
    for (const auto& [joint, saved] : info.savedIkRotate) {
        const RotateOrder order =
            rotateOrderFromIndex(std::get<int>(graph.getValue(graph.plug(joint + ".rotateOrder")))).value();
        const Eigen::Vector3d got = std::get<Eigen::Vector3d>(graph.getValue(graph.plug(joint + ".rotate")));
        const double angle =
            orientationAngle(eulerToMatrix(saved * std::numbers::pi / 180.0, order), eulerToMatrix(got, order)) *
            180.0 / std::numbers::pi;
        if (angle > worst) {
            worst = angle;
            worstJoint = joint;
        }
    }
    return worst;
}

// The worst distance, in cm, between a skin influence's world position and the one its skinCluster's bind-pre matrix
// holds (0 where the scene is saved at its bind pose), over every skin; -1 when the scene has no skin.
double worstBindError(Graph& graph, const MayaSceneInfo& info, int& influences)
{
    double worst = -1.0;
    influences = 0;
    for (const auto& skin : info.skins)
        for (std::size_t i = 0; i < skin.influences.size(); ++i) {
            if (skin.influences[i].empty() || skin.bindPreMatrix[i].isZero()) continue;
            const Eigen::Matrix4d world =
                std::get<Eigen::Matrix4d>(graph.getValue(graph.plug(skin.influences[i] + ".worldMatrix")));
            const Eigen::Vector3d bindPosition = skin.bindPreMatrix[i].inverse().topRightCorner<3, 1>();
            worst = std::max(worst, (world.topRightCorner<3, 1>() - bindPosition).norm());
            ++influences;
        }
    return worst;
}

bool jointsFinite(Graph& graph)
{
    for (NodeId n = 0; n < graph.nodeCount(); ++n)
        if (graph.nodeType(n).name() == "joint" &&
            !isFinite(graph.getValue(graph.plug(graph.nodeName(n) + ".worldMatrix"))))
            return false;
    return true;
}

}  // namespace

TEST_CASE(
    "maya scenes of ../shared/maya: each evaluates or is refused in one line, and Maya's IK answers hold within 0.01 "
    "deg")
{
    const auto scenes = sharedScenes();
    if (scenes.empty()) {
        MESSAGE("[skipped] ../shared/maya is absent");
        return;
    }
    int loaded = 0, refused = 0;
    for (const fs::path& scene : scenes) {
        CAPTURE(scene.string());
        MayaSceneInfo info;
        std::unique_ptr<Graph> graph;
        try {
            graph = loadRigFile(scene, makeBuiltinRegistry(), nullptr, &info);
        }
        catch (const Error& e) {
            const std::string message = e.what();
            CHECK(message.find('\n') == std::string::npos);
            CHECK(e.kind() == ErrorKind::userInput);
            std::cout << fmt::format("maya scene {}: refused: {}\n", scene.filename().string(), message);
            ++refused;
            continue;
        }
        ++loaded;
        CHECK(jointsFinite(*graph));
        std::string joint;
        const double worst = worstIkError(*graph, info, joint);
        std::cout << fmt::format("maya scene {}: {} nodes, IK joints with a saved rotate {}, worst {:.3g} deg{}\n",
                                 scene.filename().string(), info.nodes, info.savedIkRotate.size(), worst,
                                 joint.empty() ? "" : " at " + joint);
        CHECK(worst < 0.01);
        int influences = 0;
        const double bind = worstBindError(*graph, info, influences);
        if (bind >= 0)
            std::cout << fmt::format("maya scene {}: {} skin influences, worst {:.3g} cm from the bind pose{}\n",
                                     scene.filename().string(), influences, bind, bind < 1e-4 ? " (saved at it)" : "");
        // A scene saved at its bind pose is there exactly: close to it (1e-2 cm) means within 1e-4 cm.
        if (bind >= 0 && bind < 1e-2) CHECK(bind < 1e-4);
        // Over the playback range: finite, and two threads give the serial evaluation's bits.
        auto parallel = graph->instance();
        parallel->setThreads(2);
        const double first = info.playbackRange ? info.playbackRange->first : info.savedTime;
        const double last = info.playbackRange ? info.playbackRange->second : info.savedTime;
        for (double f = first; f <= last; f += 1.0) {
            graph->setTime(f);
            parallel->setTime(f);
            REQUIRE(jointsFinite(*graph));
            for (NodeId n = 0; n < graph->nodeCount(); ++n) {
                if (graph->nodeType(n).name() != "joint") continue;
                const Plug world = graph->plug(graph->nodeName(n) + ".worldMatrix");
                parallel->evaluate(std::span<const Plug>(&world, 1));
                REQUIRE(bitEqual(graph->getValue(world), parallel->getValue(world)));
            }
        }
    }
    std::cout << fmt::format("maya scenes: {} evaluate, {} refused in one line\n", loaded, refused);
}

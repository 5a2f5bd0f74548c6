// The skeleton-space edit nodes (nodes/edit/, docs/nodes.md "Editing a clip's skeleton") through a Graph:
// lookAt against closed forms (one joint onto its target, a chain's shares of the remaining turn worked by
// hand in the plane, limits reached, a target behind and on a pivot, weights), offsetLayer and blendClips
// against hand-computed matrices, the example clip -> lookAt graph serial and parallel, the biped inverted
// to look at a target through rigInversion (rigs/examples/biped_lookat.yaml), and bad inputs.

#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "learned_fixtures.h"
#include "nodes/builtin_nodes.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;

double deg(double degrees) { return degrees * pi / 180.0; }

Eigen::Matrix4d frame(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& position)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation;
    m.topRightCorner<3, 1>() = position;
    return m;
}

Eigen::Matrix3d rotation(double radians, const Eigen::Vector3d& axis)
{
    return Eigen::AngleAxisd(radians, axis.normalized()).toRotationMatrix();
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
    return std::atan2(a.cross(b).norm(), a.dot(b));
}

double maxDiff(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) { return (a - b).cwiseAbs().maxCoeff(); }

// A graph with one node `n` of `type`.
std::unique_ptr<rig::Graph> single(const std::string& type)
{
    auto g = std::make_unique<rig::Graph>(rig::makeBuiltinRegistry());
    g->addNode(type, "n");
    return g;
}

// A lookAt over `chain` (root first) toward `target`; further settings by the caller.
std::unique_ptr<rig::Graph> lookAt(const std::vector<Eigen::Matrix4d>& chain, const Eigen::Vector3d& target)
{
    auto g = single("lookAt");
    for (std::size_t k = 0; k < chain.size(); ++k) g->setValue(g->plug(fmt::format("n.inMatrix[{}]", k)), chain[k]);
    g->setValue(g->plug("n.target"), target);
    return g;
}

Eigen::Matrix4d out(rig::Graph& g, int k)
{
    return std::get<Eigen::Matrix4d>(g.getValue(g.plug(fmt::format("n.outMatrix[{}]", k))));
}

// A joint's turn, radians (the engine's unit inside; graph-eval prints degrees).
double turnOf(rig::Graph& g, int k) { return std::get<double>(g.getValue(g.plug(fmt::format("n.turn[{}]", k)))); }

// The world direction of local +Z (the default aim axis) of a world matrix.
Eigen::Vector3d aimOf(const Eigen::Matrix4d& m) { return m.topLeftCorner<3, 3>().col(2); }

std::string errorOf(rig::Graph& g)
{
    try {
        g.evaluateAll();
    }
    catch (const rig::Error& e) {
        CHECK(e.kind() == rig::ErrorKind::userInput);
        return e.what();
    }
    return "";
}

// Three joints 10 apart along +Z (a tentacle pointing forward), axes of the world: every turn toward a
// target in the XZ plane is about Y.
std::vector<Eigen::Matrix4d> planarChain()
{
    std::vector<Eigen::Matrix4d> chain;
    for (int k = 0; k < 3; ++k) chain.push_back(frame(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, 0, 10.0 * k)));
    return chain;
}

// The planar chain's turns worked by hand: headings in the XZ plane (atan2(x, z)), joint k at its moved
// pivot, the aim along the chain, each joint turning min(share * remaining angle, limit).
std::vector<double> planarTurns(const std::vector<double>& share, const std::vector<double>& limitDegrees)
{
    const double tx = 30.0, tz = 40.0;
    double heading = 0.0, px = 0.0, pz = 0.0;
    std::vector<double> turns;
    for (int k = 0; k < 3; ++k) {
        if (k > 0) {  // the joint sits 10 further along the chain's heading so far
            px += 10.0 * std::sin(heading);
            pz += 10.0 * std::cos(heading);
        }
        const double remaining = std::atan2(tx - px, tz - pz) - heading;
        const double phi =
            std::min(share[static_cast<std::size_t>(k)] * remaining, deg(limitDegrees[static_cast<std::size_t>(k)]));
        turns.push_back(phi);
        heading += phi;
    }
    return turns;
}

}  // namespace

TEST_CASE("lookAt: one joint turns its aim exactly onto the target")
{
    const Eigen::Matrix4d in = frame(rotation(0.7, {1, -2, 0.5}), {3, 150, -4});
    const Eigen::Vector3d target(40, 170, 60);
    SUBCASE("upMode none: the smallest turn")
    {
        auto g = lookAt({in}, target);
        g->setValue(g->plug("n.upMode"), 0);
        const Eigen::Matrix4d m = out(*g, 0);
        const Eigen::Vector3d toTarget = target - in.topRightCorner<3, 1>();
        CHECK(angleBetween(aimOf(m), toTarget) < 1e-12);
        CHECK(turnOf(*g, 0) == doctest::Approx(angleBetween(aimOf(in), toTarget)).epsilon(1e-13));
        CHECK(m.col(3) == in.col(3));  // turned about its own position
        // The smallest turn: about aim x direction, so that axis does not move.
        const Eigen::Vector3d axis = aimOf(in).cross(toTarget).normalized();
        CHECK((m.topLeftCorner<3, 3>() * in.topLeftCorner<3, 3>().transpose() * axis - axis).norm() < 1e-14);
    }
    SUBCASE("upMode world: the aim constraint's frame [A, U, A x U] [a, u, a x u]^T")
    {
        auto g = lookAt({in}, target);
        const Eigen::Matrix4d m = out(*g, 0);
        const Eigen::Vector3d A = (target - in.topRightCorner<3, 1>()).normalized();
        const Eigen::Vector3d U = (Eigen::Vector3d::UnitY() - A.y() * A).normalized();
        Eigen::Matrix3d world;
        world << A, U, A.cross(U);
        Eigen::Matrix3d local;  // aim +Z, up +Y in the joint's axes
        local << Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitY(),
            Eigen::Vector3d::UnitZ().cross(Eigen::Vector3d::UnitY());
        CHECK((m.topLeftCorner<3, 3>() - world * local.transpose()).cwiseAbs().maxCoeff() < 1e-14);
        CHECK(angleBetween(aimOf(m), target - in.topRightCorner<3, 1>()) < 1e-12);
    }
}

TEST_CASE("lookAt: each joint takes its share of the remaining turn (worked by hand in the plane)")
{
    const std::vector<double> share{0.3, 0.5, 1.0};
    auto g = lookAt(planarChain(), {30, 0, 40});
    g->setValue(g->plug("n.share"), share);
    g->setValue(g->plug("n.upMode"), 0);
    const std::vector<double> expected = planarTurns(share, {180, 180, 180});
    for (int k = 0; k < 3; ++k) CHECK(turnOf(*g, k) == doctest::Approx(expected[k]).epsilon(1e-13));
    // The last joint has share 1: its aim reaches the target exactly.
    CHECK(angleBetween(aimOf(out(*g, 2)), Eigen::Vector3d(30, 0, 40) - out(*g, 2).topRightCorner<3, 1>()) < 1e-12);
    // Later joints are re-composed from the edited ones: each keeps its place in the one before it.
    const std::vector<Eigen::Matrix4d> in = planarChain();
    for (int k = 0; k < 2; ++k) {
        const Eigen::Matrix4d before = in[k].inverse() * in[k + 1];
        const Eigen::Matrix4d after = out(*g, k).inverse() * out(*g, k + 1);
        CHECK((after.topRightCorner<3, 1>() - before.topRightCorner<3, 1>()).norm() < 1e-13);
        CHECK(rig::orientationAngle(after.topLeftCorner<3, 3>(), before.topLeftCorner<3, 3>()) ==
              doctest::Approx(expected[k + 1]).epsilon(1e-12));
    }
    SUBCASE("joints on one pivot split a turn in products of their shares; no shares: equal parts")
    {
        std::vector<Eigen::Matrix4d> stacked(3, frame(Eigen::Matrix3d::Identity(), {1, 2, 3}));
        auto s = lookAt(stacked, Eigen::Vector3d(1, 2, 3) + Eigen::Vector3d(10, 0, 10));  // 45 degrees
        s->setValue(s->plug("n.upMode"), 0);
        for (int k = 0; k < 3; ++k) CHECK(turnOf(*s, k) == doctest::Approx(deg(15.0)).epsilon(1e-13));
        s->setValue(s->plug("n.share"), std::vector<double>{0.5, 0.5, 1.0});
        CHECK(turnOf(*s, 0) == doctest::Approx(deg(22.5)).epsilon(1e-13));
        CHECK(turnOf(*s, 1) == doctest::Approx(deg(11.25)).epsilon(1e-13));
        CHECK(turnOf(*s, 2) == doctest::Approx(deg(11.25)).epsilon(1e-13));
    }
}

TEST_CASE("lookAt: a joint at its limit turns exactly its limit, the next ones take the rest")
{
    const std::vector<double> share{0.3, 0.5, 1.0};
    const std::vector<double> limit{5.0, 6.0, 90.0};
    auto g = lookAt(planarChain(), {30, 0, 40});
    g->setValue(g->plug("n.share"), share);
    g->setValue(g->plug("n.limit"), limit);
    g->setValue(g->plug("n.upMode"), 0);
    const std::vector<double> expected = planarTurns(share, limit);
    CHECK(expected[0] == doctest::Approx(deg(5.0)));  // the hand computation reaches the limits too
    CHECK(expected[1] == doctest::Approx(deg(6.0)));
    CHECK(turnOf(*g, 0) == doctest::Approx(deg(5.0)).epsilon(1e-14));
    CHECK(turnOf(*g, 1) == doctest::Approx(deg(6.0)).epsilon(1e-14));
    CHECK(turnOf(*g, 2) == doctest::Approx(expected[2]).epsilon(1e-13));
    CHECK(rig::orientationAngle(out(*g, 0).topLeftCorner<3, 3>(), Eigen::Matrix3d::Identity()) ==
          doctest::Approx(deg(5.0)).epsilon(1e-13));
    SUBCASE("a last joint at its limit leaves the aim short of the target by the rest")
    {
        g->setValue(g->plug("n.limit"), std::vector<double>{5.0, 6.0, 10.0});
        CHECK(turnOf(*g, 2) == doctest::Approx(deg(10.0)).epsilon(1e-14));
        const Eigen::Vector3d toTarget = Eigen::Vector3d(30, 0, 40) - out(*g, 2).topRightCorner<3, 1>();
        CHECK(angleBetween(aimOf(out(*g, 2)), toTarget) == doctest::Approx(expected[2] - deg(10.0)).epsilon(1e-12));
    }
}

TEST_CASE("lookAt: a target straight behind turns about the up, a target on a pivot turns nothing")
{
    const Eigen::Matrix4d in = frame(Eigen::Matrix3d::Identity(), {0, 0, 0});
    SUBCASE("behind, limited to 90 degrees: a quarter turn about world up, aim to +X")
    {
        auto g = lookAt({in}, {0, 0, -10});
        g->setValue(g->plug("n.limit"), std::vector<double>{90.0});
        CHECK((out(*g, 0).topLeftCorner<3, 3>() - rotation(pi / 2, Eigen::Vector3d::UnitY())).norm() < 1e-15);
        CHECK(turnOf(*g, 0) == doctest::Approx(deg(90.0)).epsilon(1e-14));
    }
    SUBCASE("behind, no limit: a half turn onto the target, up kept")
    {
        auto g = lookAt({in}, {0, 0, -10});
        const Eigen::Matrix4d m = out(*g, 0);
        CHECK(angleBetween(aimOf(m), Eigen::Vector3d(0, 0, -1)) < 1e-12);
        CHECK((m.topLeftCorner<3, 3>().col(1) - Eigen::Vector3d::UnitY()).norm() < 1e-15);
    }
    SUBCASE("on the joint itself: unchanged, no NaN")
    {
        const Eigen::Matrix4d j = frame(rotation(0.4, {0, 1, 1}), {5, 6, 7});
        auto g = lookAt({j}, {5, 6, 7});
        CHECK(rig::bitEqual(rig::Value(out(*g, 0)), rig::Value(j)));
        CHECK(turnOf(*g, 0) == 0.0);
    }
    SUBCASE("on a middle joint's pivot: that joint stays, the others turn")
    {
        auto g = lookAt(planarChain(), {0, 0, 10});
        g->setValue(g->plug("n.upMode"), 0);
        for (int k = 0; k < 3; ++k) CHECK(out(*g, k).allFinite());
        CHECK(turnOf(*g, 1) == 0.0);
    }
}

TEST_CASE("lookAt: a target or world up that is not finite gives NaN outputs, never the unedited chain")
{
    // Values set are refused when not finite; a node computes them: the inverse of a zero-scaled joint (NaN),
    // a product of two matrices of 1e300 (infinities).
    const std::string sources =
        "nodes:\n"
        "  - {name: zero, type: joint, scale: [0, 0, 0]}\n"
        "  - {name: nanD, type: decomposeMatrix}\n"
        "  - {name: big, type: transform, translate: [1e300, 1e300, 1e300], scale: [1e300, 1e300, 1e300]}\n"
        "  - {name: bigSquared, type: multMatrix}\n"
        "  - {name: infD, type: decomposeMatrix}\n"
        "  - {name: n, type: lookAt, upMode: world}\n"
        "connections:\n"
        "  - zero.worldInverseMatrix -> nanD.inputMatrix\n"
        "  - big.worldMatrix -> bigSquared.matrixIn[0]\n"
        "  - big.worldMatrix -> bigSquared.matrixIn[1]\n"
        "  - bigSquared.matrixSum -> infD.inputMatrix\n";
    for (const std::string source : {"nanD", "infD"})
        for (const std::string input : {"target", "worldUp"}) {
            CAPTURE(source);
            CAPTURE(input);
            auto g = rig::loadGraphText(fmt::format("{}  - {}.outputTranslate -> n.{}\n", sources, source, input),
                                        "look.yaml", rig::makeBuiltinRegistry());
            const auto chain = planarChain();
            for (std::size_t k = 0; k < chain.size(); ++k)
                g->setValue(g->plug(fmt::format("n.inMatrix[{}]", k)), chain[k]);
            if (input == "worldUp") g->setValue(g->plug("n.target"), Eigen::Vector3d(0, 5, 10));
            for (int k = 0; k < 3; ++k) {
                CHECK(out(*g, k).array().isNaN().all());
                CHECK(std::isnan(turnOf(*g, k)));
            }
        }
}

TEST_CASE("lookAt: weight 0 leaves the chain bit for bit, 1 is the full edit, between scales every turn")
{
    const std::vector<double> share{0.3, 0.5, 1.0};
    auto full = lookAt(planarChain(), {30, 5, 40});
    full->setValue(full->plug("n.share"), share);
    auto g = lookAt(planarChain(), {30, 5, 40});
    g->setValue(g->plug("n.share"), share);
    g->setValue(g->plug("n.weight"), 0.0);
    const std::vector<Eigen::Matrix4d> in = planarChain();
    for (int k = 0; k < 3; ++k) CHECK(rig::bitEqual(rig::Value(out(*g, k)), rig::Value(in[k])));
    g->setValue(g->plug("n.weight"), 1.0);
    for (int k = 0; k < 3; ++k) CHECK(rig::bitEqual(rig::Value(out(*g, k)), rig::Value(out(*full, k))));
    g->setValue(g->plug("n.weight"), 0.25);
    for (int k = 0; k < 3; ++k) CHECK(turnOf(*g, k) == doctest::Approx(0.25 * turnOf(*full, k)).epsilon(1e-13));
    // The root turns about its own pivot by a quarter of its full turn about the same axis.
    const Eigen::Matrix3d r0 = out(*full, 0).topLeftCorner<3, 3>();
    const Eigen::AngleAxisd aa(r0);
    CHECK((out(*g, 0).topLeftCorner<3, 3>() - rotation(0.25 * aa.angle(), aa.axis())).norm() < 1e-14);
    // deltaMatrix carries a joint's children: outMatrix = deltaMatrix * inMatrix.
    for (int k = 0; k < 3; ++k) {
        const auto delta = std::get<Eigen::Matrix4d>(g->getValue(g->plug(fmt::format("n.deltaMatrix[{}]", k))));
        CHECK(maxDiff(delta * in[k], out(*g, k)) < 1e-14);
    }
}

TEST_CASE("lookAt: a gap in inMatrix's indices is no joint, outputs are numbered along the chain")
{
    const std::vector<Eigen::Matrix4d> chain = planarChain();
    auto dense = lookAt({chain[0], chain[2]}, {30, 0, 40});
    auto g = single("lookAt");
    g->setValue(g->plug("n.inMatrix[0]"), chain[0]);
    g->setValue(g->plug("n.inMatrix[5000]"), chain[2]);
    g->setValue(g->plug("n.target"), Eigen::Vector3d(30, 0, 40));
    g->evaluateAll();
    const rig::NodeId n = g->node("n");
    CHECK(g->elementIndices(n, g->nodeType(n).findAttribute("outMatrix")) == std::vector<int>{0, 1});
    for (int k = 0; k < 2; ++k) CHECK(rig::bitEqual(rig::Value(out(*g, k)), rig::Value(out(*dense, k))));
}

TEST_CASE("offsetLayer: a rotation and translation in the joint's axes or in world axes, weighted")
{
    auto g = single("offsetLayer");
    // The joint: turned 90 degrees about Z (x -> y, y -> -x), at (1, 2, 3).
    const Eigen::Matrix4d in = frame(rotation(pi / 2, Eigen::Vector3d::UnitZ()), {1, 2, 3});
    g->setValue(g->plug("n.inMatrix"), in);
    g->setValue(g->plug("n.rotate"), Eigen::Vector3d(pi / 2, 0, 0));  // 90 degrees about X
    g->setValue(g->plug("n.translate"), Eigen::Vector3d(0, 10, 0));
    auto result = [&] { return std::get<Eigen::Matrix4d>(g->getValue(g->plug("n.outMatrix"))); };
    Eigen::Matrix4d local;  // Rz90 * Rx90, the translation along the joint's Y = world -X
    local << 0, 0, 1, -9, 1, 0, 0, 2, 0, 1, 0, 3, 0, 0, 0, 1;
    CHECK(maxDiff(result(), local) < 1e-15);
    g->setValue(g->plug("n.space"), 1);
    Eigen::Matrix4d world;  // Rx90 * Rz90 about the joint's position, the translation along world Y
    world << 0, -1, 0, 1, 0, 0, -1, 12, 1, 0, 0, 3, 0, 0, 0, 1;
    CHECK(maxDiff(result(), world) < 1e-15);
    g->setValue(g->plug("n.weight"), 0.5);
    CHECK(maxDiff(result(), frame(rotation(pi / 4, Eigen::Vector3d::UnitX()) * in.topLeftCorner<3, 3>(), {1, 7, 3})) <
          1e-15);
    g->setValue(g->plug("n.weight"), 0.0);
    CHECK(rig::bitEqual(rig::Value(result()), rig::Value(in)));
}

TEST_CASE("blendClips: slerp midpoints the shorter way, translations and stretch linear, ends exact")
{
    auto g = single("blendClips");
    const Eigen::Matrix4d a0 = frame(Eigen::Matrix3d::Identity(), {0, 0, 0});
    const Eigen::Matrix4d b0 = frame(rotation(pi / 2, Eigen::Vector3d::UnitZ()), {10, 0, 0});
    const Eigen::Matrix4d a1 = frame(rotation(0.1, Eigen::Vector3d::UnitY()), {0, 5, 0});
    // 270 degrees about Y from a1 is -90: the shorter way round passes through -45 degrees from a1.
    const Eigen::Matrix4d b1 = frame(rotation(0.1 + 1.5 * pi, Eigen::Vector3d::UnitY()) * 3.0, {0, 5, 4});
    g->setValue(g->plug("n.inMatrixA[0]"), a0);
    g->setValue(g->plug("n.inMatrixB[0]"), b0);
    g->setValue(g->plug("n.inMatrixA[1]"), a1);
    g->setValue(g->plug("n.inMatrixB[1]"), b1);
    auto result = [&](int j) {
        return std::get<Eigen::Matrix4d>(g->getValue(g->plug(fmt::format("n.outMatrix[{}]", j))));
    };
    g->setValue(g->plug("n.weight"), 0.5);
    CHECK(maxDiff(result(0), frame(rotation(pi / 4, Eigen::Vector3d::UnitZ()), {5, 0, 0})) < 1e-15);
    CHECK(maxDiff(result(1), frame(rotation(0.1 - pi / 4, Eigen::Vector3d::UnitY()) * 2.0, {0, 5, 2})) < 1e-14);
    g->setValue(g->plug("n.weight"), 0.0);
    CHECK(rig::bitEqual(rig::Value(result(0)), rig::Value(a0)));
    CHECK(rig::bitEqual(rig::Value(result(1)), rig::Value(a1)));
    g->setValue(g->plug("n.weight"), 1.0);
    CHECK(rig::bitEqual(rig::Value(result(0)), rig::Value(b0)));
    CHECK(rig::bitEqual(rig::Value(result(1)), rig::Value(b1)));
}

TEST_CASE("a clip through lookAt: the example graph evaluates, its arm follows, serial equals parallel bit for bit")
{
    const auto file = rig::test::sourceDir() / "rigs/examples/clip_lookat.yaml";
    auto serial = rig::loadGraphFile(file, rig::makeBuiltinRegistry());
    auto parallel = serial->instance();
    parallel->setThreads(2);
    std::vector<rig::Plug> plugs;
    for (int k = 0; k < 4; ++k) {
        plugs.push_back(serial->plug(fmt::format("look.outMatrix[{}]", k)));
        plugs.push_back(serial->plug(fmt::format("look.turn[{}]", k)));
    }
    plugs.push_back(serial->plug("left_shoulder.matrixSum"));
    bool turned = false;
    for (double frame : {1.0, 37.5, 80.0, 120.0}) {
        CAPTURE(frame);
        serial->setTime(frame);
        parallel->setTime(frame);
        serial->evaluate(plugs);
        parallel->evaluate(plugs);
        for (const rig::Plug& p : plugs) CHECK(rig::bitEqual(serial->getValue(p), parallel->getValue(p)));
        const std::vector<double> limit{15, 15, 30};
        for (int k = 0; k < 3; ++k) {
            const double t = std::get<double>(serial->getValue(plugs[static_cast<std::size_t>(2 * k + 1)]));
            CHECK(t <= deg(limit[static_cast<std::size_t>(k)]) + 1e-12);
            turned |= t > deg(1.0);
        }
        // The arm under Spine1 turns with it.
        const auto spineIn = std::get<Eigen::Matrix4d>(serial->getValue(serial->plug("clip.worldMatrix[13]")));
        const auto armIn = std::get<Eigen::Matrix4d>(serial->getValue(serial->plug("clip.worldMatrix[17]")));
        const auto spineOut = std::get<Eigen::Matrix4d>(serial->getValue(plugs[0]));
        const auto armOut = std::get<Eigen::Matrix4d>(serial->getValue(plugs.back()));
        CHECK(maxDiff(spineOut.inverse() * armOut, spineIn.inverse() * armIn) < 1e-12);
    }
    CHECK(turned);
    // graph-eval prints the same with one thread and two.
    const std::string command =
        rig::test::tool("graph-eval") + " rigs/examples/clip_lookat.yaml --frames 1:120:17 --get 'look.outMatrix[*]'";
    const auto one = rig::test::run(command + " --threads 1");
    const auto two = rig::test::run(command + " --threads 2");
    CHECK(one.exitCode == 0);
    CHECK(one.err == "");
    CHECK(one.out.find("look.outMatrix[3]") != std::string::npos);
    CHECK(one.out == two.out);
}

TEST_CASE("clip -> lookAt -> rigInversion: the real biped's head looks at the target, one thread or two")
{
    if (!std::filesystem::exists(rig::test::cmuClip)) return;
    // The example with its files named from the source folder and the approximation learned for this run.
    const auto source = rig::test::sourceDir();
    std::string text = rig::test::readFile(source / "rigs/examples/biped_lookat.yaml");
    auto replace = [&](const std::string& from, const std::string& to) {
        const auto at = text.find(from);
        REQUIRE(at != std::string::npos);
        text.replace(at, from.size(), to);
    };
    replace("../biped.yaml", (source / "rigs/biped.yaml").string());
    replace("../../build/biped.approx.yaml", rig::test::bipedApproximation().string());
    replace("../maps/cmu_to_biped_lookat.yaml", (source / "rigs/maps/cmu_to_biped_lookat.yaml").string());
    const auto rig = rig::test::writeFile(rig::test::scratchDir("biped_lookat") / "biped_lookat.yaml", text);
    const std::string command = fmt::format(
        "{} {} --frames 1:120:7 --get 'look.outMatrix[3]' --get Head.worldMatrix "
        "--get target.translate --get 'inverter.value[*]'",
        rig::test::tool("graph-eval"), rig.string());
    const auto one = rig::test::run(command + " --threads 1");
    const auto two = rig::test::run(command + " --threads 2");
    INFO(one.err);
    REQUIRE(one.exitCode == 0);
    CHECK(one.out == two.out);
    // Per frame: the edited head aims exactly at the target (no limit reached on this path), and the
    // biped's head, inverted from it, within 0.1 degrees (targets in the clip's units, the biped in cm).
    const double scale = 5.644444444444445;  // rigs/maps/cmu_to_biped_lookat.yaml
    const YAML::Node frames = YAML::Load(one.out);
    REQUIRE(frames.size() == 18);
    auto matrix = [](const YAML::Node& rows) {
        Eigen::Matrix4d m;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m(r, c) = rows[r][c].as<double>();
        return m;
    };
    for (const YAML::Node& f : frames) {
        CAPTURE(f["frame"].as<double>());
        const Eigen::Matrix4d edited = matrix(f["look.outMatrix[3]"]);
        const Eigen::Matrix4d head = matrix(f["Head.worldMatrix"]);
        const Eigen::Vector3d target(f["target.translate"][0].as<double>(), f["target.translate"][1].as<double>(),
                                     f["target.translate"][2].as<double>());
        CHECK(angleBetween(aimOf(edited), target - edited.topRightCorner<3, 1>()) < 1e-6);
        CHECK(angleBetween(aimOf(head), scale * target - head.topRightCorner<3, 1>()) < deg(0.1));
    }
}

TEST_CASE("skeleton edits: bad inputs give one line naming the node and attribute")
{
    const Eigen::Matrix4d j = Eigen::Matrix4d::Identity();
    auto g = lookAt({j, j, j}, {0, 0, 10});
    g->setValue(g->plug("n.share"), std::vector<double>{0.5, 1.0});
    CHECK(errorOf(*g) ==
          "n.share has 2 numbers but the chain has 3 joints (inMatrix elements); give one number per joint, root "
          "first, or none");
    g->setValue(g->plug("n.share"), std::vector<double>{0.5, 1.5, 1.0});
    CHECK(errorOf(*g) ==
          "n.share[1] is 1.5; a share is the fraction of the remaining turn the joint takes, from 0 to 1");
    g->setValue(g->plug("n.share"), std::vector<double>{});
    g->setValue(g->plug("n.limit"), std::vector<double>{10, -5, 30});
    CHECK(errorOf(*g) == "n.limit[1] is -5 degrees; a limit is the largest angle the joint may turn, 0 or more");
    g->setValue(g->plug("n.limit"), std::vector<double>{10});
    CHECK(errorOf(*g) ==
          "n.limit has 1 numbers but the chain has 3 joints (inMatrix elements); give one number per joint, root "
          "first, or none");

    auto b = single("blendClips");
    b->setValue(b->plug("n.inMatrixA[0]"), j);
    b->setValue(b->plug("n.inMatrixB[0]"), j);
    b->setValue(b->plug("n.inMatrixB[1]"), j);
    CHECK(errorOf(*b) ==
          "n.inMatrixB[1] has no inMatrixA[1]; connect the same joints of both clips, at the same indices");
}

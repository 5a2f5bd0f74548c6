// ikHandle through a Graph, on the rigs of docs/ik-and-deformers.md loaded verbatim: the end joint
// reaches reachable goals, the mid joint lies in the pole vector's plane on its side, twist turns that
// plane, stretch and soft IK follow their formulas, unreachable goals straighten the chain towards the
// goal, degenerate inputs stay finite, the IK/FK switch, and checked mode.

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/transform_math.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

// The YAML block after the line `<!-- snippet: NAME -->` of docs/ik-and-deformers.md.
std::string docSnippet(const std::string& name)
{
    std::ifstream in(rig::test::sourceDir() / "docs" / "ik-and-deformers.md");
    std::stringstream text;
    text << in.rdbuf();
    const std::string doc = text.str();
    const std::string marker = fmt::format("<!-- snippet: {} -->", name);
    const auto at = doc.find(marker);
    REQUIRE_MESSAGE(at != std::string::npos, "no snippet " << name);
    const auto open = doc.find("```yaml\n", at);
    REQUIRE(open != std::string::npos);
    const auto begin = open + 8;
    const auto close = doc.find("```", begin);
    REQUIRE(close != std::string::npos);
    return doc.substr(begin, close - begin);
}

struct Rig {
    std::unique_ptr<rig::Graph> graph;

    explicit Rig(const std::string& snippet)
        : graph(rig::loadGraphText(docSnippet(snippet), "t.yaml", rig::makeBuiltinRegistry()))
    {
    }
    void set(const std::string& path, const rig::Value& value) { graph->setValue(graph->plug(path), value); }
    Eigen::Vector3d vec(const std::string& path)
    {
        return std::get<Eigen::Vector3d>(graph->getValue(graph->plug(path)));
    }
    Eigen::Matrix4d mat(const std::string& path)
    {
        return std::get<Eigen::Matrix4d>(graph->getValue(graph->plug(path)));
    }
    Eigen::Vector3d position(const std::string& node) { return mat(node + ".worldMatrix").topRightCorner<3, 1>(); }
    std::string check()
    {
        const std::vector<std::string> mismatches = graph->checkEvaluation();
        return fmt::format("{}", fmt::join(mismatches, ", "));
    }
};

Eigen::Vector3d v3(double x, double y, double z) { return Eigen::Vector3d(x, y, z); }

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

// The component of v perpendicular to the unit vector axis.
Eigen::Vector3d perpendicular(const Eigen::Vector3d& v, const Eigen::Vector3d& axis) { return v - v.dot(axis) * axis; }

// arm-ik: upper bone 30, lower bone 28.
constexpr double upperArm = 30.0;
constexpr double lowerArm = 28.0;

}  // namespace

TEST_CASE("ikHandle: the doc's arm rig loads and its copies match the joints at rest")
{
    Rig r("arm-ik");
    // The ikHandle's constants are the joints' values: with the goal at the rest wrist position and no
    // pole vector, the IK gives back the rest pose (rotations zero).
    auto restRig = rig::loadGraphText(R"(
nodes:
  - {name: rig_root, type: transform, translate: [0, 140, 0]}
  - {name: clavicle, type: joint, parent: rig_root, translate: [5, 0, 0]}
  - {name: shoulder, type: joint, parent: clavicle, translate: [15, 0, 0], jointOrient: [0, 0, -40], rotateOrder: xzy}
  - {name: elbow, type: joint, parent: shoulder, translate: [30, 0, 0], jointOrient: [0, 0, 10]}
  - {name: wrist, type: joint, parent: elbow, translate: [28, 0, 0]}
)",
                                      "rest.yaml", rig::makeBuiltinRegistry());
    const Eigen::Vector3d restWrist =
        std::get<Eigen::Matrix4d>(restRig->getValue(restRig->plug("wrist.worldMatrix"))).topRightCorner<3, 1>();
    const Eigen::Vector3d restElbow =
        std::get<Eigen::Matrix4d>(restRig->getValue(restRig->plug("elbow.worldMatrix"))).topRightCorner<3, 1>();
    r.set("arm_ik_ctrl.translate", restWrist);
    r.set("arm_ik.poleVector", v3(0, 0, 0));
    CHECK(near(r.vec("arm_ik.startRotate"), v3(0, 0, 0), 1e-12));
    CHECK(near(r.vec("arm_ik.midRotate"), v3(0, 0, 0), 1e-12));
    CHECK(near(r.position("wrist"), restWrist));
    CHECK(near(r.position("elbow"), restElbow));
    CHECK(r.vec("arm_ik.outMidTranslate") == v3(upperArm, 0, 0));
    CHECK(r.vec("arm_ik.outEndTranslate") == v3(lowerArm, 0, 0));
    CHECK(r.check() == "");
}

TEST_CASE("ikHandle: random reachable goals are reached, the elbow in the pole vector's plane")
{
    Rig r("arm-ik");
    std::mt19937 random(1234);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    auto direction = [&] {
        Eigen::Vector3d v;
        do v = v3(unit(random), unit(random), unit(random));
        while (v.norm() < 0.1 || v.norm() > 1.0);
        return Eigen::Vector3d(v.normalized());
    };

    // `scale`: the uniform scale of the transforms above the chain (a joint's own scale is compensated
    // below it, a transform's is not: Maya's rule), which scales the bones' world lengths.
    auto run = [&](int count, double scale) {
        const Eigen::Vector3d start = r.position("shoulder");
        for (int i = 0; i < count; ++i) {
            CAPTURE(i);
            const Eigen::Vector3d aim = direction();
            std::uniform_real_distribution<double> reach(scale * (upperArm - lowerArm + 0.01),
                                                         scale * (upperArm + lowerArm - 0.01));
            const Eigen::Vector3d goal = start + reach(random) * aim;
            Eigen::Vector3d pole = direction() * (1.0 + 50.0 * (unit(random) + 1.0));
            if (perpendicular(pole.normalized(), aim).norm() < 0.05) pole = aim.unitOrthogonal() * 10.0;
            r.set("arm_ik_ctrl.translate", goal);
            r.set("arm_ik.poleVector", pole);
            const Eigen::Vector3d elbow = r.position("elbow");
            const Eigen::Vector3d wrist = r.position("wrist");
            CHECK((wrist - goal).norm() < tolerance);
            CHECK(std::abs((elbow - start).norm() - scale * upperArm) < tolerance);
            CHECK(std::abs((wrist - elbow).norm() - scale * lowerArm) < tolerance);
            // In the plane of start, goal and start + pole, on the pole's side.
            const Eigen::Vector3d normal = aim.cross(pole).normalized();
            CHECK(std::abs((elbow - start).dot(normal)) < tolerance);
            CHECK((elbow - start).dot(perpendicular(pole, aim)) > 0.0);
            // The elbow bends about its own Z (the rest plane normal), so midRotate is about Z only.
            const Eigen::Vector3d mid = r.vec("arm_ik.midRotate");
            CHECK(std::abs(mid.x()) < 1e-12);
            CHECK(std::abs(mid.y()) < 1e-12);
        }
    };
    SUBCASE("unscaled parents") { run(300, 1.0); }
    SUBCASE("rotated, scaled and compensated parents")
    {
        // The clavicle's scale reaches the shoulder's inverseScale and the ikHandle's startInverseScale;
        // rig_root is a transform: its scale of 2 scales the whole arm.
        r.set("rig_root.rotate", v3(deg(20), deg(-35), deg(70)));
        r.set("rig_root.scale", v3(2.0, 2.0, 2.0));
        r.set("clavicle.rotate", v3(deg(5), deg(10), deg(-15)));
        r.set("clavicle.scale", v3(1.5, 0.75, 1.25));
        run(200, 2.0);
    }
}

TEST_CASE("ikHandle: twist turns the chain plane about the start-goal axis")
{
    Rig r("arm-ik");
    const Eigen::Vector3d start = r.position("shoulder");
    const Eigen::Vector3d goal = v3(40, 115, 15);
    r.set("arm_ik_ctrl.translate", goal);
    r.set("arm_ik.poleVector", v3(0.3, -0.2, -1));
    const Eigen::Vector3d aim = (goal - start).normalized();
    const Eigen::Vector3d elbow0 = r.position("elbow") - start;
    for (double twist : {30.0, -75.0, 120.0, 180.0}) {
        CAPTURE(twist);
        r.set("arm_ik.twist", deg(twist));
        const Eigen::Vector3d elbow = r.position("elbow") - start;
        CHECK(near(elbow, Eigen::AngleAxisd(deg(twist), aim) * elbow0));
        CHECK((r.position("wrist") - goal).norm() < tolerance);
    }
    // The same as turning the pole vector by the twist.
    r.set("arm_ik.twist", deg(50));
    const Eigen::Vector3d twisted = r.position("elbow");
    r.set("arm_ik.twist", 0.0);
    r.set("arm_ik.poleVector", Eigen::Vector3d(Eigen::AngleAxisd(deg(50), aim) * v3(0.3, -0.2, -1)));
    CHECK(near(r.position("elbow"), twisted));
}

TEST_CASE("ikHandle: beyond reach the chain points straight at the goal - stretch reaches it")
{
    Rig r("arm-ik");
    const Eigen::Vector3d start = r.position("shoulder");
    const Eigen::Vector3d aim = v3(0.6, -0.3, 0.5).normalized();
    const double chain = upperArm + lowerArm;
    for (double distance : {chain, chain + 1e-6, chain + 5.0, 3.0 * chain}) {
        CAPTURE(distance);
        const Eigen::Vector3d goal = start + distance * aim;
        r.set("arm_ik_ctrl.translate", goal);
        r.set("arm_ik.stretch", false);
        // At d = L exactly the elbow is only known to ~1e-7 (theta ~ sqrt(rounding of d)); beyond, exactly.
        const double elbowTolerance = distance == chain ? 1e-6 : tolerance;
        CHECK(near(r.position("elbow"), start + upperArm * aim, elbowTolerance));
        CHECK(near(r.position("wrist"), start + chain * aim));
        CHECK(r.vec("arm_ik.outMidTranslate") == v3(upperArm, 0, 0));
        CHECK(r.vec("arm_ik.outEndTranslate") == v3(lowerArm, 0, 0));

        r.set("arm_ik.stretch", true);
        const double k = distance / chain;
        CHECK((r.position("wrist") - goal).norm() < tolerance);
        CHECK(near(r.position("elbow"), start + k * upperArm * aim, elbowTolerance));
        CHECK(near(r.vec("arm_ik.outMidTranslate"), v3(k * upperArm, 0, 0)));
        CHECK(near(r.vec("arm_ik.outEndTranslate"), v3(k * lowerArm, 0, 0)));
        CHECK(r.check() == "");
    }
    // Stretch does nothing within reach.
    r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + 40.0 * aim));
    CHECK(r.vec("arm_ik.outMidTranslate") == v3(upperArm, 0, 0));
    CHECK((r.position("wrist") - (start + 40.0 * aim)).norm() < tolerance);
}

TEST_CASE("ikHandle: soft IK follows its formula")
{
    Rig r("arm-ik");
    const Eigen::Vector3d start = r.position("shoulder");
    const Eigen::Vector3d aim = v3(0.2, -0.9, 0.3).normalized();
    const double chain = upperArm + lowerArm;
    const double s = 5.0;
    r.set("arm_ik.softness", s);
    auto soft = [&](double d) {
        return d <= chain - s ? d : (chain - s) + s * (1.0 - std::exp(-(d - (chain - s)) / s));
    };
    for (double distance : {30.0, chain - s, chain - 2.0, chain, chain + 4.0, 2.0 * chain}) {
        CAPTURE(distance);
        const Eigen::Vector3d goal = start + distance * aim;
        r.set("arm_ik_ctrl.translate", goal);
        r.set("arm_ik.stretch", false);
        const double reach = soft(distance);
        CHECK(reach <= distance);
        CHECK(reach < chain);
        const Eigen::Vector3d wrist = r.position("wrist");
        CHECK(near(wrist, start + reach * aim));  // on the ray, at the soft reach
        CHECK(r.vec("arm_ik.outMidTranslate") == v3(upperArm, 0, 0));

        // Soft stretch: the bones scale by d / reach so the goal is reached with the elbow still bent.
        r.set("arm_ik.stretch", true);
        const double k = distance / reach;
        CHECK((r.position("wrist") - goal).norm() < tolerance);
        CHECK(near(r.vec("arm_ik.outMidTranslate"), v3(k * upperArm, 0, 0)));
        CHECK(near(r.vec("arm_ik.outEndTranslate"), v3(k * lowerArm, 0, 0)));
        CHECK(std::abs((r.position("elbow") - start).norm() - k * upperArm) < tolerance);
    }
    // Two values by hand: d = 58 (full length) reaches 53 + 5 (1 - e^-1); d = 53 is still exact.
    r.set("arm_ik.stretch", false);
    r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + 58.0 * aim));
    CHECK((r.position("wrist") - start).norm() == doctest::Approx(53.0 + 5.0 * (1.0 - std::exp(-1.0))).epsilon(1e-12));
    r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + 53.0 * aim));
    CHECK((r.position("wrist") - start).norm() == doctest::Approx(53.0).epsilon(1e-12));
}

TEST_CASE("ikHandle: degenerate inputs follow the documented rules and stay finite")
{
    Rig r("arm-ik");
    const Eigen::Vector3d start = r.position("shoulder");
    auto allFinite = [&] {
        for (const char* plug :
             {"arm_ik.startRotate", "arm_ik.midRotate", "arm_ik.outMidTranslate", "arm_ik.outEndTranslate"})
            if (!finite(r.vec(plug))) return false;
        return finite(r.position("wrist")) && finite(r.position("elbow"));
    };

    SUBCASE("goal at the start: the chain folds along its rest direction")
    {
        r.set("arm_ik_ctrl.translate", start);
        CHECK(allFinite());
        // Folded fully, the wrist is |30 - 28| from the start, along the rest chain's direction.
        CHECK(std::abs((r.position("wrist") - start).norm() - 2.0) < tolerance);
        CHECK(std::abs((r.position("elbow") - start).norm() - upperArm) < tolerance);
        r.set("arm_ik.stretch", true);
        r.set("arm_ik.softness", 3.0);
        CHECK(allFinite());
    }
    SUBCASE("goal closer than |L1 - L2|: fully folded towards the goal")
    {
        const Eigen::Vector3d aim = v3(1, 1, 0).normalized();
        r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + 0.5 * aim));
        CHECK(allFinite());
        CHECK(near(r.position("wrist"), start + 2.0 * aim));
    }
    SUBCASE("pole vector zero or parallel to the chain: the rest plane is kept")
    {
        const Eigen::Vector3d goal = v3(45, 100, 0);  // in the rest plane z = 0
        r.set("arm_ik_ctrl.translate", goal);
        for (const Eigen::Vector3d& pole :
             {v3(0, 0, 0), Eigen::Vector3d(goal - start), Eigen::Vector3d(start - goal)}) {
            r.set("arm_ik.poleVector", pole);
            CHECK(allFinite());
            CHECK((r.position("wrist") - goal).norm() < tolerance);
            CHECK(std::abs(r.position("elbow").z()) < tolerance);  // rest plane: the chain's XY plane
        }
        // Pole parallel and goal along the rest plane's normal: a perpendicular is picked, still finite.
        r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + v3(0, 0, 40)));
        r.set("arm_ik.poleVector", v3(0, 0, 3));
        CHECK(allFinite());
        CHECK((r.position("wrist") - (start + v3(0, 0, 40))).norm() < tolerance);
    }
    SUBCASE("a straight rest chain bends about the mid joint's Z")
    {
        r.set("arm_ik.midJointOrient", v3(0, 0, 0));
        r.set("elbow.jointOrient", v3(0, 0, 0));
        const Eigen::Vector3d goal = start + v3(20, -30, 10);
        r.set("arm_ik_ctrl.translate", goal);
        CHECK(allFinite());
        CHECK((r.position("wrist") - goal).norm() < tolerance);
        const Eigen::Vector3d mid = r.vec("arm_ik.midRotate");
        CHECK(mid.z() > 0.0);
        CHECK(std::abs(mid.x()) + std::abs(mid.y()) < 1e-12);
        r.set("arm_ik.poleVector", v3(0, 0, 0));
        CHECK(allFinite());
    }
    SUBCASE("zero-length bones and chain")
    {
        r.set("arm_ik_ctrl.translate", Eigen::Vector3d(start + v3(10, 10, 10)));
        r.set("arm_ik.endTranslate", v3(0, 0, 0));
        CHECK(allFinite());
        CHECK(near(r.vec("arm_ik.midRotate"), v3(0, 0, 0)));
        r.set("arm_ik.midTranslate", v3(0, 0, 0));
        CHECK(allFinite());
        CHECK(near(r.vec("arm_ik.startRotate"), v3(0, 0, 0)));
        r.set("arm_ik.stretch", true);
        r.set("arm_ik.softness", 2.0);
        CHECK(allFinite());
    }
    SUBCASE("singular parent and huge values")
    {
        r.set("clavicle.scale", v3(0, 1, 1));
        CHECK(allFinite());
        r.set("clavicle.scale", v3(1, 1, 1));
        r.set("arm_ik_ctrl.translate", v3(1e200, -1e200, 1e200));
        r.set("arm_ik.poleVector", v3(1e-200, 0, 1e-200));
        CHECK(allFinite());
        r.set("arm_ik.stretch", true);
        CHECK(allFinite());
        r.set("arm_ik.softness", 1e-300);
        CHECK(allFinite());
    }
    CHECK(r.check() == "");
}

TEST_CASE("ikHandle: the doc's leg with pole control, soft stretch and IK/FK switch")
{
    Rig r("leg-ik-fk");
    const Eigen::Vector3d start = r.position("thigh");
    CHECK(near(start, v3(10, 95, 0)));

    auto checkIk = [&](const Eigen::Vector3d& goal) {
        r.set("leg_ik_ctrl.translate", goal);
        const Eigen::Vector3d pole = r.position("leg_pole_ctrl");
        CHECK((r.position("ankle") - goal).norm() < tolerance);
        const Eigen::Vector3d aim = (goal - start).normalized();
        const Eigen::Vector3d knee = r.position("knee") - start;
        CHECK(std::abs(knee.dot(aim.cross(pole - start).normalized())) < tolerance);
        CHECK(knee.dot(perpendicular(pole - start, aim)) > 0.0);  // the knee points at the pole control
    };
    checkIk(v3(12, 14, 6));  // within the hard reach (87 - 2)
    CHECK(std::abs((r.position("knee") - start).norm() - 45.0) < tolerance);
    checkIk(v3(15, 9, 8));     // the soft zone, stretched by d / reach
    checkIk(v3(30, -20, 10));  // far beyond: stretched
    CHECK((r.position("knee") - start).norm() > 45.0);
    r.set("leg_pole_ctrl.translate", v3(-30, 40, 20));
    checkIk(v3(0, 30, 20));

    // FK: the switch passes the FK controls' rotations and the rest bone lengths.
    r.set("leg_settings.ikFk", 0.0);
    CHECK(near(r.vec("thigh.rotate"), v3(0, 0, deg(20))));
    CHECK(near(r.vec("knee.rotate"), v3(0, 0, deg(35))));
    CHECK(near(r.vec("knee.translate"), v3(45, 0, 0)));
    CHECK(near(r.vec("ankle.translate"), v3(42, 0, 0)));
    // Half way: the Euler angles blend linearly.
    r.set("leg_settings.ikFk", 0.5);
    const Eigen::Vector3d ikThigh = r.vec("leg_ik.startRotate");
    CHECK(near(r.vec("thigh.rotate"), 0.5 * ikThigh + 0.5 * v3(0, 0, deg(20))));
    CHECK(r.check() == "");
}

TEST_CASE("ikHandle: a hinge knee that slides (bendAxis, midSlide) reaches every pose its FK knee reaches")
{
    // Random FK poses of the doc's sliding knee (the hips turned, the thigh in any direction, the knee bent 2 to
    // 150 degrees); the IK with its goal on the FK ankle and its pole on the FK knee gives the FK joints back.
    Rig r("leg-sliding-knee");
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> angle(-60.0, 60.0), bend(2.0, 150.0);
    for (int pose = 0; pose < 200; ++pose) {
        CAPTURE(pose);
        r.set("hips.rotate", v3(deg(angle(rng)), deg(angle(rng)), deg(angle(rng))));
        r.set("hips.translate", v3(angle(rng) / 6.0, 100.0, angle(rng) / 6.0));
        r.set("thigh_fk_ctrl.rotate", v3(deg(angle(rng)), deg(angle(rng)), deg(angle(rng))));
        r.set("knee_fk_ctrl.rotateX", deg(bend(rng)));
        r.set("leg_settings.ikFk", 0.0);
        std::vector<Eigen::Matrix4d> fk;
        for (const char* joint : {"thigh", "knee", "ankle"}) fk.push_back(r.mat(std::string(joint) + ".worldMatrix"));
        r.set("leg_settings.ikFk", 1.0);
        r.set("leg_ik_ctrl.translate", Eigen::Vector3d(fk[2].topRightCorner<3, 1>()));
        r.set("leg_pole_ctrl.translate", Eigen::Vector3d(fk[1].topRightCorner<3, 1>()));
        int k = 0;
        for (const char* joint : {"thigh", "knee", "ankle"}) {
            CAPTURE(joint);
            CHECK(near(r.mat(std::string(joint) + ".worldMatrix"), fk[static_cast<std::size_t>(k++)], 1e-8));
        }
    }
    // The rest goal and pole give the rest pose; past the longest reach the chain is as straight as the hinge
    // makes it, pointing at the goal, and stretch reaches the goal.
    r.set("hips.rotate", v3(0, 0, 0));
    r.set("hips.translate", v3(0, 100, 0));
    r.set("leg_ik_ctrl.translate", v3(36, 14, 4));
    r.set("leg_pole_ctrl.translate", v3(22, 52, 54));
    CHECK(near(r.vec("thigh.rotate"), v3(0, 0, 0)));
    CHECK(near(r.vec("knee.rotate"), v3(0, 0, 0)));
    CHECK(near(r.vec("knee.translate"), v3(14, -38, 0)));
    const Eigen::Vector3d start = r.position("thigh");
    const Eigen::Vector3d far = start + 100.0 * (v3(36, 14, 4) - start).normalized();
    r.set("leg_ik_ctrl.translate", far);
    const double longest = v3(28, -76, 0).norm();
    CHECK(std::abs((r.position("ankle") - start).norm() - longest) < 1e-9);
    CHECK((r.position("ankle") - start).normalized().dot((far - start).normalized()) > 1.0 - 1e-12);
    r.set("leg_ik.stretch", true);
    CHECK((r.position("ankle") - far).norm() < 1e-9);
    // A goal nearer than any reach folds the leg to the pose whose ankle is nearest the hip; from there the pose moves
    // on continuously as the goal moves out. The sliding knee brings the ankle nearest 0.2 degrees before the complete
    // fold: a branch ending at the complete fold jumped 0.4 degrees as the goal crossed that fold's reach.
    r.set("leg_ik.stretch", false);
    const Eigen::Vector3d out = (v3(36, 14, 4) - start).normalized();
    r.set("leg_ik_ctrl.translate", Eigen::Vector3d(start + 1.0 * out));
    const double nearest = (r.position("ankle") - start).norm();
    const Eigen::Matrix4d folded = r.mat("knee.worldMatrix");
    for (const double beyond : {1e-9, 1e-7, 1e-5}) {
        CAPTURE(beyond);
        r.set("leg_ik_ctrl.translate", Eigen::Vector3d(start + (nearest + beyond) * out));
        CHECK(std::abs((r.position("ankle") - start).norm() - (nearest + beyond)) < 1e-9);
        CHECK(rig::orientationAngle(r.mat("knee.worldMatrix").block<3, 3>(0, 0), folded.block<3, 3>(0, 0)) <
              std::sqrt(beyond));
    }
    // Equal bones folded onto each other (the goal at the start, then just off it): finite, folded as far as the
    // hinge goes.
    for (const Eigen::Vector3d& goal : {start, Eigen::Vector3d(start + v3(0.01, 0, 0))}) {
        r.set("leg_ik_ctrl.translate", goal);
        for (const char* joint : {"thigh", "knee", "ankle"}) {
            CAPTURE(joint);
            CHECK(r.mat(std::string(joint) + ".worldMatrix").allFinite());
        }
    }
    CHECK(r.check() == "");
}

TEST_CASE("ikHandle: rotate orders and checked mode over every input")
{
    // Any start rotate order gives the same pose.
    Rig r("arm-ik");
    const Eigen::Vector3d goal = v3(38, 112, 18);
    r.set("arm_ik_ctrl.translate", goal);
    const Eigen::Matrix4d elbow = r.mat("elbow.worldMatrix");
    for (int order = 0; order < 6; ++order) {
        CAPTURE(order);
        r.set("arm_ik.startRotateOrder", order);
        r.set("shoulder.rotateOrder", order);
        r.set("arm_ik.midRotateOrder", order);
        r.set("elbow.rotateOrder", order);
        CHECK(near(r.mat("elbow.worldMatrix"), elbow));
        CHECK((r.position("wrist") - goal).norm() < tolerance);
        CHECK(r.check() == "");
    }

    // A lone node: every input changed in turn, checkEvaluation must find nothing.
    rig::Graph graph(rig::makeBuiltinRegistry());
    const rig::NodeId node = graph.addNode("ikHandle", "ik");
    graph.setValue(graph.plug("ik.midTranslate"), v3(30, 0, 0));
    graph.setValue(graph.plug("ik.endTranslate"), v3(25, 3, 0));
    Eigen::Matrix4d goalMatrix = Eigen::Matrix4d::Identity();
    goalMatrix.col(3) << 60, 10, 5, 1;
    graph.setValue(graph.plug("ik.goalMatrix"), goalMatrix);  // beyond reach: stretch matters
    const auto& specs = graph.attributes(node);
    for (int pass = 0; pass < 3; ++pass) {
        for (std::size_t a = 0; a < specs.size(); ++a) {
            const rig::AttributeSpec& spec = specs[a];
            if (!spec.input) continue;
            CAPTURE(spec.name);
            const rig::Plug plug{node, static_cast<rig::AttrId>(a), -1, -1};
            const double k = 1.0 + pass;
            switch (spec.type) {
                case rig::ValueType::Enum:  // rotate orders have 6 values, midSlideAxis 3
                    graph.setValue(plug, (pass * 2 + 1) % (spec.name == "midSlideAxis" ? 3 : 6));
                    break;
                case rig::ValueType::Bool:
                    graph.setValue(plug, pass != 1);
                    break;
                case rig::ValueType::Double:
                    graph.setValue(plug, 0.7 * k);
                    break;
                case rig::ValueType::Vector3: {
                    Eigen::Vector3d v = std::get<Eigen::Vector3d>(graph.getValue(plug)) + v3(0.3, -0.2, 0.5) * k;
                    graph.setValue(plug, v);
                    break;
                }
                case rig::ValueType::Matrix4: {
                    Eigen::Matrix4d m = std::get<Eigen::Matrix4d>(graph.getValue(plug));
                    m.topLeftCorner<3, 3>() =
                        Eigen::AngleAxisd(0.3 * k, v3(1, 2, -0.5).normalized()).toRotationMatrix();
                    m(0, 3) += 2.0 * k;
                    graph.setValue(plug, m);
                    break;
                }
                default:
                    FAIL("unexpected attribute type");
            }
            CHECK(graph.checkEvaluation().empty());
        }
    }
}

// mayaIkHandle (Maya's ikHandle, ikRPsolver and ikSCsolver) on chains of joint nodes wired by hand: the effector
// reaches reachable goals, the mid joint lies in the pole vector's plane on its side, twist turns that plane,
// unreachable goals straighten the chain toward the goal, the reference pose is a fixed point, ikBlend, the
// handle's frame (goal at its rotate pivot, pole in its parent's space), degenerate inputs, random chains.

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "graph/graph.h"
#include "nodes/builtin_nodes.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

// A chain of joints j0 .. jn (jn the end joint, under which Maya's effector sits) and the handle h driving
// j0 .. j(n-1). Every joint value is given to the handle as the constant the loader would set.
struct ChainSpec {
    std::vector<Eigen::Vector3d> translate;                                     // n + 1: the end joint's translate last
    std::vector<Eigen::Vector3d> rotate, orient, rotateAxis, scale, preferred;  // n
    std::vector<int> order;                                                     // n
    int bones() const { return static_cast<int>(translate.size()) - 1; }
};

ChainSpec straightSpec(int bones, double length)
{
    ChainSpec s;
    s.translate.assign(static_cast<std::size_t>(bones) + 1, Eigen::Vector3d(length, 0, 0));
    s.translate[0].setZero();
    const auto n = static_cast<std::size_t>(bones);
    s.rotate = s.orient = s.rotateAxis = s.preferred = std::vector<Eigen::Vector3d>(n, Eigen::Vector3d::Zero());
    s.scale.assign(n, Eigen::Vector3d::Ones());
    s.order.assign(n, 0);
    return s;
}

class TestChain {
public:
    explicit TestChain(const ChainSpec& spec) : spec_(spec), graph_(rig::makeBuiltinRegistry())
    {
        const int n = spec.bones();
        for (int i = 0; i <= n; ++i) {
            const std::string j = fmt::format("j{}", i);
            graph_.addNode("joint", j);
            set(j + ".translate", spec.translate[static_cast<std::size_t>(i)]);
            if (i > 0) {
                graph_.connect(graph_.plug(fmt::format("j{}.worldMatrix", i - 1)), graph_.plug(j + ".parentMatrix"));
                graph_.connect(graph_.plug(fmt::format("j{}.scale", i - 1)), graph_.plug(j + ".inverseScale"));
            }
        }
        graph_.addNode("mayaIkHandle", "h");
        for (int i = 0; i < n; ++i) {
            const auto k = static_cast<std::size_t>(i);
            const std::string j = fmt::format("j{}", i);
            set(j + ".jointOrient", spec.orient[k]);
            set(j + ".rotateAxis", spec.rotateAxis[k]);
            set(j + ".scale", spec.scale[k]);
            graph_.setValue(graph_.plug(j + ".rotateOrder"), spec.order[k]);
            const std::string e = fmt::format("[{}]", i);
            set("h.jointTranslate" + e, spec.translate[k]);
            set("h.jointRotate" + e, spec.rotate[k]);
            set("h.jointOrient" + e, spec.orient[k]);
            set("h.jointRotateAxis" + e, spec.rotateAxis[k]);
            set("h.jointScale" + e, spec.scale[k]);
            set("h.jointPreferredAngle" + e, spec.preferred[k]);
            graph_.setValue(graph_.plug("h.jointRotateOrder" + e), spec.order[k]);
            graph_.connect(graph_.plug("h.outRotate" + e), graph_.plug(j + ".rotate"));
        }
        set("h.effectorTranslate", spec.translate.back());
    }

    void set(const std::string& path, const rig::Value& value) { graph_.setValue(graph_.plug(path), value); }
    rig::Graph& graph() { return graph_; }
    int bones() const { return spec_.bones(); }

    Eigen::Matrix4d world(int joint)
    {
        return std::get<Eigen::Matrix4d>(graph_.getValue(graph_.plug(fmt::format("j{}.worldMatrix", joint))));
    }
    Eigen::Vector3d position(int joint) { return world(joint).topRightCorner<3, 1>(); }
    Eigen::Vector3d effector() { return position(bones()); }
    Eigen::Vector3d out(int joint)
    {
        return std::get<Eigen::Vector3d>(graph_.getValue(graph_.plug(fmt::format("h.outRotate[{}]", joint))));
    }
    // outRotate[i] as a rotation against jointRotate[i].
    double angleFromReference(int joint)
    {
        const auto k = static_cast<std::size_t>(joint);
        const auto order = *rig::rotateOrderFromIndex(spec_.order[k]);
        return rig::orientationAngle(rig::eulerToMatrix(out(joint), order), rig::eulerToMatrix(spec_.rotate[k], order));
    }
    // The handle turned as the effector is in the reference pose (the last chain joint's world orientation), as
    // Maya's handle tool leaves it: an ikSCsolver's chain then keeps its reference twist.
    void orientHandleAtReference()
    {
        blend(0.0);
        const Eigen::Matrix3d r = rig::polarRotation(world(bones() - 1).topLeftCorner<3, 3>());
        blend(1.0);
        set("h.rotate", rig::matrixToEuler(r, rig::RotateOrder::xyz));
    }
    void goal(const Eigen::Vector3d& p) { set("h.translate", p); }
    void pole(const Eigen::Vector3d& v) { set("h.poleVector", v); }
    void solver(int type) { graph_.setValue(graph_.plug("h.solverType"), type); }
    void blend(double w) { set("h.ikBlend", w); }

    // The pose FK gives (ikBlend 0): joint positions and the effector.
    std::vector<Eigen::Vector3d> referencePositions()
    {
        blend(0.0);
        std::vector<Eigen::Vector3d> p;
        for (int i = 0; i <= bones(); ++i) p.push_back(position(i));
        blend(1.0);
        return p;
    }

private:
    ChainSpec spec_;
    rig::Graph graph_;
};

// Signed angle from a to b about unit axis, both taken perpendicular to it.
double angleAbout(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& axis)
{
    const Eigen::Vector3d pa = a - a.dot(axis) * axis, pb = b - b.dot(axis) * axis;
    return std::atan2(pa.cross(pb).dot(axis), pa.dot(pb));
}

Eigen::Vector3d randomUnit(std::mt19937& rng)
{
    std::normal_distribution<double> normal;
    return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

Eigen::Vector3d randomAngles(std::mt19937& rng, double maxDegrees)
{
    std::uniform_real_distribution<double> u(-deg(maxDegrees), deg(maxDegrees));
    return {u(rng), u(rng), u(rng)};
}

// A random chain: bones of 2 to 12 cm in random directions, random rotates, joint orients, rotate axes and rotate
// orders; `planar` keeps every bone in the XY plane with rotations about Z (a chain with one plane).
ChainSpec randomSpec(std::mt19937& rng, int bones, bool planar)
{
    std::uniform_real_distribution<double> length(2.0, 12.0), angle(-deg(80), deg(80));
    std::uniform_int_distribution<int> order(0, 5);
    ChainSpec s = straightSpec(bones, 1.0);
    s.translate[0] = Eigen::Vector3d(1.5, -2.0, 0.5);
    for (int i = 0; i < bones; ++i) {
        const auto k = static_cast<std::size_t>(i);
        if (planar) {
            s.translate[k + 1] = length(rng) * Eigen::Vector3d(std::cos(angle(rng)), std::sin(angle(rng)) * 0.5, 0.0);
            s.rotate[k] = Eigen::Vector3d(0, 0, angle(rng));
            s.orient[k] = Eigen::Vector3d(0, 0, angle(rng));
        } else {
            s.translate[k + 1] = length(rng) * randomUnit(rng);
            s.rotate[k] = randomAngles(rng, 170);
            s.orient[k] = randomAngles(rng, 90);
            s.rotateAxis[k] = randomAngles(rng, 30);
            s.order[k] = order(rng);
        }
    }
    if (planar) s.orient[0] = Eigen::Vector3d(0, 0, 0.3);
    return s;
}

// The sum of the joints' offsets from the start, perpendicular to start->goal: the chain's side (mayaIkHandle's
// plane vector; for two bones the mid joint's).
Eigen::Vector3d chainSide(const std::vector<Eigen::Vector3d>& p, const Eigen::Vector3d& goal)
{
    const Eigen::Vector3d h = (goal - p[0]).normalized();
    Eigen::Vector3d side = Eigen::Vector3d::Zero();
    for (std::size_t k = 1; k + 1 < p.size(); ++k) side += p[k] - p[0];
    return side - side.dot(h) * h;
}

}  // namespace

TEST_CASE("maya ik: two-bone rotate plane reaches the goal with the mid joint on the pole vector's side")
{
    std::mt19937 rng(7);
    ChainSpec spec = straightSpec(2, 10.0);
    spec.rotate[1] = Eigen::Vector3d(0, 0, deg(30));
    TestChain chain(spec);
    std::uniform_real_distribution<double> reach(1.0, 19.5);
    for (int trial = 0; trial < 50; ++trial) {
        const Eigen::Vector3d goal = reach(rng) * randomUnit(rng);
        const Eigen::Vector3d pole = randomUnit(rng);
        chain.goal(goal);
        chain.pole(pole);
        CHECK((chain.effector() - goal).norm() < tolerance);
        const Eigen::Vector3d start = chain.position(0), mid = chain.position(1), h = (goal - start).normalized();
        // In the plane of start, goal and start + pole, on the pole's side of the start->goal line.
        CHECK(std::abs((mid - start).dot(h.cross(pole).normalized())) < tolerance);
        CHECK(std::abs(angleAbout(mid - start, pole, h)) < 1e-9);
        // Twist turns that plane about start->goal by its angle.
        chain.set("h.twist", deg(40));
        CHECK((chain.effector() - goal).norm() < tolerance);
        CHECK(angleAbout(pole, chain.position(1) - start, h) == doctest::Approx(deg(40)).epsilon(1e-9));
        chain.set("h.twist", 0.0);
    }
}

TEST_CASE("maya ik: an unreachable goal straightens the chain toward it")
{
    for (int bones : {1, 2, 3, 4}) {
        CAPTURE(bones);
        std::mt19937 rng(static_cast<unsigned>(bones));
        ChainSpec spec = randomSpec(rng, bones, true);
        TestChain chain(spec);
        double length = 0.0;
        for (int i = 1; i <= bones; ++i) length += spec.translate[static_cast<std::size_t>(i)].norm();
        const Eigen::Vector3d start = chain.referencePositions()[0];
        const Eigen::Vector3d direction = Eigen::Vector3d(0.3, -1.0, 0.2).normalized();
        chain.goal(start + 3.0 * length * direction);
        if (bones == 1) {  // one bone straight toward the goal: aims
            CHECK((chain.effector() - start).normalized().dot(direction) == doctest::Approx(1.0).epsilon(1e-12));
            continue;
        }
        CHECK((chain.effector() - (start + length * direction)).norm() < 1e-6);
        for (int i = 1; i < bones; ++i) CHECK(((chain.position(i) - start).cross(direction)).norm() < 1e-6);
    }
}

TEST_CASE("maya ik: the reference pose is a fixed point")
{
    std::mt19937 rng(11);
    for (int trial = 0; trial < 40; ++trial) {
        const int bones = 1 + trial % 4;
        const bool singleChain = bones == 1 || trial % 3 == 0;
        CAPTURE(trial);
        // Rotate plane past two bones: a planar chain (its plane is the one the pole must lie in).
        const ChainSpec spec = randomSpec(rng, bones, !singleChain && bones > 2);
        TestChain chain(spec);
        chain.solver(singleChain ? 1 : 0);
        const std::vector<Eigen::Vector3d> p = chain.referencePositions();
        chain.goal(p.back());
        if (!singleChain) chain.pole(chainSide(p, p.back()) * 3.7);
        if (singleChain) chain.orientHandleAtReference();
        for (int i = 0; i < bones; ++i) CHECK(chain.angleFromReference(i) < tolerance);
    }
}

TEST_CASE("maya ik: rotate orders, joint orients and rotate axes: random chains reach every reachable goal")
{
    std::mt19937 rng(2024);
    for (int trial = 0; trial < 120; ++trial) {
        const int bones = 1 + trial % 5;
        const bool singleChain = trial % 2 == 1;
        CAPTURE(trial);
        const ChainSpec spec = randomSpec(rng, bones, false);
        TestChain chain(spec);
        chain.solver(singleChain ? 1 : 0);
        chain.pole(randomUnit(rng));
        chain.set("h.twist", deg(25.0 * (trial % 3)));
        const std::vector<Eigen::Vector3d> p = chain.referencePositions();
        double length = 0.0;
        for (std::size_t k = 1; k < p.size(); ++k) length += (p[k] - p[k - 1]).norm();
        const double current = (p.back() - p[0]).norm();
        // Reachable: the distances from the current one to the straight chain's; two bones fold down to |l1 - l2|.
        double nearest = current;
        if (bones == 2) nearest = std::abs((p[1] - p[0]).norm() - (p[2] - p[1]).norm()) + 0.01;
        if (bones == 1) nearest = length = current;
        const double distance =
            std::uniform_real_distribution<double>(nearest, nearest + 0.98 * (length - nearest))(rng);
        const Eigen::Vector3d goal = p[0] + distance * randomUnit(rng);
        chain.goal(goal);
        CHECK((chain.effector() - goal).norm() < tolerance * std::max(1.0, length));
        for (int i = 0; i < bones; ++i) CHECK(chain.out(i).allFinite());
    }
}

TEST_CASE("maya ik: the rotate plane past two bones puts the chain's side on the pole vector's")
{
    std::mt19937 rng(5);
    for (int bones : {3, 4, 5}) {
        const ChainSpec spec = randomSpec(rng, bones, true);
        TestChain chain(spec);
        const std::vector<Eigen::Vector3d> p = chain.referencePositions();
        double length = 0.0;
        for (std::size_t k = 1; k < p.size(); ++k) length += (p[k] - p[k - 1]).norm();
        const double current = (p.back() - p[0]).norm();
        const Eigen::Vector3d goal =
            p[0] + (current + 0.5 * (length - current)) * Eigen::Vector3d(0.3, 0.5, 0.8).normalized();
        const Eigen::Vector3d pole(0.2, 0.4, -1.0);
        chain.goal(goal);
        chain.pole(pole);
        CHECK((chain.effector() - goal).norm() < tolerance * 10);
        std::vector<Eigen::Vector3d> q;
        for (int i = 0; i <= bones; ++i) q.push_back(chain.position(i));
        CHECK(std::abs(angleAbout(chainSide(q, goal), pole, (goal - q[0]).normalized())) < 1e-9);
    }
}

TEST_CASE("maya ik: ikBlend 0 gives the FK rotates, between slerps each joint")
{
    std::mt19937 rng(3);
    const ChainSpec spec = randomSpec(rng, 2, false);
    TestChain chain(spec);
    chain.goal(Eigen::Vector3d(4, 3, -2));
    chain.pole(Eigen::Vector3d(0, 0, 1));
    std::vector<Eigen::Matrix3d> ik;
    for (int i = 0; i < 2; ++i)
        ik.push_back(
            rig::eulerToMatrix(chain.out(i), *rig::rotateOrderFromIndex(spec.order[static_cast<std::size_t>(i)])));
    chain.blend(0.0);
    for (int i = 0; i < 2; ++i) CHECK((chain.out(i) - spec.rotate[static_cast<std::size_t>(i)]).norm() < 1e-12);
    chain.blend(0.25);
    for (int i = 0; i < 2; ++i) {
        const auto k = static_cast<std::size_t>(i);
        const auto order = *rig::rotateOrderFromIndex(spec.order[k]);
        const Eigen::Quaterniond fk(rig::eulerToMatrix(spec.rotate[k], order));
        const Eigen::Matrix3d expected = fk.slerp(0.25, Eigen::Quaterniond(ik[k])).toRotationMatrix();
        CHECK(rig::orientationAngle(rig::eulerToMatrix(chain.out(i), order), expected) < tolerance);
        // The Euler triple nearest the FK one.
        CHECK((chain.out(i) - spec.rotate[k]).cwiseAbs().maxCoeff() < pi);
    }
}

TEST_CASE("maya ik: a one-bone single-chain handle aims the effector, then turns it about the aim toward the handle")
{
    ChainSpec spec = straightSpec(1, 5.0);
    spec.orient[0] = Eigen::Vector3d(deg(10), deg(20), deg(-30));
    TestChain chain(spec);
    chain.solver(1);
    const std::vector<Eigen::Vector3d> p = chain.referencePositions();
    const Eigen::Vector3d target(1, 7, 3);
    const Eigen::Vector3d handleTurn(deg(40), deg(-15), deg(70));
    chain.set("h.rotate", handleTurn);
    chain.goal(target);
    const Eigen::Vector3d aim = (target - p[0]).normalized();
    CHECK((chain.effector() - p[0]).normalized().dot(aim) == doctest::Approx(1.0).epsilon(1e-14));
    // The closest a turn about the aim can come: what still parts the effector's orientation from the handle's has
    // no twist about the aim (swing-twist), whatever the turn the handle was given.
    const Eigen::Matrix3d handle = rig::eulerToMatrix(handleTurn, rig::RotateOrder::xyz);
    const Eigen::Quaterniond apart(Eigen::Matrix3d(handle * chain.world(0).topLeftCorner<3, 3>().transpose()));
    CHECK(std::abs(apart.vec().dot(aim)) < 1e-12);
}

TEST_CASE("maya ik: the goal is the handle's rotate pivot in world space, the pole vector in its parent's space")
{
    ChainSpec spec = straightSpec(2, 10.0);
    spec.rotate[1] = Eigen::Vector3d(0, 0, deg(45));
    TestChain chain(spec);
    Eigen::Matrix4d parent = Eigen::Matrix4d::Identity();
    parent.topLeftCorner<3, 3>() = Eigen::AngleAxisd(deg(90), Eigen::Vector3d::UnitX()).toRotationMatrix();
    parent.topRightCorner<3, 1>() = Eigen::Vector3d(1, 2, 3);
    chain.set("h.parentMatrix", parent);
    chain.set("h.translate", Eigen::Vector3d(2, 1, -4));
    chain.set("h.rotatePivot", Eigen::Vector3d(1, 1, 0));
    chain.set("h.rotatePivotTranslate", Eigen::Vector3d(0.5, 0, 0));
    chain.set("h.rotate", Eigen::Vector3d(0.3, 0.2, 0.1));  // turns the handle, not the goal
    chain.pole(Eigen::Vector3d(0, 1, 0));                   // world +Z through the parent
    const Eigen::Vector3d goal = (parent * Eigen::Vector4d(3.5, 2, -4, 1)).head<3>();
    CHECK((chain.effector() - goal).norm() < tolerance);
    const Eigen::Vector3d h = goal.normalized();
    CHECK(std::abs(angleAbout(chain.position(1), Eigen::Vector3d::UnitZ(), h)) < 1e-9);
    const auto world = std::get<Eigen::Matrix4d>(chain.graph().getValue(chain.graph().plug("h.worldMatrix")));
    const auto local = std::get<Eigen::Matrix4d>(chain.graph().getValue(chain.graph().plug("h.matrix")));
    CHECK((world - parent * local).norm() < 1e-12);
}

TEST_CASE("maya ik: a straight chain bends as its preferred angles do")
{
    ChainSpec spec = straightSpec(2, 10.0);
    spec.preferred[1] = Eigen::Vector3d(0, 0, deg(20));  // the knee bends toward +Y
    TestChain chain(spec);
    chain.pole(Eigen::Vector3d(0, 1, 0));
    chain.solver(1);  // single chain: the plane is the preferred one
    chain.goal(Eigen::Vector3d(12, 0, 0));
    CHECK((chain.effector() - Eigen::Vector3d(12, 0, 0)).norm() < tolerance);
    CHECK(chain.position(1).y() < -1.0);  // the end swung up to the goal's line, the knee below it
    CHECK(std::abs(chain.position(1).z()) < tolerance);
}

TEST_CASE("maya ik: degenerate inputs stay finite")
{
    for (int bones : {1, 2, 3}) {
        CAPTURE(bones);
        ChainSpec spec = straightSpec(bones, 5.0);
        if (bones > 1) spec.translate[1].setZero();  // a zero-length bone
        TestChain chain(spec);
        const auto finite = [&] {
            for (int i = 0; i < bones; ++i) CHECK(chain.out(i).allFinite());
        };
        chain.goal(Eigen::Vector3d::Zero());  // at the start joint
        finite();
        chain.goal(Eigen::Vector3d(3, 0, 0));
        chain.pole(Eigen::Vector3d(2, 0, 0));  // parallel to start->goal
        finite();
        chain.pole(Eigen::Vector3d::Zero());
        finite();
        chain.goal(Eigen::Vector3d(1e200, -1e200, 1e200));
        finite();
        chain.goal(Eigen::Vector3d(-7, 0, 0));  // straight behind
        finite();
    }
}

TEST_CASE("maya ik: checked mode finds every input's effect declared")
{
    std::mt19937 rng(9);
    TestChain chain(randomSpec(rng, 3, false));
    chain.goal(Eigen::Vector3d(3, 4, 5));
    CHECK(chain.graph().checkEvaluation().empty());
}

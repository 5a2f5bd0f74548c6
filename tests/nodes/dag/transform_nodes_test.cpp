// transform and joint through a Graph loaded from rig text: degrees in the file, radians inside; every
// rotate order against hand-written products of elementary rotations; jointOrient, rotatePivot,
// segment scale compensation, a hand-computed chain, world inverses, and what a change recomputes.
// Expected matrices are built here from cos/sin, never by the library's matrix functions.

#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Core>

#include "core/error.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-12;

double deg(double degrees) { return degrees * pi / 180.0; }

std::unique_ptr<rig::Graph> load(const std::string& text)
{
    return rig::loadGraphText(text, "t.yaml", rig::makeBuiltinRegistry());
}

Eigen::Matrix4d mat(rig::Graph& g, const std::string& path)
{
    return std::get<Eigen::Matrix4d>(g.getValue(g.plug(path)));
}

Eigen::Vector3d vec(rig::Graph& g, const std::string& path)
{
    return std::get<Eigen::Vector3d>(g.getValue(g.plug(path)));
}

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

// Elementary rotations written out (column vectors, right-handed).
Eigen::Matrix4d rx(double a)
{
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix4d m;
    m << 1, 0, 0, 0, 0, c, -s, 0, 0, s, c, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d ry(double a)
{
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix4d m;
    m << c, 0, s, 0, 0, 1, 0, 0, -s, 0, c, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d rz(double a)
{
    const double c = std::cos(a), s = std::sin(a);
    Eigen::Matrix4d m;
    m << c, -s, 0, 0, s, c, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d translation(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 3) = x;
    m(1, 3) = y;
    m(2, 3) = z;
    return m;
}

Eigen::Matrix4d scaling(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 0) = x;
    m(1, 1) = y;
    m(2, 2) = z;
    return m;
}

Eigen::Vector4d point(double x, double y, double z) { return Eigen::Vector4d(x, y, z, 1); }

// Rotation for rotate = (a, b, c) radians in `order`: the first letter applies first, so with column
// vectors it is the rightmost factor.
Eigen::Matrix4d handRotation(const std::string& order, double a, double b, double c)
{
    const Eigen::Matrix4d x = rx(a), y = ry(b), z = rz(c);
    if (order == "xyz") return z * y * x;
    if (order == "yzx") return x * z * y;
    if (order == "zxy") return y * x * z;
    if (order == "xzy") return y * z * x;
    if (order == "yxz") return z * x * y;
    if (order == "zyx") return x * y * z;
    FAIL("unknown order " << order);
    return Eigen::Matrix4d::Identity();
}

const std::vector<std::string> orders{"xyz", "yzx", "zxy", "xzy", "yxz", "zyx"};

}  // namespace

TEST_CASE("transform nodes: joint rotate (30, 45, 60) in every rotate order")
{
    for (std::size_t index = 0; index < orders.size(); ++index) {
        const std::string& order = orders[index];
        CAPTURE(order);
        auto g = load(fmt::format(R"(
nodes:
  - {{name: j, type: joint, rotate: [30, 45, 60], rotateOrder: {0}, translate: [1, -2, 3]}}
  - {{name: t, type: transform, rotate: [30, 45, 60], rotateOrder: {0}, translate: [1, -2, 3]}}
)",
                                  order));
        // The file's degrees are radians inside; the order name is Maya's enum index.
        CHECK(near(vec(*g, "j.rotate"), Eigen::Vector3d(pi / 6, pi / 4, pi / 3)));
        CHECK(std::get<double>(g->getValue(g->plug("j.rotateZ"))) == doctest::Approx(pi / 3));
        CHECK(std::get<int>(g->getValue(g->plug("j.rotateOrder"))) == static_cast<int>(index));

        const Eigen::Matrix4d expected = translation(1, -2, 3) * handRotation(order, pi / 6, pi / 4, pi / 3);
        CHECK(near(mat(*g, "j.worldMatrix"), expected));
        CHECK(near(mat(*g, "j.matrix"), expected));
        CHECK(near(mat(*g, "t.worldMatrix"), expected));

        // Setting the order by index afterwards gives the same matrix.
        g->setValue(g->plug("j.rotateOrder"), static_cast<int>((index + 1) % orders.size()));
        g->setValue(g->plug("j.rotateOrder"), static_cast<int>(index));
        CHECK(near(mat(*g, "j.worldMatrix"), expected));
    }

    SUBCASE("a single 90 degree turn about each axis sends the axes where the right-hand rule says")
    {
        auto g = load(R"(
nodes:
  - {name: x, type: joint, rotateX: 90}
  - {name: y, type: joint, rotateY: 90}
  - {name: z, type: joint, rotateZ: 90}
)");
        CHECK(near(mat(*g, "x.worldMatrix") * point(0, 1, 0), point(0, 0, 1)));
        CHECK(near(mat(*g, "y.worldMatrix") * point(0, 0, 1), point(1, 0, 0)));
        CHECK(near(mat(*g, "z.worldMatrix") * point(1, 0, 0), point(0, 1, 0)));
    }
}

TEST_CASE("transform nodes: jointOrient applies after rotate (M = T * JO * R)")
{
    auto g = load(R"(
nodes:
  - {name: j, type: joint, translate: [1, 2, 3], jointOrient: [0, 0, 90], rotate: [90, 0, 0]}
  - {name: k, type: joint, translate: [-1, 0.5, 2], jointOrient: [10, 20, 30], rotate: [30, 45, 60], rotateOrder: yzx}
)");
    CHECK(near(vec(*g, "j.jointOrient"), Eigen::Vector3d(0, 0, pi / 2)));
    // R = Rx(90) sends +Y to +Z, then JO = Rz(90) leaves +Z alone: (0, 1, 0) -> (1, 2, 4).
    // (The other order would give (0, 2, 3).)
    CHECK(near(mat(*g, "j.worldMatrix") * point(0, 1, 0), point(1, 2, 4)));
    CHECK(near(mat(*g, "j.worldMatrix"), translation(1, 2, 3) * rz(pi / 2) * rx(pi / 2)));

    // jointOrient is always xyz: JO = Rz(30) Ry(20) Rx(10); rotate in yzx: R = Rx(30) Rz(60) Ry(45).
    const Eigen::Matrix4d expected =
        translation(-1, 0.5, 2) * rz(deg(30)) * ry(deg(20)) * rx(deg(10)) * rx(deg(30)) * rz(deg(60)) * ry(deg(45));
    CHECK(near(mat(*g, "k.worldMatrix"), expected));

    // rotateAxis sits between rotate and scale: M = T * JO * R * RA * S.
    g->setValue(g->plug("k.rotateAxis"), Eigen::Vector3d(deg(5), deg(-15), deg(25)));
    g->setValue(g->plug("k.scale"), Eigen::Vector3d(2, 0.5, 1.5));
    const Eigen::Matrix4d withAxis = expected * rz(deg(25)) * ry(deg(-15)) * rx(deg(5)) * scaling(2, 0.5, 1.5);
    CHECK(near(mat(*g, "k.worldMatrix"), withAxis));
}

TEST_CASE("transform nodes: rotatePivot keeps the pivot point fixed")
{
    auto g = load(R"(
nodes:
  - {name: p, type: transform, rotatePivot: [1, 2, 3], rotate: [30, 45, 60]}
  - {name: q, type: transform, rotatePivot: [1, 2, 3], rotate: [0, 0, 90], translate: [10, 0, 0]}
  - {name: s, type: transform, scalePivot: [1, 1, 0], scale: [2, 3, 4]}
)");
    const Eigen::Matrix4d p = mat(*g, "p.worldMatrix");
    CHECK(near(p * point(1, 2, 3), point(1, 2, 3)));
    // Any other point turns about the pivot: pivot + R * (offset).
    const Eigen::Matrix4d r = handRotation("xyz", pi / 6, pi / 4, pi / 3);
    CHECK(near(p * point(2, 2, 3), point(1, 2, 3) + r * Eigen::Vector4d(1, 0, 0, 0)));
    CHECK(near(p, translation(1, 2, 3) * r * translation(-1, -2, -3)));

    // 90 degrees about Z around (1, 2, 3), then translate (10, 0, 0).
    const Eigen::Matrix4d q = mat(*g, "q.worldMatrix");
    CHECK(near(q * point(1, 2, 3), point(11, 2, 3)));
    CHECK(near(q * point(2, 2, 3), point(11, 3, 3)));
    CHECK(near(q * point(1, 3, 0), point(10, 2, 0)));

    // Scale about the scale pivot (1, 1, 0): the pivot stays, (2, 2, 1) goes to (1 + 2, 1 + 3, 4).
    const Eigen::Matrix4d s = mat(*g, "s.worldMatrix");
    CHECK(near(s * point(1, 1, 0), point(1, 1, 0)));
    CHECK(near(s * point(2, 2, 1), point(3, 4, 4)));
}

TEST_CASE("transform nodes: segmentScaleCompensate across a parent joint")
{
    auto g = load(R"(
nodes:
  - {name: root, type: joint, scale: [2, 3, 4]}
  - {name: on, type: joint, parent: root, translate: [1, 1, 1], rotate: [0, 0, 90]}
  - {name: off, type: joint, parent: root, translate: [1, 1, 1], rotate: [0, 0, 90], segmentScaleCompensate: false}
  - {name: own, type: joint, parent: root, translate: [1, 1, 1], rotate: [0, 0, 90], scale: [5, 1, 1]}
  - {name: onTip, type: joint, parent: on, translate: [1, 0, 0]}
)");
    // parent: connects root.scale -> child.inverseScale.
    REQUIRE(g->incomingConnection(g->plug("on.inverseScale")) != nullptr);
    CHECK(g->plugName(g->incomingConnection(g->plug("on.inverseScale"))->source) == "root.scale");
    CHECK(near(vec(*g, "on.inverseScale"), Eigen::Vector3d(2, 3, 4)));

    // The parent's scale places the child (translate (1, 1, 1) -> (2, 3, 4)) in both cases.
    // On: diag(2, 3, 4) * diag(1/2, 1/3, 1/4) * Rz(90) = Rz(90), no scale reaches the child.
    Eigen::Matrix4d expectedOn = rz(pi / 2);
    expectedOn.col(3) = point(2, 3, 4);
    CHECK(near(mat(*g, "on.worldMatrix"), expectedOn));
    // Off: the parent's scale stays: diag(2, 3, 4) * Rz(90).
    Eigen::Matrix4d expectedOff = scaling(2, 3, 4) * rz(pi / 2);
    expectedOff.col(3) = point(2, 3, 4);
    CHECK(near(mat(*g, "off.worldMatrix"), expectedOff));
    // The joint's own scale is kept: Rz(90) * diag(5, 1, 1).
    Eigen::Matrix4d expectedOwn = rz(pi / 2) * scaling(5, 1, 1);
    expectedOwn.col(3) = point(2, 3, 4);
    CHECK(near(mat(*g, "own.worldMatrix"), expectedOwn));
    // The grandchild sees no scale: on's +X is world +Y, one unit up from (2, 3, 4).
    CHECK(near(mat(*g, "onTip.worldMatrix") * point(0, 0, 0), point(2, 4, 4)));

    // Changing the parent's scale flows through the connection.
    g->setValue(g->plug("root.scale"), Eigen::Vector3d(0.5, 0.5, 0.5));
    expectedOn.col(3) = point(0.5, 0.5, 0.5);
    CHECK(near(mat(*g, "on.worldMatrix"), expectedOn));
    expectedOff = scaling(0.5, 0.5, 0.5) * rz(pi / 2);
    expectedOff.col(3) = point(0.5, 0.5, 0.5);
    CHECK(near(mat(*g, "off.worldMatrix"), expectedOff));

    // Switching compensation off on "on" lets the parent's scale through.
    g->setValue(g->plug("on.segmentScaleCompensate"), false);
    CHECK(near(mat(*g, "on.worldMatrix"), expectedOff));
}

TEST_CASE("transform nodes: a three-joint chain's world positions")
{
    auto g = load(R"(
nodes:
  - {name: root, type: joint, translate: [0, 10, 0], rotateZ: 90}
  - {name: mid, type: joint, parent: root, translate: [4, 0, 0], jointOrient: [0, 0, 90], rotateX: 90}
  - {name: tip, type: joint, parent: mid, translate: [3, 2, 0]}
)");
    // root: at (0, 10, 0), turned Rz(90).
    // mid: (0, 10, 0) + Rz(90) (4, 0, 0) = (0, 14, 0); orientation Rz(90) Rz(90) Rx(90) = Rz(180) Rx(90).
    // tip: Rx(90) (3, 2, 0) = (3, 0, 2), Rz(180) -> (-3, 0, 2): at (-3, 14, 2).
    CHECK(near(mat(*g, "root.worldMatrix").col(3), point(0, 10, 0)));
    CHECK(near(mat(*g, "mid.worldMatrix").col(3), point(0, 14, 0)));
    CHECK(near(mat(*g, "tip.worldMatrix").col(3), point(-3, 14, 2)));
    Eigen::Matrix4d midWorld;
    midWorld << -1, 0, 0, 0, 0, 0, 1, 14, 0, 1, 0, 0, 0, 0, 0, 1;
    CHECK(near(mat(*g, "mid.worldMatrix"), midWorld));
    CHECK(near(mat(*g, "tip.worldMatrix").topLeftCorner<3, 3>(), midWorld.topLeftCorner<3, 3>()));
    // A local matrix does not include the parent.
    CHECK(near(mat(*g, "tip.matrix"), translation(3, 2, 0)));

    // Straightening the root: mid at (4, 10, 0), orientation Rz(90) Rx(90); tip: Rx(90) (3, 2, 0) =
    // (3, 0, 2), Rz(90) -> (0, 3, 2): at (4, 13, 2).
    g->setValue(g->plug("root.rotateZ"), 0.0);
    CHECK(near(mat(*g, "mid.worldMatrix").col(3), point(4, 10, 0)));
    CHECK(near(mat(*g, "tip.worldMatrix").col(3), point(4, 13, 2)));
}

TEST_CASE("transform nodes: worldInverseMatrix * worldMatrix = identity")
{
    auto g = load(R"(
nodes:
  - {name: root, type: transform, translate: [1, 2, 3], rotate: [10, -20, 30], scale: [2, 0.5, 3],
     shear: [0.2, 0, -0.1],
     rotatePivot: [0.5, 0, 1], scalePivot: [0, 1, 0], rotateOrder: zxy}
  - {name: a, type: joint, parent: root, translate: [4, 0, 0], rotate: [30, 45, 60], jointOrient: [0, 90, 0],
     scale: [1, 2, 1]}
  - {name: b, type: joint, parent: a, translate: [0, 5, 0], rotate: [-70, 10, 5], rotateOrder: yxz}
)");
    for (const char* n : {"root", "a", "b"}) {
        CAPTURE(n);
        const std::string name(n);
        const Eigen::Matrix4d world = mat(*g, name + ".worldMatrix");
        const Eigen::Matrix4d inverse = mat(*g, name + ".worldInverseMatrix");
        CHECK(near(inverse * world, Eigen::Matrix4d::Identity(), 1e-10));
        CHECK(near(world * inverse, Eigen::Matrix4d::Identity(), 1e-10));
        // world = parentMatrix * matrix.
        CHECK(near(world, mat(*g, name + ".parentMatrix") * mat(*g, name + ".matrix"), 1e-12));
    }
}

TEST_CASE("transform nodes: setting the root's rotate recomputes its chain only")
{
    auto g = load(R"(
nodes:
  - {name: hips, type: joint, translate: [0, 100, 0]}
  - {name: spine1, type: joint, parent: hips, translate: [0, 10, 0]}
  - {name: spine2, type: joint, parent: spine1, translate: [0, 10, 0]}
  - {name: spine3, type: joint, parent: spine2, translate: [0, 10, 0]}
  - {name: leg1, type: joint, parent: hips, translate: [10, -5, 0]}
  - {name: leg2, type: joint, parent: leg1, translate: [0, -40, 0]}
)");
    const std::vector<std::string> names{"hips", "spine1", "spine2", "spine3", "leg1", "leg2"};
    auto counts = [&] {
        std::map<std::string, std::uint64_t> c;
        for (const auto& n : names) c[n] = g->computeCount(g->node(n));
        return c;
    };
    g->evaluateAll();
    const auto first = counts();
    for (const auto& n : names) CHECK(first.at(n) == 1);
    // Nothing changed: nothing recomputes.
    g->evaluateAll();
    CHECK(counts() == first);

    // Bending spine1 by 90 degrees about Z: spine2 (10 up the spine) swings to -X.
    g->setValue(g->plug("spine1.rotate"), Eigen::Vector3d(0, 0, pi / 2));
    CHECK(near(mat(*g, "spine3.worldMatrix").col(3), point(-20, 110, 0)));
    g->evaluateAll();
    auto now = counts();
    CHECK(now.at("spine1") == 2);
    CHECK(now.at("spine2") == 2);
    CHECK(now.at("spine3") == 2);
    CHECK(now.at("hips") == 1);
    CHECK(now.at("leg1") == 1);
    CHECK(now.at("leg2") == 1);

    // The root of everything: all six recompute once.
    g->setValue(g->plug("hips.rotateY"), deg(90));
    g->evaluateAll();
    const auto after = counts();
    for (const auto& n : names) {
        CAPTURE(n);
        CHECK(after.at(n) == now.at(n) + 1);
    }
    // hips Ry(90) sends +X to -Z: leg1 at (0, 95, -10).
    CHECK(near(mat(*g, "leg1.worldMatrix").col(3), point(0, 95, -10)));
}

TEST_CASE("transform nodes: parent: from a transform to a joint does not compensate the transform's scale, as in Maya")
{
    auto g = load(R"(
nodes:
  - {name: group, type: transform, scale: [2, 2, 2]}
  - {name: child, type: joint, parent: group, translate: [1, 0, 0]}
)");
    CHECK(g->incomingConnection(g->plug("child.parentMatrix")) != nullptr);
    CHECK(g->incomingConnection(g->plug("child.inverseScale")) == nullptr);
    // The group's scale reaches the joint: placed at 2 along x, and scaled by 2.
    Eigen::Matrix4d expected = scaling(2, 2, 2);
    expected.col(3) = point(2, 0, 0);
    CHECK(near(mat(*g, "child.worldMatrix"), expected));
}

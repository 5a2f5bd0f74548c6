// The constraint node types (docs/constraints.md) through a Graph: closed-form results (weighted means,
// quaternion averages, parent spaces, joint orient removal, rigid attachment, exact aiming, pole
// vectors), the degenerate cases' documented rules, the YAML examples of docs/constraints.md loaded
// verbatim, and checked mode (complete affects tables) for every type.

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <Eigen/Geometry>

#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/transform_math.h"
#include "test_support.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

Eigen::Vector3d v3(double x, double y, double z) { return Eigen::Vector3d(x, y, z); }

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

// Rotation of `degrees` about axis 0 (X), 1 (Y) or 2 (Z).
Eigen::Matrix3d rot(int axis, double degrees)
{
    return Eigen::AngleAxisd(deg(degrees), Eigen::Vector3d::Unit(axis)).toRotationMatrix();
}

Eigen::Matrix4d trs(const Eigen::Vector3d& translate, const Eigen::Matrix3d& rotation = Eigen::Matrix3d::Identity())
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = rotation;
    m.topRightCorner<3, 1>() = translate;
    return m;
}

// The rotation part of a matrix with its column lengths removed.
Eigen::Matrix3d unscaled(const Eigen::Matrix4d& m)
{
    Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    for (int i = 0; i < 3; ++i) r.col(i).normalize();
    return r;
}

const std::vector<std::string> constraintTypes{"pointConstraint", "orientConstraint", "parentConstraint",
                                               "aimConstraint", "poleVectorConstraint"};

// The YAML block of docs/constraints.md that starts with "# example: NAME", verbatim.
std::string docExample(const std::string& name)
{
    std::ifstream in(rig::test::sourceDir() / "docs" / "constraints.md");
    std::stringstream text;
    text << in.rdbuf();
    const std::string page = text.str();
    const std::string fence = "```yaml\n";
    const auto at = page.find(fmt::format("{}# example: {}\n", fence, name));
    REQUIRE(at != std::string::npos);
    const auto from = at + fence.size();
    const auto to = page.find("```", from);
    REQUIRE(to != std::string::npos);
    return page.substr(from, to - from);
}

struct Rig {
    std::unique_ptr<rig::Graph> graph;

    Rig() : graph(std::make_unique<rig::Graph>(rig::makeBuiltinRegistry())) {}
    explicit Rig(const std::string& yaml) : graph(rig::loadGraphText(yaml, "t.yaml", rig::makeBuiltinRegistry())) {}

    void add(const std::string& type, const std::string& name) { graph->addNode(type, name); }
    void set(const std::string& path, const rig::Value& value) { graph->setValue(graph->plug(path), value); }
    void connect(const std::string& from, const std::string& to) { graph->connect(graph->plug(from), graph->plug(to)); }
    Eigen::Vector3d vec(const std::string& path)
    {
        return std::get<Eigen::Vector3d>(graph->getValue(graph->plug(path)));
    }
    Eigen::Matrix4d mat(const std::string& path)
    {
        return std::get<Eigen::Matrix4d>(graph->getValue(graph->plug(path)));
    }
    std::string check() { return fmt::format("{}", fmt::join(graph->checkEvaluation(), ", ")); }
};

}  // namespace

TEST_CASE("constraints: every type and attribute is documented")
{
    const auto registry = rig::makeBuiltinRegistry();
    for (const std::string& name : constraintTypes) {
        CAPTURE(name);
        const rig::NodeType* type = registry->find(name);
        REQUIRE(type != nullptr);
        CHECK(type->description().find("Maya") != std::string::npos);
        for (const rig::AttributeSpec& spec : type->attributes()) {
            CAPTURE(spec.name);
            CHECK_FALSE(spec.description.empty());
            if (spec.name == "targetWeight") {
                CHECK(spec.keyable);
                CHECK(spec.array);
                CHECK(std::get<double>(spec.defaultValue) == 1.0);
            }
        }
    }
}

TEST_CASE("constraints: an attribute the types share is declared alike in each (constraint_attributes.h)")
{
    const auto registry = rig::makeBuiltinRegistry();
    // Shared attributes whose description is the same in every type that has them; the others (targetMatrix,
    // offset, the rest values, constraintParentInverseMatrix, constraintTranslate) may say how a type reads them.
    const std::set<std::string> sameDescription{"targetWeight", "constraintRotateOrder", "constraintJointOrient",
                                                "constraintRotate"};
    std::map<std::string, std::vector<const rig::AttributeSpec*>> shared;
    for (const std::string& name : constraintTypes)
        for (const rig::AttributeSpec& spec : registry->find(name)->attributes()) shared[spec.name].push_back(&spec);
    for (const char* everywhere : {"targetMatrix", "targetWeight", "constraintParentInverseMatrix"})
        CHECK(shared[everywhere].size() == constraintTypes.size());
    CHECK(shared["constraintRotate"].size() == 3);
    CHECK(shared["offset"].size() == 4);
    for (const auto& [name, specs] : shared) {
        CAPTURE(name);
        const rig::AttributeSpec& first = *specs.front();
        for (const rig::AttributeSpec* spec : specs) {
            // aimConstraint's constraintTranslate is an input (the object's translate), the others' an output.
            if (name == "constraintTranslate" && spec->input != first.input) continue;
            CHECK(spec->type == first.type);
            CHECK(spec->input == first.input);
            CHECK(spec->keyable == first.keyable);
            CHECK(spec->array == first.array);
            CHECK(spec->min == first.min);
            CHECK(spec->max == first.max);
            CHECK(spec->enumNames == first.enumNames);
            // offset is a translation (cm) in point and poleVector, a rotation in orient and aim.
            if (name != "offset") CHECK(spec->unit == first.unit);
            if (sameDescription.contains(name)) CHECK(spec->description == first.description);
        }
    }
}

TEST_CASE("pointConstraint: weighted mean of the targets")
{
    Rig r;
    r.add("pointConstraint", "pc");
    CHECK(near(r.vec("pc.constraintTranslate"), v3(0, 0, 0)));  // no target: restTranslate

    // The targets' rotations do not matter, only their positions.
    r.set("pc.targetMatrix[0]", trs(v3(4, 0, 8), rot(0, 30)));
    r.set("pc.targetMatrix[1]", trs(v3(8, 4, 0), rot(1, -70)));
    CHECK(near(r.vec("pc.constraintTranslate"), v3(6, 2, 4)));  // absent weights count 1
    r.set("pc.targetWeight[0]", 1.0);
    r.set("pc.targetWeight[1]", 3.0);
    CHECK(near(r.vec("pc.constraintTranslate"), v3(7, 3, 2)));  // (1 * p0 + 3 * p1) / 4
    r.set("pc.offset", v3(1, -1, 0.5));
    CHECK(near(r.vec("pc.constraintTranslate"), v3(8, 2, 2.5)));

    SUBCASE("sparse indices; a weight without a target is ignored")
    {
        r.set("pc.targetMatrix[4]", trs(v3(-4, 0, 0)));
        r.set("pc.targetWeight[4]", 4.0);
        r.set("pc.targetWeight[7]", 100.0);
        // (4 + 24 - 16, 0 + 12 + 0, 8 + 0 + 0) / 8, plus the offset.
        CHECK(near(r.vec("pc.constraintTranslate"), v3(1.5 + 1, 1.5 - 1, 1 + 0.5)));
    }
    SUBCASE("all weights zero: restTranslate, not NaN")
    {
        r.set("pc.restTranslate", v3(3, 2, 1));
        r.set("pc.targetWeight[0]", 0.0);
        r.set("pc.targetWeight[1]", 0.0);
        CHECK(near(r.vec("pc.constraintTranslate"), v3(3, 2, 1)));
        r.set("pc.targetWeight[1]", 1e-3);  // any positive total: the (only) weighted target
        CHECK(near(r.vec("pc.constraintTranslate"), v3(8 + 1, 4 - 1, 0 + 0.5)));
    }
}

TEST_CASE("pointConstraint: the result is in the parent's space")
{
    // A transform under a turned, scaled, moved parent lands exactly on the weighted mean.
    Rig r(R"(
nodes:
  - {name: parent, type: transform, translate: [1, 2, 3], rotate: [0, 0, 90], scale: [2, 2, 2]}
  - {name: obj, type: transform, parent: parent}
  - {name: a, type: transform, translate: [10, 0, 0]}
  - {name: b, type: transform, translate: [0, 10, 0]}
  - {name: pc, type: pointConstraint, targetWeight: [1, 3]}
connections:
  - a.worldMatrix -> pc.targetMatrix[0]
  - b.worldMatrix -> pc.targetMatrix[1]
  - parent.worldInverseMatrix -> pc.constraintParentInverseMatrix
  - pc.constraintTranslate -> obj.translate
)");
    // Mean (2.5, 7.5, 0); minus the parent's translate (1.5, 5.5, -3); turned by -90 about Z (x, y) ->
    // (y, -x): (5.5, -1.5, -3); halved.
    CHECK(near(r.vec("obj.translate"), v3(2.75, -0.75, -1.5)));
    CHECK(near(Eigen::Vector3d(r.mat("obj.worldMatrix").topRightCorner<3, 1>()), v3(2.5, 7.5, 0)));
    r.set("b.translate", v3(-4, 2, 6));
    CHECK(near(Eigen::Vector3d(r.mat("obj.worldMatrix").topRightCorner<3, 1>()), v3(-0.5, 1.5, 4.5)));
    CHECK(r.check() == "");
}

TEST_CASE("orientConstraint: quaternion average of the targets")
{
    Rig r;
    r.add("orientConstraint", "oc");
    r.set("oc.targetMatrix[0]", trs(v3(5, 0, 0)));
    r.set("oc.targetMatrix[1]", trs(v3(0, 7, 0), rot(2, 90)));
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(45))));

    SUBCASE("unequal weights: the half angles blend as vectors")
    {
        r.set("oc.targetWeight[1]", 2.0);
        // q = normalize(1 * (w 1, z 0) + 2 * (cos 45, sin 45)): half angle atan2(2 sin 45, 1 + 2 cos 45).
        const double expected = 2.0 * std::atan2(2.0 * std::sin(pi / 4), 1.0 + 2.0 * std::cos(pi / 4));
        CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, expected)));
    }
    SUBCASE("sign alignment: 0 and 270 degrees blend the short way, to -45")
    {
        r.set("oc.targetMatrix[1]", trs(v3(0, 0, 0), rot(2, 270)));
        CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(-45))));
    }
    SUBCASE("a target's scale and shear are ignored")
    {
        Eigen::Matrix4d scaled = trs(v3(0, 0, 0), rot(2, 90));
        scaled.topLeftCorner<3, 3>() *= Eigen::Vector3d(2, 0.5, 3).asDiagonal();
        r.set("oc.targetMatrix[1]", scaled);
        CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(45))));
    }
    SUBCASE("offset turns the result in its own axes")
    {
        r.set("oc.offset", v3(deg(90), 0, 0));
        // W = Rz(45) * Rx(90): in xyz order (X first) that is (90, 0, 45).
        CHECK(near(r.vec("oc.constraintRotate"), v3(deg(90), 0, deg(45))));
    }
    SUBCASE("all weights zero: restRotate")
    {
        r.set("oc.restRotate", v3(deg(1), deg(2), deg(3)));
        r.set("oc.targetWeight[0]", 0.0);
        r.set("oc.targetWeight[1]", 0.0);
        CHECK(near(r.vec("oc.constraintRotate"), v3(deg(1), deg(2), deg(3))));
    }
}

TEST_CASE("orientConstraint: parent space, joint orient removal, rotate order")
{
    Rig r(R"(
nodes:
  - {name: parent, type: joint, rotate: [0, 0, 30]}
  - {name: child, type: joint, parent: parent, translate: [10, 0, 0], jointOrient: [0, 0, 10]}
  - {name: a, type: transform}
  - {name: b, type: transform, rotate: [0, 0, 90]}
  - {name: oc, type: orientConstraint}
connections:
  - a.worldMatrix -> oc.targetMatrix[0]
  - b.worldMatrix -> oc.targetMatrix[1]
)");
    // At the root: 45 degrees.
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(45))));
    // Under a parent turned 30 degrees: 15 in the parent's space.
    r.connect("parent.worldInverseMatrix", "oc.constraintParentInverseMatrix");
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(15))));
    // The child's joint orient of 10 degrees is removed: rotate 5, so that P * JO * R = Rz(45).
    r.set("oc.constraintJointOrient", v3(0, 0, deg(10)));
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(5))));
    r.connect("oc.constraintRotate", "child.rotate");
    CHECK(near(unscaled(r.mat("child.worldMatrix")), rot(2, 45)));

    SUBCASE("general orientations and rotate orders")
    {
        // Any parent orientation, joint orient and rotate order: the child's world orientation is the
        // targets' average. One target: exactly its orientation.
        r.graph->disconnect(r.graph->plug("b.worldMatrix"), r.graph->plug("oc.targetMatrix[1]"));
        r.set("oc.targetWeight[1]", 0.0);
        r.set("parent.rotate", v3(deg(25), deg(-40), deg(70)));
        r.set("a.rotate", v3(deg(-120), deg(35), deg(10)));
        const Eigen::Vector3d jo(deg(15), deg(-5), deg(30));
        r.set("child.jointOrient", jo);
        r.set("oc.constraintJointOrient", jo);
        for (int order = 0; order < 6; ++order) {
            CAPTURE(order);
            r.set("child.rotateOrder", order);
            r.set("oc.constraintRotateOrder", order);
            CHECK(near(unscaled(r.mat("child.worldMatrix")), unscaled(r.mat("a.worldMatrix"))));
        }
        CHECK(r.check() == "");
    }
    SUBCASE("a scaled parent joint with segment scale compensation stays exact")
    {
        r.set("parent.scale", v3(1, 2, 3));
        r.set("b.rotate", v3(deg(20), deg(50), deg(-60)));
        const Eigen::Quaterniond qa(unscaled(r.mat("a.worldMatrix")));
        Eigen::Quaterniond qb(unscaled(r.mat("b.worldMatrix")));
        if (qa.dot(qb) < 0) qb.coeffs() = -qb.coeffs();
        const Eigen::Quaterniond mean(Eigen::Vector4d((qa.coeffs() + qb.coeffs()).normalized()));
        CHECK(near(unscaled(r.mat("child.worldMatrix")), mean.toRotationMatrix()));
    }
}

TEST_CASE("parentConstraint: explicit offsets and blending")
{
    Rig r;
    r.add("parentConstraint", "pc");
    // Target at (10, 0, 0) turned 90 about Z; the object sits 5 along the target's Y: at (5, 0, 0).
    r.set("pc.targetMatrix[0]", trs(v3(10, 0, 0), rot(2, 90)));
    r.set("pc.targetOffset[0]", trs(v3(0, 5, 0)));
    CHECK(near(r.vec("pc.constraintTranslate"), v3(5, 0, 0)));
    CHECK(near(r.vec("pc.constraintRotate"), v3(0, 0, deg(90))));
    // The offset's rotation adds in the target's axes: 90 + (-30) about Z.
    r.set("pc.targetOffset[0]", trs(v3(0, 5, 0), rot(2, -30)));
    CHECK(near(r.vec("pc.constraintRotate"), v3(0, 0, deg(60))));

    SUBCASE("two targets: positions blend linearly, orientations as orientConstraint")
    {
        r.set("pc.targetOffset[0]", trs(v3(0, 0, 0)));
        r.set("pc.targetMatrix[1]", trs(v3(0, 0, 0)));
        r.set("pc.targetWeight[0]", 1.0);
        r.set("pc.targetWeight[1]", 3.0);
        CHECK(near(r.vec("pc.constraintTranslate"), v3(2.5, 0, 0)));
        const double half = std::atan2(1.0 * std::sin(pi / 4), 3.0 + 1.0 * std::cos(pi / 4));
        CHECK(near(r.vec("pc.constraintRotate"), v3(0, 0, 2 * half)));
    }
    SUBCASE("all weights zero: restTranslate and restRotate")
    {
        r.set("pc.restTranslate", v3(1, 2, 3));
        r.set("pc.restRotate", v3(0, deg(10), 0));
        r.set("pc.targetWeight[0]", 0.0);
        CHECK(near(r.vec("pc.constraintTranslate"), v3(1, 2, 3)));
        CHECK(near(r.vec("pc.constraintRotate"), v3(0, deg(10), 0)));
    }
    SUBCASE("maintainOffset replaces targetOffset by targetRestMatrix^-1 * restMatrix")
    {
        r.set("pc.maintainOffset", true);
        r.set("pc.restMatrix", trs(v3(1, 2, 3), rot(0, 20)));
        // targetRestMatrix[0] absent: identity, so the offset is restMatrix itself.
        const Eigen::Matrix4d expected = trs(v3(10, 0, 0), rot(2, 90)) * trs(v3(1, 2, 3), rot(0, 20));
        CHECK(near(r.vec("pc.constraintTranslate"), Eigen::Vector3d(expected.topRightCorner<3, 1>())));
        // A target at its rest matrix leaves the object at restMatrix.
        r.set("pc.targetRestMatrix[0]", trs(v3(10, 0, 0), rot(2, 90)));
        CHECK(near(r.vec("pc.constraintTranslate"), v3(1, 2, 3)));
        CHECK(near(r.vec("pc.constraintRotate"), v3(deg(20), 0, 0)));
        // A singular rest matrix counts as identity.
        r.set("pc.targetRestMatrix[0]", Eigen::Matrix4d(Eigen::Matrix4d::Zero()));
        CHECK(near(r.vec("pc.constraintTranslate"), Eigen::Vector3d(expected.topRightCorner<3, 1>())));
    }
}

TEST_CASE("parentConstraint: the docs' wiring keeps a joint in a hierarchy rigidly attached")
{
    Rig r(docExample("parent-constrained-joint"));
    // Rest: the arm's own rest values.
    CHECK(near(r.vec("arm.translate"), v3(10, 0, 0)));
    CHECK(near(r.vec("arm.rotate"), v3(0, 0, 0)));
    CHECK(near(r.mat("arm.worldMatrix"), trs(v3(0, 110, 0))));

    // The control moves to (5, 130, 0) and turns 90 about Y: the arm, 20 below it, follows rigidly.
    r.set("ctrl.translate", v3(5, 130, 0));
    r.set("ctrl.rotate", v3(0, deg(90), 0));
    CHECK(near(r.mat("arm.worldMatrix"), trs(v3(5, 110, 0), rot(1, 90))));
    // Channels: hips^-1 maps (5, 110, 0) to (10, -5, 0); rotate R = JO^-1 * Rz(90)^-1 * Ry(90) = Ry(90).
    CHECK(near(r.vec("arm.translate"), v3(10, -5, 0)));
    CHECK(near(r.vec("arm.rotate"), v3(0, deg(90), 0)));

    // Any motion of the control and of the hips: arm world = ctrl world * ctrlRest^-1 * armRest.
    r.set("ctrl.translate", v3(3, -7, 12));
    r.set("ctrl.rotate", v3(deg(20), deg(-35), deg(50)));
    r.set("hips.rotate", v3(deg(10), deg(80), deg(-30)));
    r.set("hips.translate", v3(4, 90, -6));
    const Eigen::Matrix4d expected = r.mat("ctrl.worldMatrix") * trs(v3(0, -130, 0)) * trs(v3(0, 110, 0));
    CHECK(near(r.mat("arm.worldMatrix"), expected));
    CHECK(r.check() == "");
}

TEST_CASE("aimConstraint: the docs' head rig aims exactly, with the up axis in the up plane")
{
    Rig r(docExample("aim-head"));
    CHECK(near(r.vec("head.rotate"), v3(0, 0, 0)));  // at rest it already looks at `look`

    // The head's world aim (Z) and up (Y) axes against the target and the world up direction.
    auto checkAim = [&](const Eigen::Vector3d& worldUp, bool upMatters) {
        const Eigen::Matrix4d head = r.mat("head.worldMatrix");
        const Eigen::Vector3d toTarget =
            (r.mat("look.worldMatrix").topRightCorner<3, 1>() - head.topRightCorner<3, 1>()).normalized();
        const Eigen::Vector3d aim = head.topLeftCorner<3, 3>() * v3(0, 0, 1);
        const Eigen::Vector3d up = head.topLeftCorner<3, 3>() * v3(0, 1, 0);
        CHECK(aim.norm() == doctest::Approx(1.0));
        CHECK(aim.cross(toTarget).norm() <= 1e-12);
        CHECK(aim.dot(toTarget) > 0.0);
        if (upMatters) {
            const Eigen::Vector3d normal = toTarget.cross(worldUp).normalized();
            CHECK(std::abs(up.dot(normal)) <= 1e-12);
            CHECK(up.dot(worldUp) > 0.0);
        }
    };

    r.set("neck.rotate", v3(deg(10), deg(-20), deg(100)));
    r.set("neck.rotateOrder", 4);
    const std::vector<Eigen::Vector3d> targets{v3(30, 170, 40), v3(-50, 120, -10), v3(5, 300, 2), v3(0, 140, -80)};
    auto forEachTarget = [&](const std::function<Eigen::Vector3d()>& worldUp, bool upMatters) {
        for (const Eigen::Vector3d& target : targets) {
            CAPTURE(target);
            r.set("look.translate", target);
            checkAim(worldUp(), upMatters);
        }
    };
    // object: toward the up object.
    r.set("up.translate", v3(20, 250, -30));
    forEachTarget([&] { return Eigen::Vector3d(v3(20, 250, -30) - r.mat("head.worldMatrix").topRightCorner<3, 1>()); },
                  true);
    // vector: worldUpVector in world space.
    r.set("head_aimConstraint.worldUpType", 3);
    r.set("head_aimConstraint.worldUpVector", v3(1, 1, 0.3));
    forEachTarget([] { return v3(1, 1, 0.3); }, true);
    // objectRotation: worldUpVector in the up object's axes.
    r.set("head_aimConstraint.worldUpType", 2);
    r.set("head_aimConstraint.worldUpVector", v3(0, 0, 1));
    r.set("up.rotate", v3(deg(-60), 0, deg(25)));
    forEachTarget([] { return Eigen::Vector3d(rot(2, 25) * rot(0, -60) * v3(0, 0, 1)); }, true);
    // scene: +Y; with another joint orient and rotate order on the head.
    r.set("head_aimConstraint.worldUpType", 0);
    r.set("head.jointOrient", v3(deg(-90), deg(20), deg(5)));
    r.set("head_aimConstraint.constraintJointOrient", v3(deg(-90), deg(20), deg(5)));
    r.set("head.rotateOrder", 5);
    r.set("head_aimConstraint.constraintRotateOrder", 5);
    forEachTarget([] { return v3(0, 1, 0); }, true);
    // none: aims, with the smallest turn from the rest frame.
    r.set("head_aimConstraint.worldUpType", 4);
    forEachTarget([] { return v3(0, 1, 0); }, false);
    CHECK(r.check() == "");
}

TEST_CASE("aimConstraint: closed forms at the root")
{
    Rig r;
    r.add("aimConstraint", "ac");
    r.set("ac.targetMatrix[0]", trs(v3(0, 10, 0)));
    // Aim X at +Y, up Y toward world +Y (parallel): no usable up, the shortest arc from X to Y is 90
    // about Z.
    CHECK(near(r.vec("ac.constraintRotate"), v3(0, 0, deg(90))));
    // Up toward +X instead: X -> Y, Y -> X, so Z -> -Z: a half turn about the diagonal (1, 1, 0).
    r.set("ac.worldUpVector", v3(1, 0, 0));
    Eigen::Matrix3d expected;
    expected << 0, 1, 0, 1, 0, 0, 0, 0, -1;
    const Eigen::Vector3d angles = r.vec("ac.constraintRotate");
    CHECK(near(rig::eulerToMatrix(angles, rig::RotateOrder::xyz), expected));

    SUBCASE("the object's position comes from constraintTranslate in the parent's space")
    {
        // Parent at (0, 20, 0), translate (-10, -10, 0): the object at (-10, 10, 0), level with the
        // target and 10 to its left, so the aim is +X and up +Y: no rotation.
        r.set("ac.constraintParentInverseMatrix", trs(v3(0, -20, 0)));
        r.set("ac.constraintTranslate", v3(-10, -10, 0));
        r.set("ac.worldUpVector", v3(0, 1, 0));
        CHECK(near(r.vec("ac.constraintRotate"), v3(0, 0, 0)));
        // An offset of 30 about Y is applied after aiming.
        r.set("ac.offset", v3(0, deg(30), 0));
        CHECK(near(r.vec("ac.constraintRotate"), v3(0, deg(30), 0)));
    }
    SUBCASE("aim and up vectors need not be unit or orthogonal")
    {
        r.set("ac.worldUpVector", v3(0, 0, 1));
        r.set("ac.aimVector", v3(2, 2, 0));
        r.set("ac.upVector", v3(0, 3, 0));
        const Eigen::Matrix3d w = rig::eulerToMatrix(r.vec("ac.constraintRotate"), rig::RotateOrder::xyz);
        CHECK(near(w * v3(1, 1, 0).normalized(), v3(0, 1, 0), 1e-12));
        // Up's part orthogonal to the aim, (-1, 1, 0)/sqrt2, goes to +Z.
        CHECK(near(w * v3(-1, 1, 0).normalized(), v3(0, 0, 1), 1e-12));
    }
}

TEST_CASE("aimConstraint: degenerate inputs follow the documented rules")
{
    Rig r;
    r.add("aimConstraint", "ac");
    r.set("ac.restRotate", v3(deg(7), deg(8), deg(9)));
    r.set("ac.constraintTranslate", v3(1, 2, 3));
    CHECK(near(r.vec("ac.constraintRotate"), v3(deg(7), deg(8), deg(9))));  // no target
    r.set("ac.targetMatrix[0]", trs(v3(1, 2, 3)));
    CHECK(near(r.vec("ac.constraintRotate"), v3(deg(7), deg(8), deg(9))));  // target on the object
    r.set("ac.targetMatrix[0]", trs(v3(1, 2, 13)));
    r.set("ac.aimVector", v3(0, 0, 0));
    CHECK(near(r.vec("ac.constraintRotate"), v3(deg(7), deg(8), deg(9))));  // zero aim vector
    r.set("ac.aimVector", v3(1, 0, 0));

    // No usable up: the shortest arc; +X onto +Z is -90 about Y (compared as matrices: gimbal lock).
    auto rotation = [&] { return rig::eulerToMatrix(r.vec("ac.constraintRotate"), rig::RotateOrder::xyz); };
    for (int upType : {0, 3, 4}) {
        CAPTURE(upType);
        r.set("ac.worldUpType", upType);
        r.set("ac.upVector", v3(-5, 0, 0));  // parallel to the aim
        CHECK(near(rotation(), rot(1, -90)));
    }
    r.set("ac.upVector", v3(0, 1, 0));
    r.set("ac.worldUpType", 3);
    r.set("ac.worldUpVector", v3(0, 0, -2));  // parallel to the direction to the target
    CHECK(near(rotation(), rot(1, -90)));
    r.set("ac.worldUpVector", v3(0, 0, 0));  // zero
    CHECK(near(rotation(), rot(1, -90)));
    r.set("ac.worldUpType", 1);  // up object at the object's position
    r.set("ac.worldUpMatrix", trs(v3(1, 2, 3)));
    CHECK(near(rotation(), rot(1, -90)));
    // Target straight behind the aim axis: a half turn, finite, aim exact.
    r.set("ac.worldUpType", 4);
    r.set("ac.targetMatrix[0]", trs(v3(-9, 2, 3)));
    CHECK(r.vec("ac.constraintRotate").allFinite());
    CHECK(near(rotation() * v3(1, 0, 0), v3(-1, 0, 0), 1e-12));
}

TEST_CASE("poleVectorConstraint: from the start joint to the target, in the chosen frame")
{
    Rig r;
    r.add("poleVectorConstraint", "pv");
    // Start joint: parent at (0, 140, 0), translate (0, 10, 0): world (0, 150, 0).
    r.set("pv.pivotSpace", trs(v3(0, 140, 0)));
    r.set("pv.constraintRotatePivot", v3(0, 10, 0));
    r.set("pv.targetMatrix[0]", trs(v3(25, 170, -20), rot(0, 45)));
    CHECK(near(r.vec("pv.constraintTranslate"), v3(25, 20, -20)));
    // A turned start parent moves the start joint: (0, 140, 0) + Rz(90) (0, 10, 0) = (-10, 140, 0).
    r.set("pv.pivotSpace", trs(v3(0, 140, 0), rot(2, 90)));
    CHECK(near(r.vec("pv.constraintTranslate"), v3(35, 30, -20)));
    // Two targets with weights 1 and 3; the second at (5, 150, 40): mean (10, 155, 25).
    r.set("pv.targetMatrix[1]", trs(v3(5, 150, 40)));
    r.set("pv.targetWeight[1]", 3.0);
    CHECK(near(r.vec("pv.constraintTranslate"), v3(20, 15, 25)));
    // A handle parent's space: only its 3x3 part applies (a direction), here -90 about Z: (y, -x, z).
    r.set("pv.constraintParentInverseMatrix", trs(v3(100, 200, 300), rot(2, -90)));
    CHECK(near(r.vec("pv.constraintTranslate"), v3(15, -20, 25)));
    r.set("pv.offset", v3(1, 2, 3));
    CHECK(near(r.vec("pv.constraintTranslate"), v3(16, -18, 28)));
    // All weights zero: restTranslate.
    r.set("pv.restTranslate", v3(0, 0, 1));
    r.set("pv.targetWeight[0]", 0.0);
    r.set("pv.targetWeight[1]", 0.0);
    CHECK(near(r.vec("pv.constraintTranslate"), v3(0, 0, 1)));
}

TEST_CASE("poleVectorConstraint: the docs' arm puts the elbow in the pole's plane")
{
    Rig r(docExample("pole-vector"));
    auto position = [&](const std::string& node) {
        return Eigen::Vector3d(r.mat(node + ".worldMatrix").topRightCorner<3, 1>());
    };
    for (const Eigen::Vector3d& pole : {v3(25, 170, -20), v3(20, 100, 30), v3(-10, 150, 60)}) {
        CAPTURE(pole);
        r.set("pole_ctrl.translate", pole);
        const Eigen::Vector3d start = position("shoulder");
        CHECK(near(start, v3(0, 150, 0)));
        CHECK(near(r.vec("arm_poleVectorConstraint.constraintTranslate"), pole - start));
        const Eigen::Vector3d goal = position("hand_ctrl") - start;
        const Eigen::Vector3d toPole = pole - start;
        const Eigen::Vector3d elbow = position("elbow") - start;
        const Eigen::Vector3d side = toPole - toPole.dot(goal.normalized()) * goal.normalized();
        CHECK(std::abs(elbow.dot(goal.cross(side).normalized())) <= 1e-9);  // in the plane
        CHECK(elbow.dot(side) > 0.0);                                       // on the pole's side
    }
    CHECK(r.check() == "");
}

TEST_CASE("constraints: degenerate inputs give finite outputs")
{
    const Eigen::Matrix4d zero = Eigen::Matrix4d::Zero();
    Eigen::Matrix4d flat = trs(v3(1, 2, 3), rot(1, 30));
    flat.col(1).setZero();  // a collapsed axis
    for (const std::string& type : constraintTypes) {
        CAPTURE(type);
        Rig r;
        r.add(type, "c");
        const rig::NodeType& t = r.graph->nodeType(0);
        auto has = [&](const char* name) { return t.findAttribute(name) >= 0; };
        auto outputsFinite = [&] {
            for (const char* out : {"c.constraintTranslate", "c.constraintRotate"})
                if (has(out + 2) && !t.attribute(t.findAttribute(out + 2)).input) CHECK(r.vec(out).allFinite());
        };
        outputsFinite();  // no targets
        r.set("c.targetMatrix[0]", zero);
        r.set("c.targetMatrix[1]", flat);
        r.set("c.targetMatrix[2]", trs(v3(1e12, -1e12, 0)));
        outputsFinite();
        r.set("c.constraintParentInverseMatrix", zero);
        outputsFinite();
        r.set("c.constraintParentInverseMatrix", flat);
        outputsFinite();
        for (int i = 0; i < 3; ++i) r.set(fmt::format("c.targetWeight[{}]", i), 0.0);
        outputsFinite();
        if (has("targetRestMatrix")) {
            r.set("c.targetWeight[1]", 1.0);
            r.set("c.maintainOffset", true);
            r.set("c.targetRestMatrix[1]", zero);
            r.set("c.restMatrix", flat);
            outputsFinite();
        }
        if (has("worldUpMatrix")) {
            r.set("c.targetWeight[1]", 1.0);
            for (int upType = 0; upType < 5; ++upType) {
                r.set("c.worldUpType", upType);
                r.set("c.worldUpMatrix", zero);
                outputsFinite();
                r.set("c.worldUpMatrix", flat);
                outputsFinite();
            }
        }
    }
}

namespace {

// A valid value unlike the attribute's default (k varies it between calls).
rig::Value nonDefault(const rig::AttributeSpec& spec, int k)
{
    const double d = 0.375 + 0.25 * k;
    switch (spec.type) {
        case rig::ValueType::Double:
            return rig::toDouble(spec.defaultValue) + d;
        case rig::ValueType::Bool:
            return !std::get<bool>(spec.defaultValue);
        case rig::ValueType::Vector3:
            return Eigen::Vector3d(std::get<Eigen::Vector3d>(spec.defaultValue) + v3(d, -2 * d, 3 * d));
        case rig::ValueType::Matrix4: {
            Eigen::Matrix4d m = trs(v3(3 * d, -2 * d, d), rot(k % 3, 20 + 15 * d));
            m.topLeftCorner<3, 3>() *= Eigen::Vector3d(1 + d, 1, 0.5).asDiagonal();
            return m;
        }
        default:
            return spec.defaultValue;
    }
}

}  // namespace

TEST_CASE("constraints: checked mode finds no missing affects entries")
{
    std::vector<std::string> types = constraintTypes;
    types.push_back("scaleConstraint");
    for (const std::string& typeName : types) {
        CAPTURE(typeName);
        Rig r;
        const rig::NodeId node = r.graph->addNode(typeName, "n");
        CHECK(r.check() == "");
        const auto& specs = r.graph->attributes(node);

        // Every output value, to tell whether a change moved one (else its check proves nothing).
        auto outputs = [&] {
            std::vector<rig::Value> values;
            for (std::size_t o = 0; o < specs.size(); ++o)
                if (!specs[o].input) values.push_back(r.graph->getValue({node, static_cast<rig::AttrId>(o), -1, -1}));
            return values;
        };
        std::vector<char> mattered(specs.size(), 0);
        auto setAndCheck = [&](const rig::Plug& plug, const rig::Value& value) {
            const std::vector<rig::Value> before = outputs();
            r.graph->setValue(plug, value);
            CHECK(r.check() == "");
            const std::vector<rig::Value> after = outputs();
            for (std::size_t i = 0; i < after.size(); ++i)
                if (!rig::bitEqual(before[i], after[i])) mattered[static_cast<std::size_t>(plug.attr)] = 1;
        };
        auto setAll = [&](int pass, const std::string& skip) {
            for (std::size_t a = 0; a < specs.size(); ++a) {
                const rig::AttributeSpec& spec = specs[a];
                if (!spec.input || spec.name == skip) continue;
                CAPTURE(spec.name);
                // Maya's per-target inputs at indices of their own: where targetMatrix[i] exists it wins.
                const bool mayaTarget = !spec.mayaCompound.empty() && spec.name != "targetWeight";
                const std::vector<int> indices = !spec.array  ? std::vector<int>{-1}
                                                 : mayaTarget ? std::vector<int>{5, 3, 4}
                                                              : std::vector<int>{2, 0, 1};
                for (int index : indices) {
                    const rig::Plug plug{node, static_cast<rig::AttrId>(a), index, -1};
                    if (spec.type == rig::ValueType::Enum) {
                        // Every value, ending on a different one in each pass (aimConstraint's up types).
                        const int n = static_cast<int>(spec.enumNames.size());
                        const int start = std::get<int>(spec.defaultValue);
                        for (int i = 1; i <= n + 1; ++i) setAndCheck(plug, (start + i + pass) % n);
                    } else if (spec.type == rig::ValueType::Bool) {
                        setAndCheck(plug, !std::get<bool>(r.graph->getValue(plug)));
                    } else {
                        setAndCheck(plug, nonDefault(spec, pass * 3 + index + 1));
                    }
                }
            }
        };
        for (int pass = 0; pass < 4; ++pass) {
            CAPTURE(pass);
            setAll(pass, "");
        }
        // Rest values matter once every weight is zero.
        for (int i : {0, 1, 2, 3, 4, 5})
            setAndCheck({node, r.graph->nodeType(node).findAttribute("targetWeight"), i, -1}, 0.0);
        setAll(4, "targetWeight");
        for (std::size_t a = 0; a < specs.size(); ++a) {
            if (!specs[a].input) continue;
            CAPTURE(specs[a].name);
            // scaleConstraint's constraintScaleCompensate is declared for Maya's wiring and not used
            // (docs/constraints.md).
            if (specs[a].name == "constraintScaleCompensate") continue;
            CHECK_MESSAGE(mattered[a], "no value set on this input changed an output");
        }
    }
}

TEST_CASE("constraints: checked mode over the docs' rigs")
{
    for (const char* name : {"parent-constrained-joint", "aim-head", "pole-vector"}) {
        CAPTURE(name);
        Rig r(docExample(name));
        CHECK(r.check() == "");
        for (const char* node : {"ctrl", "look", "up", "pole_ctrl", "hand_ctrl", "hips", "neck", "chest"}) {
            if (r.graph->findNode(node) < 0) continue;
            CAPTURE(node);
            r.set(fmt::format("{}.translate", node), v3(3, 140, -4));
            CHECK(r.check() == "");
            r.set(fmt::format("{}.rotate", node), v3(deg(10), deg(-20), deg(35)));
            CHECK(r.check() == "");
        }
    }
}

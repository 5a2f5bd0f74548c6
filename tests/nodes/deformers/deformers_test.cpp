// The rig deformer nodes of docs/ik-and-deformers.md through a Graph: blendColors, twistDistribute
// (pure twist, and the forearm rig of the doc loaded verbatim with swing present), slidingPivot,
// squashStretch, coupledBend (the order test fails on purpose), saturate, spring (history), and
// checked mode for every non-stateful type.

#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
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

Eigen::Matrix3d rotation(double radians, const Eigen::Vector3d& axis)
{
    return Eigen::AngleAxisd(radians, axis.normalized()).toRotationMatrix();
}

// The YAML block after the line `<!-- snippet: NAME -->` of docs/ik-and-deformers.md.
std::string docSnippet(const std::string& name)
{
    std::ifstream in(rig::test::sourceDir() / "docs" / "ik-and-deformers.md");
    std::stringstream text;
    text << in.rdbuf();
    const std::string doc = text.str();
    const auto at = doc.find(fmt::format("<!-- snippet: {} -->", name));
    REQUIRE_MESSAGE(at != std::string::npos, "no snippet " << name);
    const auto open = doc.find("```yaml\n", at);
    REQUIRE(open != std::string::npos);
    const auto close = doc.find("```", open + 8);
    REQUIRE(close != std::string::npos);
    return doc.substr(open + 8, close - open - 8);
}

struct Fixture {
    std::unique_ptr<rig::Graph> owned;
    rig::Graph& graph;

    Fixture() : owned(std::make_unique<rig::Graph>(rig::makeBuiltinRegistry())), graph(*owned) {}
    explicit Fixture(const std::string& yaml)
        : owned(rig::loadGraphText(yaml, "t.yaml", rig::makeBuiltinRegistry())), graph(*owned)
    {
    }
    void add(const std::string& type, const std::string& name) { graph.addNode(type, name); }
    void set(const std::string& path, const rig::Value& value) { graph.setValue(graph.plug(path), value); }
    void connect(const std::string& from, const std::string& to) { graph.connect(graph.plug(from), graph.plug(to)); }
    double num(const std::string& path) { return rig::toDouble(graph.getValue(graph.plug(path))); }
    Eigen::Vector3d vec(const std::string& path) { return std::get<Eigen::Vector3d>(graph.getValue(graph.plug(path))); }
    Eigen::Matrix4d mat(const std::string& path) { return std::get<Eigen::Matrix4d>(graph.getValue(graph.plug(path))); }
    Eigen::Matrix3d worldRotation(const std::string& node) { return mat(node + ".worldMatrix").topLeftCorner<3, 3>(); }
    Eigen::Vector3d worldPosition(const std::string& node) { return mat(node + ".worldMatrix").topRightCorner<3, 1>(); }
};

const std::vector<std::string> deformerTypes{"ikHandle",      "blendColors", "twistDistribute", "slidingPivot",
                                             "squashStretch", "coupledBend", "saturate",        "spring"};

}  // namespace

TEST_CASE("deformers: every type and attribute is documented - only spring is stateful")
{
    const auto registry = rig::makeBuiltinRegistry();
    for (const std::string& name : deformerTypes) {
        CAPTURE(name);
        const rig::NodeType* type = registry->find(name);
        REQUIRE(type != nullptr);
        CHECK_FALSE(type->description().empty());
        CHECK(type->stateful() == (name == "spring"));
        for (const rig::AttributeSpec& spec : type->attributes()) {
            CAPTURE(spec.name);
            CHECK_FALSE(spec.description.empty());
        }
    }
}

TEST_CASE("deformers: blendColors")
{
    Fixture f;
    f.add("blendColors", "b");
    // Maya's defaults: red and blue, half way.
    CHECK(near(f.vec("b.output"), v3(0.5, 0, 0.5)));
    f.set("b.color1", v3(10, 20, -30));
    f.set("b.color2G", 4.0);
    f.set("b.color2R", -2.0);
    f.set("b.blender", 0.25);
    CHECK(near(f.vec("b.output"), v3(10 * 0.25 - 2 * 0.75, 20 * 0.25 + 4 * 0.75, -30 * 0.25 + 1 * 0.75)));
    CHECK(f.num("b.outputG") == doctest::Approx(8.0));
    f.set("b.blender", 1.0);
    CHECK(f.vec("b.output") == v3(10, 20, -30));
    f.set("b.blender", 0.0);
    CHECK(f.vec("b.output") == v3(-2, 4, 1));
    CHECK_THROWS(f.set("b.blender", 1.5));

    // An IK/FK switch of rotations: angles arrive in degrees and leave as angles.
    f.add("transform", "ik");
    f.add("transform", "fk");
    f.add("joint", "j");
    f.connect("ik.rotate", "b.color1");
    f.connect("fk.rotate", "b.color2");
    f.connect("b.output", "j.rotate");
    f.set("ik.rotate", v3(deg(90), 0, deg(-20)));
    f.set("fk.rotate", v3(deg(10), deg(40), 0));
    f.set("b.blender", 0.75);
    CHECK(near(f.vec("b.output"), v3(70, 10, -15)));
    CHECK(near(f.vec("j.rotate"), v3(deg(70), deg(10), deg(-15))));
}

TEST_CASE("deformers: twistDistribute distributes a pure twist exactly")
{
    Fixture f;
    f.add("twistDistribute", "t");
    f.set("t.weight", std::vector<double>{0.25, 0.5, 0.75, 1.0});
    const rig::NodeId node = f.graph.node("t");
    const rig::AttrId outTwist = f.graph.nodeType(node).findAttribute("outTwist");
    f.graph.evaluateAll();
    CHECK(f.graph.elementIndices(node, outTwist) == std::vector<int>{0, 1, 2, 3});
    for (int axis = 0; axis < 3; ++axis) {
        f.set("t.twistAxis", axis);
        for (int order = 0; order < 6; ++order) {
            f.set("t.rotateOrder", order);
            for (double angle : {0.0, 10.0, -45.0, 90.0, 135.5, -179.0}) {
                CAPTURE(axis);
                CAPTURE(order);
                CAPTURE(angle);
                Eigen::Vector3d rotate = Eigen::Vector3d::Zero();
                rotate[axis] = deg(angle);
                f.set("t.rotate", rotate);
                CHECK(f.num("t.twist") == doctest::Approx(deg(angle)).epsilon(1e-12));
                const std::vector<double> weights{0.25, 0.5, 0.75, 1.0};
                for (int i = 0; i < 4; ++i)
                    CHECK(std::abs(f.num(fmt::format("t.outTwist[{}]", i)) - weights[i] * deg(angle)) < 1e-12);
            }
        }
    }
    // Swing about the other axes carries no twist.
    f.set("t.twistAxis", 0);
    f.set("t.rotateOrder", 0);
    f.set("t.rotate", v3(0, deg(60), 0));
    CHECK(std::abs(f.num("t.twist")) < 1e-12);
    f.set("t.rotate", v3(0, 0, deg(-170)));
    CHECK(std::abs(f.num("t.twist")) < 1e-12);
    // A half turn of swing: no defined twist, 0.
    f.set("t.rotate", v3(0, pi, 0));
    CHECK(std::abs(f.num("t.twist")) < 1e-12);
    // Fewer weights, fewer elements.
    f.set("t.weight", std::vector<double>{0.5});
    f.set("t.rotate", v3(deg(40), 0, 0));
    CHECK(f.num("t.outTwist[0]") == doctest::Approx(deg(20)));
    CHECK(f.graph.elementIndices(node, outTwist) == std::vector<int>{0});
}

TEST_CASE("deformers: twistDistribute on the doc's forearm extracts the twist under swing")
{
    Fixture f(docSnippet("forearm-twist"));
    const std::vector<double> weights{0.25, 0.5, 0.75};
    // Hand poses R = S * T: T the twist about the forearm (X), S a swing about an axis perpendicular to it.
    struct Pose {
        double twist, swing, swingAxisAngle;
    };
    for (const Pose& pose :
         {Pose{50, 40, 0}, Pose{-70, 65, 30}, Pose{120, 80, 110}, Pose{15, 25, -60}, Pose{-160, 10, 200}}) {
        CAPTURE(pose.twist);
        CAPTURE(pose.swing);
        const Eigen::Vector3d swingAxis(0, std::cos(deg(pose.swingAxisAngle)), std::sin(deg(pose.swingAxisAngle)));
        const Eigen::Matrix3d r =
            rotation(deg(pose.swing), swingAxis) * rotation(deg(pose.twist), Eigen::Vector3d::UnitX());
        const Eigen::Vector3d euler = rig::matrixToEuler(r, rig::RotateOrder::yzx);  // the wrist's order
        f.set("hand_ctrl.rotate", euler);
        CHECK(near(f.worldRotation("wrist"), r));
        CHECK(f.num("forearm_twist.twist") == doctest::Approx(deg(pose.twist)).epsilon(1e-12));
        for (int i = 0; i < 3; ++i) {
            const std::string roll = fmt::format("forearm_roll{}", i + 1);
            CHECK(f.num(roll + ".rotateX") == doctest::Approx(weights[i] * deg(pose.twist)).epsilon(1e-12));
            // Each roll joint turns about X only: an exact rotation about a fixed axis...
            CHECK(near(f.worldRotation(roll), rotation(weights[i] * deg(pose.twist), Eigen::Vector3d::UnitX())));
            // ...but not the weighted fraction of the hand's rotation (a slerp): the swing is dropped.
            const Eigen::Quaterniond fraction = Eigen::Quaterniond::Identity().slerp(weights[i], Eigen::Quaterniond(r));
            CHECK_FALSE(near(f.worldRotation(roll), fraction.toRotationMatrix(), 1e-3));
        }
        // The wrist's own rotateX is not the twist when a large swing is present.
        if (pose.swing >= 25) CHECK(std::abs(euler.x() - deg(pose.twist)) > 1e-3);
    }
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("deformers: slidingPivot closed form, and its pivot is not fixed")
{
    Fixture f(R"(
nodes:
  - {name: thigh, type: joint, translate: [0, 90, 0], jointOrient: [0, 0, -90]}
  - {name: shin, type: joint, parent: thigh}
  - {name: knee_pivot, type: slidingPivot, restTranslate: [45, 0, 0], slide: 2, slideQuadratic: 0.5}
connections:
  - knee_pivot.outRotate -> shin.rotate
  - knee_pivot.outTranslate -> shin.translate
)");
    for (double angle : {0.0, 30.0, 90.0, -20.0, 135.0}) {
        CAPTURE(angle);
        const double a = deg(angle);
        f.set("knee_pivot.angle", a);
        const double travel = 2.0 * a + 0.5 * a * a;
        CHECK(near(f.vec("knee_pivot.outRotate"), v3(0, 0, a)));
        CHECK(near(f.vec("knee_pivot.outTranslate"), v3(45, travel, 0)));
        // Orientation: exactly the hinge rotation.
        CHECK(near(f.worldRotation("shin"), f.worldRotation("thigh") * rotation(a, Eigen::Vector3d::UnitZ())));
        CHECK(near(f.worldPosition("shin"),
                   f.mat("thigh.worldMatrix").topLeftCorner<3, 3>() * v3(45, travel, 0) + v3(0, 90, 0)));
    }
    // The centre of the rotation taking the shin from angle 0 to angle a: fixed for a hinge, moving here.
    auto pivot = [&](double a) {
        f.set("knee_pivot.angle", 0.0);
        const Eigen::Matrix4d w0 = f.mat("shin.worldMatrix");
        f.set("knee_pivot.angle", a);
        const Eigen::Matrix4d m = f.mat("shin.worldMatrix") * w0.inverse();
        // Fixed point in the plane of the rotation (about world Z here): (I - R) p = t.
        const Eigen::Matrix2d i_r = Eigen::Matrix2d::Identity() - m.topLeftCorner<2, 2>();
        return Eigen::Vector2d(i_r.inverse() * m.block<2, 1>(0, 3));
    };
    CHECK((pivot(deg(30)) - pivot(deg(90))).norm() > 1.0);
    f.set("knee_pivot.slide", 0.0);
    f.set("knee_pivot.slideQuadratic", 0.0);
    CHECK(near(pivot(deg(30)), pivot(deg(90))));
    CHECK(near(pivot(deg(30)), f.worldPosition("shin").head<2>()));  // the joint itself: a plain hinge

    // Axis choices.
    f.set("knee_pivot.axis", 0);
    f.set("knee_pivot.slideAxis", 2);
    f.set("knee_pivot.slide", -3.0);
    f.set("knee_pivot.angle", 0.5);
    CHECK(near(f.vec("knee_pivot.outRotate"), v3(0.5, 0, 0)));
    CHECK(near(f.vec("knee_pivot.outTranslate"), v3(45, 0, -1.5)));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("deformers: squashStretch preserves volume")
{
    Fixture f;
    f.add("squashStretch", "s");
    CHECK(f.vec("s.outScale") == v3(1, 1, 1));
    for (double stretch : {0.25, 0.8, 1.0, 1.5, 3.0}) {
        CAPTURE(stretch);
        f.set("s.stretch", stretch);
        f.set("s.volume", 1.0);
        const Eigen::Vector3d full = f.vec("s.outScale");
        CHECK(full.x() == doctest::Approx(stretch));
        CHECK(full.y() == doctest::Approx(1.0 / std::sqrt(stretch)));
        CHECK(full.z() == doctest::Approx(full.y()));
        CHECK(full.prod() == doctest::Approx(1.0).epsilon(1e-14));
        f.set("s.volume", 0.0);
        CHECK(near(f.vec("s.outScale"), v3(stretch, 1, 1)));
        f.set("s.volume", 0.5);
        CHECK(f.vec("s.outScale").prod() == doctest::Approx(std::pow(stretch, 0.5)));
        CHECK(f.vec("s.outScale").y() == doctest::Approx(std::pow(stretch, -0.25)));
    }
    // length / restLength, another axis, the floor.
    f.set("s.volume", 1.0);
    f.set("s.stretch", 1.0);
    f.set("s.length", 30.0);
    CHECK(f.num("s.outStretch") == 1.0);  // restLength 0: length ignored
    f.set("s.restLength", 20.0);
    f.set("s.axis", 1);
    CHECK(f.num("s.outStretch") == doctest::Approx(1.5));
    CHECK(near(f.vec("s.outScale"), v3(1 / std::sqrt(1.5), 1.5, 1 / std::sqrt(1.5))));
    f.set("s.length", 0.0);
    CHECK(f.num("s.outStretch") == 1e-3);
    CHECK(f.vec("s.outScale").allFinite());
    CHECK(f.vec("s.outScale").prod() == doctest::Approx(1.0));
    CHECK_THROWS(f.set("s.stretch", 0.0));
}

TEST_CASE("deformers: coupledBend fails the composition-order test on purpose")
{
    Fixture f(R"(
nodes:
  - {name: base, type: joint, translate: [0, 10, 0]}
  - {name: tip, type: joint, parent: base}
  - {name: tip_end, type: joint, parent: tip, translate: [0, 10, 0]}
  - {name: bend_ctrl, type: coupledBend}
connections:
  - bend_ctrl.outRotate -> tip.rotate
)");
    auto world = [&](double bend, double turn) {
        f.set("bend_ctrl.bend", bend);
        f.set("bend_ctrl.turn", turn);
        return Eigen::Matrix3d(f.worldRotation("tip"));
    };
    const double b = deg(40);
    const double t = deg(60);
    // The node's formula: bend about Rz(turn) * X.
    CHECK(near(world(b, t), rotation(b, v3(std::cos(t), std::sin(t), 0))));
    CHECK(near(world(b, t), rotation(t, Eigen::Vector3d::UnitZ()) * rotation(b, Eigen::Vector3d::UnitX()) *
                                rotation(-t, Eigen::Vector3d::UnitZ())));

    const Eigen::Matrix3d rest = world(0, 0);
    // World deltas of each parameter, measured from rest.
    const Eigen::Matrix3d bendDelta = world(b, 0) * rest.transpose();
    const Eigen::Matrix3d turnDelta = world(0, t) * rest.transpose();
    CHECK(near(turnDelta, Eigen::Matrix3d::Identity()));  // turn alone does nothing
    // The delta of the bend depends on where turn is: at turn = t it is about another axis.
    const Eigen::Matrix3d bendDeltaAtT = world(b, t) * world(0, t).transpose();
    CHECK_FALSE(near(bendDelta, bendDeltaAtT, 1e-3));
    // Neither composition order reproduces the pose.
    const Eigen::Matrix3d actual = world(b, t);
    CHECK_FALSE(near(bendDelta * turnDelta * rest, actual, 1e-3));
    CHECK_FALSE(near(turnDelta * bendDelta * rest, actual, 1e-3));
    // The end of the chain shows it too: F(bend then turn) != F(turn then bend) as positions.
    f.set("bend_ctrl.bend", b);
    f.set("bend_ctrl.turn", 0.0);
    const Eigen::Vector3d afterBend = f.worldPosition("tip_end");
    f.set("bend_ctrl.turn", t);
    const Eigen::Vector3d afterBendThenTurn = f.worldPosition("tip_end");
    CHECK((afterBend - afterBendThenTurn).norm() > 1.0);
    // Yet each pose is an exact rotation and (bend, turn) is recovered from its axis-angle.
    const Eigen::AngleAxisd aa(actual);
    CHECK(aa.angle() == doctest::Approx(b));
    CHECK(std::abs(aa.axis().z()) < 1e-12);
    CHECK(std::atan2(aa.axis().y(), aa.axis().x()) == doctest::Approx(t));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("deformers: saturate")
{
    Fixture f;
    f.add("saturate", "s");
    const std::vector<std::pair<double, double>> cases{{-5, -1},   {-1, -1}, {-0.5, -0.5}, {0, 0},
                                                       {0.3, 0.3}, {1, 1},   {3, 1}};
    for (const auto& [in, out] : cases) {
        CAPTURE(in);
        f.set("s.input", in);
        CHECK(f.num("s.output") == out);
    }
    f.set("s.threshold", 0.0);
    f.set("s.input", 2.0);
    CHECK(f.num("s.output") == 0.0);
    CHECK_THROWS(f.set("s.threshold", -1.0));
    // Unitless between angles: 50 degrees in, threshold 30 (degrees), 30 degrees out.
    f.add("transform", "ctrl");
    f.add("joint", "j");
    f.connect("ctrl.rotateZ", "s.input");
    f.connect("s.output", "j.rotateZ");
    f.set("s.threshold", 30.0);
    f.set("ctrl.rotateZ", deg(50));
    CHECK(f.num("s.input") == doctest::Approx(50.0));
    CHECK(f.num("j.rotateZ") == doctest::Approx(deg(30)));
    f.set("ctrl.rotateZ", deg(-20));
    CHECK(f.num("j.rotateZ") == doctest::Approx(deg(-20)));
    // Past the threshold the control has no effect.
    f.set("ctrl.rotateZ", deg(80));
    const Eigen::Matrix4d a = f.mat("j.worldMatrix");
    f.set("ctrl.rotateZ", deg(120));
    CHECK(f.mat("j.worldMatrix") == a);
}

TEST_CASE("deformers: spring depends on its history")
{
    Fixture f;
    f.add("spring", "s");
    f.add("joint", "j");
    f.connect("s.output", "j.translateX");
    CHECK(f.graph.nodeType(f.graph.node("s")).stateful());
    const double k = 0.2;
    const double c = 0.1;
    f.set("s.stiffness", k);
    f.set("s.damping", c);
    f.graph.setTime(1.0);  // at startTime: rests at the input
    f.set("s.input", 0.0);
    CHECK(f.num("s.output") == 0.0);

    // A step to 10: the recurrence, frame by frame.
    f.set("s.input", 10.0);
    double position = 0.0;
    double velocity = 0.0;
    std::vector<double> outputs;
    for (int frame = 2; frame <= 8; ++frame) {
        f.graph.setTime(frame);
        velocity = (1.0 - c) * velocity + k * (10.0 - position);
        position += velocity;
        CAPTURE(frame);
        CHECK(f.num("s.output") == doctest::Approx(position));
        outputs.push_back(f.num("s.output"));
    }
    CHECK(outputs[0] == doctest::Approx(2.0));
    CHECK(f.num("j.translateX") == doctest::Approx(position));
    // Reading again without a change computes nothing: the same value.
    CHECK(f.num("s.output") == outputs.back());

    // Same inputs again (frame 2, input 10): a different output, because the history differs.
    f.graph.setTime(2.0);
    CHECK(f.num("s.output") != doctest::Approx(outputs[0]));
    // Checked mode recomputes (another step) but skips the stateful node and what it feeds.
    CHECK(f.graph.checkEvaluation().empty());
    // Going back to the start frame resets.
    f.graph.setTime(1.0);
    CHECK(f.num("s.output") == 10.0);
}

TEST_CASE("deformers: checked mode finds no missing affects entries")
{
    for (const std::string& typeName : deformerTypes) {
        if (typeName == "spring") continue;  // stateful: checkEvaluation skips it
        CAPTURE(typeName);
        rig::Graph graph(rig::makeBuiltinRegistry());
        const rig::NodeId node = graph.addNode(typeName, "n");
        CHECK(graph.checkEvaluation().empty());
        const auto& specs = graph.attributes(node);
        for (int pass = 0; pass < 3; ++pass) {
            CAPTURE(pass);
            const double k = 1.0 + 0.5 * pass;
            for (std::size_t a = 0; a < specs.size(); ++a) {
                const rig::AttributeSpec& spec = specs[a];
                if (!spec.input) continue;
                CAPTURE(spec.name);
                const rig::Plug plug{node, static_cast<rig::AttrId>(a), -1, -1};
                auto inRange = [&](double x) { return (!spec.min || x >= *spec.min) && (!spec.max || x <= *spec.max); };
                auto shifted = [&](double base, double offset) {
                    if (inRange(base + offset)) return base + offset;
                    if (inRange(base - offset)) return base - offset;
                    return *spec.min + (*spec.max - *spec.min) * (0.2 + 0.3 * pass);
                };
                switch (spec.type) {
                    case rig::ValueType::Enum: {
                        const int n = static_cast<int>(spec.enumNames.size());
                        for (int i = 1; i <= n + 1; ++i) {
                            graph.setValue(plug, (std::get<int>(spec.defaultValue) + i) % n);
                            CHECK(graph.checkEvaluation().empty());
                        }
                        continue;
                    }
                    case rig::ValueType::Bool:
                        graph.setValue(plug, !std::get<bool>(graph.getValue(plug)));
                        break;
                    case rig::ValueType::Double:
                        graph.setValue(plug, shifted(std::get<double>(graph.getValue(plug)), 0.4 * k));
                        break;
                    case rig::ValueType::Vector3: {
                        Eigen::Vector3d v = std::get<Eigen::Vector3d>(graph.getValue(plug));
                        const Eigen::Vector3d offset = v3(0.3, -0.2, 0.5) * k;
                        for (int i = 0; i < 3; ++i)
                            v[i] = shifted(v[i], offset[i] * (spec.unit == rig::Unit::Distance ? 10 : 1));
                        graph.setValue(plug, v);
                        break;
                    }
                    case rig::ValueType::Matrix4: {
                        Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
                        m.topLeftCorner<3, 3>() = rotation(0.3 * k, v3(1, 2, -0.5 * pass));
                        m.col(3) << 15.0 * k, -20.0, 2.5 * pass, 1.0;
                        graph.setValue(plug, m);
                        break;
                    }
                    case rig::ValueType::DoubleArray:
                        graph.setValue(plug, std::vector<double>{0.25 * k, 0.5, 0.75 + 0.1 * pass});
                        break;
                    default:
                        FAIL("unexpected attribute type");
                }
                CHECK(graph.checkEvaluation().empty());
            }
        }
    }
}

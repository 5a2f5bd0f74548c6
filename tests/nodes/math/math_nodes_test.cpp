// The Maya utility and matrix nodes through a Graph: closed-form results for every operation, sparse
// array inputs, unit conversion across connections, compose/decompose round trips, multMatrix order,
// and checked mode (complete affects tables) for every type.

#include <doctest/doctest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/error.h"
#include "graph/graph.h"
#include "nodes/builtin_nodes.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

struct Fixture {
    rig::Graph graph{rig::makeBuiltinRegistry()};

    void set(const std::string& path, const rig::Value& value) { graph.setValue(graph.plug(path), value); }
    void connect(const std::string& from, const std::string& to) { graph.connect(graph.plug(from), graph.plug(to)); }
    double num(const std::string& path) { return std::get<double>(graph.getValue(graph.plug(path))); }
    Eigen::Vector3d vec(const std::string& path) { return std::get<Eigen::Vector3d>(graph.getValue(graph.plug(path))); }
    Eigen::Matrix4d mat(const std::string& path) { return std::get<Eigen::Matrix4d>(graph.getValue(graph.plug(path))); }
};

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

Eigen::Vector3d v3(double x, double y, double z) { return Eigen::Vector3d(x, y, z); }

Eigen::Matrix3d rotAxis(int axis, double radians)
{
    return Eigen::AngleAxisd(radians, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
}

// The ten types of this file.
const std::vector<std::string> mathTypes{"multiplyDivide", "plusMinusAverage", "blendTwoAttr", "clamp",
                                         "reverse",        "remapValue",       "condition",    "multMatrix",
                                         "composeMatrix",  "decomposeMatrix"};

}  // namespace

TEST_CASE("math nodes: every type and attribute is documented")
{
    const auto registry = rig::makeBuiltinRegistry();
    for (const std::string& name : mathTypes) {
        CAPTURE(name);
        const rig::NodeType* type = registry->find(name);
        REQUIRE(type != nullptr);
        CHECK_FALSE(type->description().empty());
        for (const rig::AttributeSpec& spec : type->attributes()) {
            CAPTURE(spec.name);
            CHECK_FALSE(spec.description.empty());
        }
    }
}

TEST_CASE("math nodes: multiplyDivide operations")
{
    Fixture f;
    f.graph.addNode("multiplyDivide", "md");
    f.set("md.input1", v3(2, -3, 4));
    // Defaults: multiply by (1, 1, 1).
    CHECK(near(f.vec("md.output"), v3(2, -3, 4)));
    f.set("md.input2X", 4.0);
    f.set("md.input2Y", 2.0);
    f.set("md.input2Z", 0.5);
    CHECK(near(f.vec("md.output"), v3(8, -6, 2)));
    f.set("md.operation", 0);
    CHECK(near(f.vec("md.output"), v3(2, -3, 4)));
    f.set("md.operation", 2);
    CHECK(near(f.vec("md.output"), v3(0.5, -1.5, 8)));
    CHECK(f.num("md.outputZ") == doctest::Approx(8.0));
    f.set("md.operation", 3);
    CHECK(near(f.vec("md.output"), v3(16, 9, 2)));

    SUBCASE("division by zero and NaN powers give 0")
    {
        f.set("md.operation", 2);
        f.set("md.input2X", 0.0);
        f.set("md.input1Y", 0.0);
        f.set("md.input2Y", 0.0);
        CHECK(near(f.vec("md.output"), v3(0, 0, 8)));
        f.set("md.operation", 3);
        f.set("md.input1X", -8.0);
        f.set("md.input2X", 0.5);
        f.set("md.input1Y", 10.0);
        f.set("md.input2Y", 400.0);  // 1e400 overflows
        CHECK(near(f.vec("md.output"), v3(0, 0, 2)));
    }
}

TEST_CASE("math nodes: plusMinusAverage over sparse arrays")
{
    Fixture f;
    f.graph.addNode("plusMinusAverage", "pma");
    CHECK(f.num("pma.output1D") == 0.0);
    CHECK(near(f.vec("pma.output3D"), v3(0, 0, 0)));

    f.set("pma.input1D[0]", 1.0);
    f.set("pma.input1D[3]", 5.0);
    f.set("pma.input1D[7]", -2.0);
    f.set("pma.input3D[1]", v3(1, 2, 3));
    f.set("pma.input3D[4].input3Dx", 4.0);
    f.set("pma.input3D[4].input3Dy", 6.0);
    f.set("pma.input3D[4].input3Dz", 8.0);

    // Default: sum.
    CHECK(f.num("pma.output1D") == doctest::Approx(4.0));
    CHECK(near(f.vec("pma.output3D"), v3(5, 8, 11)));
    f.set("pma.operation", 2);
    CHECK(f.num("pma.output1D") == doctest::Approx(1.0 - 5.0 + 2.0));
    CHECK(near(f.vec("pma.output3D"), v3(-3, -4, -5)));
    f.set("pma.operation", 3);
    CHECK(f.num("pma.output1D") == doctest::Approx(4.0 / 3.0));
    CHECK(near(f.vec("pma.output3D"), v3(2.5, 4, 5.5)));
    CHECK(f.num("pma.output3Dz") == doctest::Approx(5.5));
    f.set("pma.operation", 0);
    CHECK(f.num("pma.output1D") == doctest::Approx(1.0));
    CHECK(near(f.vec("pma.output3D"), v3(1, 2, 3)));
}

TEST_CASE("math nodes: blendTwoAttr")
{
    Fixture f;
    f.graph.addNode("blendTwoAttr", "b");
    f.set("b.input[0]", 10.0);
    f.set("b.input[1]", 20.0);
    CHECK(f.num("b.output") == doctest::Approx(10.0));
    f.set("b.attributesBlender", 0.25);
    CHECK(f.num("b.output") == doctest::Approx(12.5));
    f.set("b.attributesBlender", 1.0);
    CHECK(f.num("b.output") == doctest::Approx(20.0));

    // A missing input[0] counts as 0; elements past [1] are ignored.
    f.graph.addNode("blendTwoAttr", "gap");
    f.set("gap.input[1]", 20.0);
    f.set("gap.input[5]", 100.0);
    f.set("gap.attributesBlender", 0.25);
    CHECK(f.num("gap.output") == doctest::Approx(5.0));
}

TEST_CASE("math nodes: clamp and reverse")
{
    Fixture f;
    f.graph.addNode("clamp", "c");
    f.set("c.inputR", 5.0);
    CHECK(near(f.vec("c.output"), v3(0, 0, 0)));  // min = max = 0 by default
    f.set("c.min", v3(0, -1, 2));
    f.set("c.max", v3(1, 1, 3));
    f.set("c.input", v3(1.5, -0.5, 0));
    CHECK(near(f.vec("c.output"), v3(1, -0.5, 2)));
    CHECK(f.num("c.outputG") == doctest::Approx(-0.5));
    f.set("c.minR", 2.0);  // min > max: max wins
    CHECK(f.num("c.outputR") == doctest::Approx(1.0));

    f.graph.addNode("reverse", "r");
    CHECK(near(f.vec("r.output"), v3(1, 1, 1)));
    f.set("r.input", v3(0.25, 1, -2));
    CHECK(near(f.vec("r.output"), v3(0.75, 0, 3)));
    CHECK(f.num("r.outputZ") == doctest::Approx(3.0));
}

TEST_CASE("math nodes: remapValue")
{
    Fixture f;
    f.graph.addNode("remapValue", "rv");
    // Empty ramp: Maya's default, linear 0 -> 0, 1 -> 1.
    f.set("rv.inputValue", 0.3);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.3));
    f.set("rv.inputMax", 10.0);
    f.set("rv.outputMax", 100.0);
    f.set("rv.outputMin", -100.0);
    f.set("rv.inputValue", 2.5);
    CHECK(f.num("rv.outValue") == doctest::Approx(-100.0 + 200.0 * 0.25));
    f.set("rv.inputValue", 20.0);  // past the ramp: its last value
    CHECK(f.num("rv.outValue") == doctest::Approx(100.0));
    f.set("rv.inputValue", -5.0);
    CHECK(f.num("rv.outValue") == doctest::Approx(-100.0));

    // Every entry's interpolation (Maya's value[i].value_Interp; the flat pairs are entries 0..2 here).
    auto setInterp = [&](int interp) {
        for (int i = 0; i < 3; ++i) f.set("rv.valueInterp[" + std::to_string(i) + "]", interp);
    };
    // A tent ramp, given out of order.
    f.set("rv.inputMax", 1.0);
    f.set("rv.outputMin", 0.0);
    f.set("rv.outputMax", 1.0);
    f.set("rv.value", std::vector<double>{1.0, 0.0, 0.0, 0.0, 0.5, 1.0});
    f.set("rv.inputValue", 0.25);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.5));  // linear (default)
    setInterp(0);                                         // none: holds the entry at or before
    CHECK(f.num("rv.outValue") == doctest::Approx(0.0));
    f.set("rv.inputValue", 0.75);
    CHECK(f.num("rv.outValue") == doctest::Approx(1.0));
    setInterp(2);  // smooth: smoothstep, s = 0.25 -> 3s^2 - 2s^3
    f.set("rv.inputValue", 0.125);
    CHECK(f.num("rv.outValue") == doctest::Approx(3 * 0.0625 - 2 * 0.015625));
    // spline: Hermite on [0, 0.5] with slopes 2 (secant at the end entry) and 0 (Catmull-Rom at the
    // peak); at the middle, h00 = h01 = 1/2, h10 = 1/8: 0.5 * 1 + 0.125 * 0.5 * 2.
    setInterp(3);
    f.set("rv.inputValue", 0.25);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.625));

    SUBCASE("inputMin == inputMax reads the ramp's ends")
    {
        setInterp(1);
        // Three entries: the valueInterp elements above name entries 0 to 2.
        f.set("rv.value", std::vector<double>{0.0, 0.2, 0.5, 0.45, 1.0, 0.7});
        f.set("rv.inputMin", 2.0);
        f.set("rv.inputMax", 2.0);
        f.set("rv.inputValue", 3.0);
        CHECK(f.num("rv.outValue") == doctest::Approx(0.7));
        f.set("rv.inputValue", 1.0);
        CHECK(f.num("rv.outValue") == doctest::Approx(0.2));
        f.set("rv.inputValue", 2.0);
        CHECK(f.num("rv.outValue") == doctest::Approx(0.2));
    }
    SUBCASE("an odd ramp is an error")
    {
        f.set("rv.value", std::vector<double>{0.0, 0.2, 1.0});
        CHECK_THROWS_AS(f.num("rv.outValue"), rig::Error);
    }
}

TEST_CASE("math nodes: condition operations")
{
    Fixture f;
    f.graph.addNode("condition", "cd");
    CHECK(near(f.vec("cd.outColor"), v3(0, 0, 0)));  // 0 == 0: colorIfTrue's default
    f.set("cd.colorIfTrue", v3(1, 2, 3));
    f.set("cd.colorIfFalse", v3(4, 5, 6));
    f.set("cd.secondTerm", 3.0);
    // Expected results for firstTerm = 2, 3, 4 against 3, per operation.
    const bool expected[6][3] = {{false, true, false}, {true, false, true},  {false, false, true},
                                 {false, true, true},  {true, false, false}, {true, true, false}};
    for (int op = 0; op < 6; ++op) {
        f.set("cd.operation", op);
        for (int i = 0; i < 3; ++i) {
            CAPTURE(op);
            CAPTURE(i);
            f.set("cd.firstTerm", 2.0 + i);
            CHECK(near(f.vec("cd.outColor"), expected[op][i] ? v3(1, 2, 3) : v3(4, 5, 6)));
        }
    }
    CHECK(f.num("cd.outColorG") == doctest::Approx(5.0));
}

TEST_CASE("math nodes: multMatrix applies matrixIn[0] first")
{
    Fixture f;
    f.graph.addNode("multMatrix", "mm");
    CHECK(near(f.mat("mm.matrixSum"), Eigen::Matrix4d::Identity()));

    Eigen::Matrix4d translate = Eigen::Matrix4d::Identity();
    translate.col(3) << 1, 2, 3, 1;
    Eigen::Matrix4d rotate;  // 90 degrees about Z
    rotate << 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    f.set("mm.matrixIn[0]", translate);
    f.set("mm.matrixIn[2]", rotate);  // a gap at [1]
    // Translate first, then rotate: the origin goes to (1, 2, 3), then to (-2, 1, 3).
    Eigen::Matrix4d expected;
    expected << 0, -1, 0, -2, 1, 0, 0, 1, 0, 0, 1, 3, 0, 0, 0, 1;
    CHECK(near(f.mat("mm.matrixSum"), expected));

    f.set("mm.matrixIn[0]", rotate);
    f.set("mm.matrixIn[2]", translate);
    Eigen::Matrix4d swapped;
    swapped << 0, -1, 0, 1, 1, 0, 0, 2, 0, 0, 1, 3, 0, 0, 0, 1;
    CHECK(near(f.mat("mm.matrixSum"), swapped));
}

TEST_CASE("math nodes: composeMatrix matches T * R * SH * S and decomposeMatrix inverts it")
{
    Fixture f;
    f.graph.addNode("composeMatrix", "cm");
    f.graph.addNode("decomposeMatrix", "dm");
    CHECK(near(f.mat("cm.outputMatrix"), Eigen::Matrix4d::Identity()));

    const Eigen::Vector3d t(1, 2, 3), r(deg(30), deg(-45), deg(60)), s(2, 0.5, 3), sh(0.2, -0.1, 0.3);
    f.set("cm.inputTranslate", t);
    f.set("cm.inputRotate", r);
    f.set("cm.inputScale", s);
    f.set("cm.inputShear", sh);
    f.set("cm.inputRotateOrder", 2);  // zxy: Z applied first, then X, then Y

    Eigen::Matrix3d shear;
    shear << 1, sh.x(), sh.y(), 0, 1, sh.z(), 0, 0, 1;
    Eigen::Matrix4d expected = Eigen::Matrix4d::Identity();
    expected.topLeftCorner<3, 3>() = rotAxis(1, r.y()) * rotAxis(0, r.x()) * rotAxis(2, r.z()) * shear * s.asDiagonal();
    expected.topRightCorner<3, 1>() = t;
    CHECK(near(f.mat("cm.outputMatrix"), expected));

    f.connect("cm.outputMatrix", "dm.inputMatrix");
    f.set("dm.inputRotateOrder", 2);
    CHECK(near(f.vec("dm.outputTranslate"), t));
    CHECK(near(f.vec("dm.outputRotate"), r));
    CHECK(near(f.vec("dm.outputScale"), s));
    CHECK(near(f.vec("dm.outputShear"), sh));

    // And back: decompose's outputs into a second composeMatrix rebuild the matrix.
    f.graph.addNode("composeMatrix", "cm2");
    for (const char* a : {"Translate", "Rotate", "Scale", "Shear"})
        f.connect(std::string("dm.output") + a, std::string("cm2.input") + a);
    f.set("cm2.inputRotateOrder", 2);
    CHECK(near(f.mat("cm2.outputMatrix"), expected));

    // The quaternion output describes the same rotation.
    const Eigen::Quaterniond q(f.num("dm.outputQuatW"), f.num("dm.outputQuatX"), f.num("dm.outputQuatY"),
                               f.num("dm.outputQuatZ"));
    CHECK(q.norm() == doctest::Approx(1.0));
    CHECK(near(q.toRotationMatrix(), rotAxis(1, r.y()) * rotAxis(0, r.x()) * rotAxis(2, r.z())));

    // Another rotate order on decomposeMatrix changes outputRotate only.
    f.set("dm.inputRotateOrder", 0);
    const Eigen::Vector3d xyz = f.vec("dm.outputRotate");
    CHECK(near(rotAxis(2, xyz.z()) * rotAxis(1, xyz.y()) * rotAxis(0, xyz.x()),
               rotAxis(1, r.y()) * rotAxis(0, r.x()) * rotAxis(2, r.z())));
    CHECK(near(f.vec("dm.outputScale"), s));
}

TEST_CASE("math nodes: composeMatrix from a quaternion")
{
    Fixture f;
    f.graph.addNode("composeMatrix", "cm");
    f.set("cm.inputRotate", v3(deg(10), deg(20), deg(30)));  // ignored once useEulerRotation is off
    f.set("cm.useEulerRotation", false);
    // 90 degrees about Z, not normalized (scaled by 2).
    f.set("cm.inputQuatZ", 2 * std::sin(pi / 4));
    f.set("cm.inputQuatW", 2 * std::cos(pi / 4));
    f.set("cm.inputScale", v3(2, 1, 1));
    f.set("cm.inputTranslate", v3(5, 0, 0));
    Eigen::Matrix4d expected;
    expected << 0, -1, 0, 5, 2, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1;
    CHECK(near(f.mat("cm.outputMatrix"), expected));
    f.set("cm.inputQuatZ", 0.0);
    f.set("cm.inputQuatW", 0.0);  // a zero quaternion: no rotation
    expected.topLeftCorner<3, 3>() = Eigen::Vector3d(2, 1, 1).asDiagonal();
    CHECK(near(f.mat("cm.outputMatrix"), expected));
}

TEST_CASE("math nodes: unitless to angle connections convert degrees")
{
    Fixture f;
    f.graph.addNode("multiplyDivide", "md");
    f.graph.addNode("composeMatrix", "cm");
    f.graph.addNode("decomposeMatrix", "dm");
    f.graph.addNode("multiplyDivide", "back");
    f.set("md.input1X", 45.0);
    f.set("md.input2X", 2.0);
    f.connect("md.outputX", "cm.inputRotateZ");  // 90, unitless -> an angle: pi/2 inside
    CHECK(f.num("cm.inputRotateZ") == doctest::Approx(pi / 2));
    Eigen::Matrix4d expected = Eigen::Matrix4d::Identity();
    expected.topLeftCorner<3, 3>() = rotAxis(2, pi / 2);
    CHECK(near(f.mat("cm.outputMatrix"), expected));

    // And back: an angle output into a unitless input arrives in degrees.
    f.connect("cm.outputMatrix", "dm.inputMatrix");
    f.connect("dm.outputRotateZ", "back.input1X");
    CHECK(f.num("dm.outputRotateZ") == doctest::Approx(pi / 2));
    CHECK(f.num("back.outputX") == doctest::Approx(90.0));

    f.set("md.input2X", -1.0);
    CHECK(f.num("back.outputX") == doctest::Approx(-45.0));
}

namespace {

// A value unlike the attribute's default (k varies it between calls).
rig::Value nonDefault(const rig::AttributeSpec& spec, int k)
{
    const double d = 0.375 + 0.25 * k;
    switch (spec.type) {
        case rig::ValueType::Double:
            return rig::toDouble(spec.defaultValue) + d;
        case rig::ValueType::Int:
            return std::get<int>(spec.defaultValue) + 1 + k;
        case rig::ValueType::Bool:
            return !std::get<bool>(spec.defaultValue);
        case rig::ValueType::Vector3:
            return Eigen::Vector3d(std::get<Eigen::Vector3d>(spec.defaultValue) + v3(d, -2 * d, 3 * d));
        case rig::ValueType::Matrix4: {
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            m.topLeftCorner<3, 3>() = rotAxis(k % 3, 0.3 + d) * Eigen::Vector3d(1 + d, 2, 0.5).asDiagonal();
            m.col(3) << d, 2 * d, -d, 1;
            return m;
        }
        case rig::ValueType::DoubleArray:
            return std::vector<double>{0.0, 0.1, 0.4, 0.8 + d, 1.0, 0.3};
        default:
            return spec.defaultValue;
    }
}

}  // namespace

TEST_CASE("math nodes: checked mode finds no missing affects entries")
{
    for (const std::string& typeName : mathTypes) {
        CAPTURE(typeName);
        rig::Graph graph(rig::makeBuiltinRegistry());
        const rig::NodeId node = graph.addNode(typeName, "n");
        CHECK(graph.checkEvaluation().empty());
        const auto& specs = graph.attributes(node);
        for (int pass = 0; pass < 2; ++pass) {
            for (std::size_t a = 0; a < specs.size(); ++a) {
                const rig::AttributeSpec& spec = specs[a];
                if (!spec.input) continue;
                CAPTURE(spec.name);
                const std::vector<int> indices = spec.array ? std::vector<int>{2, 0, 1} : std::vector<int>{-1};
                for (int index : indices) {
                    const rig::Plug plug{node, static_cast<rig::AttrId>(a), index, -1};
                    if (spec.type == rig::ValueType::Enum) {
                        // Every value of an enum, ending on a non-default one.
                        const int n = static_cast<int>(spec.enumNames.size());
                        const int start = std::get<int>(spec.defaultValue);
                        for (int i = 1; i <= n + 1; ++i) {
                            graph.setValue(plug, (start + i) % n);
                            CHECK(graph.checkEvaluation().empty());
                        }
                    } else {
                        graph.setValue(plug, nonDefault(spec, pass * 3 + index + 1));
                        CHECK(graph.checkEvaluation().empty());
                    }
                }
            }
        }
    }
}

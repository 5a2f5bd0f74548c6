// Maya's utility and animation-layer node types: closed forms computed here from each node's formula, Maya's
// edge cases (division by zero, zero-length vectors, empty ranges, singular matrices), pairBlend's quaternion
// blend against Eigen's slerp, the unit conversion chain a set-driven key makes, and Maya's attribute names
// (every short name unique and resolving, the children's and the compound multi attributes' names).

#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/rotation_math.h"
#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

struct Fixture {
    rig::Graph graph{rig::makeBuiltinRegistry()};

    void add(const std::string& type, const std::string& name) { graph.addNode(type, name); }
    void set(const std::string& path, const rig::Value& value) { graph.setValue(graph.plug(path), value); }
    void connect(const std::string& from, const std::string& to) { graph.connect(graph.plug(from), graph.plug(to)); }
    double num(const std::string& path) { return std::get<double>(graph.getValue(graph.plug(path))); }
    int integer(const std::string& path) { return std::get<int>(graph.getValue(graph.plug(path))); }
    Eigen::Vector3d vec(const std::string& path) { return std::get<Eigen::Vector3d>(graph.getValue(graph.plug(path))); }
    Eigen::Matrix4d mat(const std::string& path) { return std::get<Eigen::Matrix4d>(graph.getValue(graph.plug(path))); }
};

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

Eigen::Vector3d v3(double x, double y, double z) { return Eigen::Vector3d(x, y, z); }

Eigen::Matrix3d rot(int axis, double radians)
{
    return Eigen::AngleAxisd(radians, Eigen::Vector3d::Unit(axis)).toRotationMatrix();
}

Eigen::Matrix4d affine(const Eigen::Matrix3d& linear, const Eigen::Vector3d& translation)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = linear;
    m.topRightCorner<3, 1>() = translation;
    return m;
}

}  // namespace

TEST_CASE("maya utility nodes: every registered type's Maya names are unique and resolve")
{
    const auto registry = rig::makeBuiltinRegistry();
    for (const std::string& typeName : registry->typeNames()) {
        CAPTURE(typeName);
        const rig::NodeType* type = registry->find(typeName);
        REQUIRE(type != nullptr);
        std::set<std::string> names;  // every Maya name of the type's top-level attributes and vector children
        for (std::size_t a = 0; a < type->attributes().size(); ++a) {
            const rig::AttributeSpec& spec = type->attributes()[a];
            const auto id = static_cast<rig::AttrId>(a);
            CAPTURE(spec.name);
            if (!spec.mayaCompound.empty()) {
                // A child of a compound multi attribute resolves through its compound, by either of its names.
                for (const std::string& compound : {spec.mayaCompound, spec.mayaCompoundShort}) {
                    const auto children = type->mayaCompoundChildren(compound);
                    CHECK(std::count(children.begin(), children.end(), id) == 1);
                }
                CHECK(type->findMayaAttribute(spec.name) == -1);
                continue;
            }
            CHECK(type->findMayaAttribute(spec.name) == id);
            CHECK(names.insert(spec.name).second);
            if (!spec.shortName.empty() && spec.shortName != spec.name) {
                CHECK(type->findMayaAttribute(spec.shortName) == id);
                CHECK(names.insert(spec.shortName).second);
            }
            if (spec.type != rig::ValueType::Vector3) continue;
            for (int i = 0; i < 3; ++i) {
                const auto k = static_cast<std::size_t>(i);
                CHECK(rig::mayaChildIndex(spec, spec.childNames[k]) == i);
                CHECK(names.insert(spec.childNames[k]).second);
                if (spec.shortName.empty()) continue;
                CHECK_FALSE(spec.childShortNames[k].empty());
                CHECK(rig::mayaChildIndex(spec, spec.childShortNames[k]) == i);
                CHECK(names.insert(spec.childShortNames[k]).second);
            }
        }
    }
}

TEST_CASE("maya utility nodes: the Maya utility types carry Maya's short names")
{
    const auto registry = rig::makeBuiltinRegistry();
    // Attributes of ours that Maya has no counterpart of.
    const std::set<std::string> ours{"remapValue.value", "remapValue.interp"};
    for (const std::string& typeName : rig::mayaUtilityTypeNames()) {
        CAPTURE(typeName);
        const rig::NodeType* type = registry->find(typeName);
        REQUIRE(type != nullptr);
        for (const rig::AttributeSpec& spec : type->attributes()) {
            CAPTURE(spec.name);
            if (!ours.count(typeName + "." + spec.name)) CHECK_FALSE(spec.shortName.empty());
        }
    }
    // Maya's spellings, as a scene writes them, each read as the attribute or child it names.
    struct Name {
        const char* type;
        const char* maya;
        const char* attribute;
        int child;
    };
    for (const Name& n : std::vector<Name>{{"multiplyDivide", "i1x", "input1", 0},
                                           {"multiplyDivide", "op", "operation", -1},
                                           {"multiplyDivide", "oz", "output", 2},
                                           {"plusMinusAverage", "i3", "input3D", -1},
                                           {"plusMinusAverage", "o3y", "output3D", 1},
                                           {"condition", "ctr", "colorIfTrue", 0},
                                           {"condition", "ocb", "outColor", 2},
                                           {"clamp", "mxg", "max", 1},
                                           {"clamp", "opr", "output", 0},
                                           {"reverse", "iy", "input", 1},
                                           {"blendColors", "c1r", "color1", 0},
                                           {"blendColors", "opb", "output", 2},
                                           {"decomposeMatrix", "imat", "inputMatrix", -1},
                                           {"decomposeMatrix", "orx", "outputRotate", 0},
                                           {"decomposeMatrix", "oqw", "outputQuatW", -1},
                                           {"composeMatrix", "ish", "inputShear", -1},
                                           {"multMatrix", "i", "matrixIn", -1},
                                           {"pairBlend", "itx1", "inTranslate1", 0},
                                           {"pairBlend", "irz2", "inRotate2", 2},
                                           {"pairBlend", "oty", "outTranslate", 1},
                                           {"setRange", "onz", "oldMin", 2},
                                           {"angleBetween", "euy", "euler", 1},
                                           {"quatToEuler", "ortx", "outputRotate", 0},
                                           {"animBlendNodeAdditiveRotation", "ibz", "inputB", 2},
                                           {"animBlendNodeAdditiveRotation", "acm", "accumulationMode", -1},
                                           {"unitConversion", "cf", "conversionFactor", -1},
                                           {"blendWeighted", "w", "weight", -1}}) {
        CAPTURE(n.type);
        CAPTURE(n.maya);
        const rig::NodeType* type = registry->find(n.type);
        REQUIRE(type != nullptr);
        const rig::AttrId expected = type->findAttribute(n.attribute);
        REQUIRE(expected >= 0);
        if (n.child < 0) {
            CHECK(type->findMayaAttribute(n.maya) == expected);
        } else {
            CHECK(type->findMayaAttribute(n.maya) == -1);
            CHECK(rig::mayaChildIndex(type->attribute(expected), n.maya) == n.child);
        }
    }
    // Compound multi attributes flattened into parallel arrays, in declaration order.
    const rig::NodeType* remap = registry->find("remapValue");
    const auto value = remap->mayaCompoundChildren("vl");
    REQUIRE(value.size() == 3);
    CHECK(remap->attribute(value[0]).shortName == "vp");
    CHECK(remap->attribute(value[1]).shortName == "fv");
    CHECK(remap->attribute(value[2]).shortName == "vi");
    const rig::NodeType* blend = registry->find("blendMatrix");
    CHECK(blend->mayaCompoundChildren("tgt").size() == 6);
    CHECK(blend->mayaCompoundChildren("target") == blend->mayaCompoundChildren("tgt"));
}

TEST_CASE("maya utility nodes: unitConversion and the set-driven key chain")
{
    CHECK(rig::unitConversionFactor(180.0 / pi, rig::Unit::Angle, rig::Unit::None) == doctest::Approx(1.0));
    CHECK(rig::unitConversionFactor(pi / 180.0, rig::Unit::None, rig::Unit::Angle) == doctest::Approx(1.0));
    CHECK(rig::unitConversionFactor(0.1, rig::Unit::None, rig::Unit::None) == 0.1);
    CHECK(rig::unitConversionFactor(2.0, rig::Unit::Distance, rig::Unit::None) == 2.0);

    Fixture f;
    f.add("unitConversion", "uc");
    f.set("uc.input", 4.0);
    CHECK(f.num("uc.output") == 4.0);  // default factor 1
    f.set("uc.conversionFactor", -2.5);
    CHECK(f.num("uc.output") == -10.0);

    // Maya: ctrl.rotateX (radians) -> unitConversion (cf 57.2958) -> animCurveUA.input reads degrees; the curve's
    // output is an angle again. Keys (0, 0) and (90, 45) linear: 30 degrees in gives 15 degrees out.
    auto g = rig::loadGraphText(R"(
nodes:
  - {name: ctrl, type: transform, rotate: [30, 0, 0]}
  - {name: uc, type: unitConversion}
  - {name: sdk, type: animCurveUA, keys: [[0, 0], [90, 45]], tangents: linear}
  - {name: bone, type: joint}
  - {name: uu, type: animCurveUU, keys: [[0, 0], [10, 20]], tangents: linear, input: 5}
  - {name: back, type: unitConversion}
  - {name: bone2, type: joint}
connections:
  - ctrl.rotateX -> uc.input
  - uc.output -> sdk.input
  - sdk.output -> bone.rotateZ
  - uu.output -> back.input
  - back.output -> bone2.rotateY
)",
                                "t.yaml", rig::makeBuiltinRegistry());
    g->setValue(g->plug("uc.conversionFactor"),
                rig::unitConversionFactor(180.0 / pi, rig::Unit::Angle, rig::Unit::None));
    g->setValue(g->plug("back.conversionFactor"),
                rig::unitConversionFactor(pi / 180.0, rig::Unit::None, rig::Unit::Angle));
    CHECK(std::get<double>(g->getValue(g->plug("uc.output"))) == doctest::Approx(30.0));
    CHECK(std::get<double>(g->getValue(g->plug("bone.rotateZ"))) == doctest::Approx(deg(15.0)));
    // animCurveUU gives 10 (unitless); Maya's unitConversion (cf 0.0174533) makes it 10 degrees on the rotate.
    CHECK(std::get<double>(g->getValue(g->plug("bone2.rotateY"))) == doctest::Approx(deg(10.0)));
    CHECK(g->checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: multDoubleLinear, addDoubleLinear, floatConstant, blendWeighted")
{
    Fixture f;
    f.add("multDoubleLinear", "mdl");
    f.add("addDoubleLinear", "adl");
    f.add("floatConstant", "fc");
    f.add("blendWeighted", "bw");
    f.set("mdl.input1", 3.5);
    CHECK(f.num("mdl.output") == 3.5);  // input2 defaults to 1
    f.set("mdl.input2", -2.0);
    CHECK(f.num("mdl.output") == -7.0);
    f.set("adl.input1", 3.5);
    f.set("adl.input2", -1.25);
    CHECK(f.num("adl.output") == 2.25);
    f.set("fc.inFloat", 0.625);
    CHECK(f.num("fc.outFloat") == 0.625);

    CHECK(f.num("bw.output") == 0.0);  // no inputs
    f.set("bw.input[0]", 2.0);
    f.set("bw.input[3]", 5.0);
    CHECK(f.num("bw.output") == 7.0);  // weights default to 1
    f.set("bw.weight[3]", 0.5);
    f.set("bw.weight[7]", 100.0);  // a weight without an input adds nothing
    CHECK(f.num("bw.output") == 2.0 + 2.5);
    f.set("bw.current", 3);  // Maya's current driver changes nothing
    CHECK(f.num("bw.output") == 4.5);
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: pairBlend at weights 0, 0.5 and 1")
{
    Fixture f;
    f.add("pairBlend", "pb");
    f.set("pb.inTranslate1", v3(1, 2, 3));
    f.set("pb.inTranslate2", v3(5, -2, 7));
    const Eigen::Vector3d r1(deg(90), 0, 0);
    const Eigen::Vector3d r2(0, deg(90), deg(30));
    f.set("pb.inRotate1", r1);
    f.set("pb.inRotate2", r2);
    CHECK(near(f.vec("pb.outTranslate"), v3(5, -2, 7)));  // weight defaults to 1
    CHECK(near(f.vec("pb.outRotate"), r2));

    SUBCASE("euler: each channel blends linearly")
    {
        f.set("pb.weight", 0.0);
        CHECK(near(f.vec("pb.outTranslate"), v3(1, 2, 3)));
        CHECK(near(f.vec("pb.outRotate"), r1));
        f.set("pb.weight", 0.5);
        CHECK(near(f.vec("pb.outTranslate"), v3(3, 0, 5)));
        CHECK(near(f.vec("pb.outRotate"), (r1 + r2) / 2));
        f.set("pb.translateYMode", 1);  // input 1 only
        f.set("pb.translateZMode", 2);  // input 2 only
        CHECK(near(f.vec("pb.outTranslate"), v3(3, 2, 7)));
        f.set("pb.rotateMode", 1);
        CHECK(near(f.vec("pb.outRotate"), r1));
        f.set("pb.rotateMode", 2);
        CHECK(near(f.vec("pb.outRotate"), r2));
    }
    SUBCASE("quaternion: the shorter-arc slerp of the two rotations in rotateOrder")
    {
        f.set("pb.rotInterpolation", 1);
        for (int order : {0, 2, 5}) {
            CAPTURE(order);
            f.set("pb.rotateOrder", order);
            const auto ro = *rig::rotateOrderFromIndex(order);
            const Eigen::Quaterniond q1(rig::eulerToMatrix(r1, ro));
            const Eigen::Quaterniond q2(rig::eulerToMatrix(r2, ro));
            f.set("pb.weight", 0.0);
            CHECK(near(f.vec("pb.outRotate"), r1));
            f.set("pb.weight", 1.0);
            CHECK(near(f.vec("pb.outRotate"), r2));
            for (double w : {0.5, 0.25}) {
                f.set("pb.weight", w);
                const Eigen::Matrix3d expected = q1.slerp(w, q2).toRotationMatrix();
                CHECK(near(rig::eulerToMatrix(f.vec("pb.outRotate"), ro), expected));
                // Not the Euler blend: the two differ for these rotations.
                CHECK_FALSE(near(rig::eulerToMatrix(r1 + w * (r2 - r1), ro), expected, 1e-3));
            }
        }
        // Equal rotations written differently blend to that rotation, not through the Euler difference.
        f.set("pb.rotateOrder", 0);
        f.set("pb.inRotate1", v3(0, 0, deg(-170)));
        f.set("pb.inRotate2", v3(0, 0, deg(170)));
        f.set("pb.weight", 0.5);
        CHECK(near(rig::eulerToMatrix(f.vec("pb.outRotate"), rig::RotateOrder::xyz), rot(2, pi)));
    }
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: distanceBetween, setRange, inverseMatrix")
{
    Fixture f;
    f.add("distanceBetween", "db");
    f.set("db.point1", v3(1, 2, 3));
    f.set("db.point2", v3(4, 6, 3));
    CHECK(f.num("db.distance") == doctest::Approx(5.0));
    // point2 placed by a matrix turning (4, 6, 3) about Z by 90 degrees and moving it by (0, 0, 12): (-6, 4, 15).
    f.set("db.inMatrix2", affine(rot(2, pi / 2), v3(0, 0, 12)));
    CHECK(f.num("db.distance") == doctest::Approx(std::sqrt(49.0 + 4.0 + 144.0)));
    f.set("db.inMatrix1", affine(Eigen::Matrix3d::Identity(), v3(-7, 2, 12)));  // point1 at (-6, 4, 15)
    CHECK(f.num("db.distance") == doctest::Approx(0.0));

    f.add("setRange", "sr");
    f.set("sr.min", v3(0, 10, -1));
    f.set("sr.max", v3(1, 20, 1));
    f.set("sr.oldMin", v3(0, 0, 5));
    f.set("sr.oldMax", v3(360, 2, 5));
    f.set("sr.value", v3(90, 0.5, 5));
    CHECK(near(f.vec("sr.outValue"), v3(0.25, 12.5, -1)));  // oldMin == oldMax: value not above gives min
    f.set("sr.value", v3(400, -3, 6));
    CHECK(near(f.vec("sr.outValue"), v3(1, 10, 1)));  // held to the range; above an empty range gives max
    f.set("sr.oldMin", v3(360, 2, 5));                // a reversed old range maps its own start to min
    f.set("sr.oldMax", v3(0, 0, 5));
    f.set("sr.value", v3(270, 1.5, 0));
    CHECK(near(f.vec("sr.outValue"), v3(0.25, 12.5, -1)));

    f.add("inverseMatrix", "im");
    const Eigen::Matrix4d m =
        affine(rot(0, 0.3) * rot(1, -1.1) * Eigen::Vector3d(2, 0.5, 3).asDiagonal(), v3(4, -5, 6));
    f.set("im.inputMatrix", m);
    CHECK(near(f.mat("im.outputMatrix") * m, Eigen::Matrix4d::Identity()));
    f.set("im.inputMatrix", affine(Eigen::Vector3d(1, 0, 1).asDiagonal(), v3(1, 2, 3)));  // singular
    CHECK(near(f.mat("im.outputMatrix"), Eigen::Matrix4d::Identity()));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: angleBetween, including zero and opposite vectors")
{
    Fixture f;
    f.add("angleBetween", "ab");
    CHECK(f.num("ab.angle") == 0.0);  // equal defaults
    f.set("ab.vector1", v3(2, 0, 0));
    f.set("ab.vector2", v3(0, 3, 0));
    CHECK(f.num("ab.angle") == doctest::Approx(pi / 2));
    CHECK(near(f.vec("ab.axis"), v3(0, 0, 1)));
    CHECK(near(f.vec("ab.euler"), v3(0, 0, pi / 2)));
    // (1, 1, 0) onto (0, 0, 1): 90 degrees about (1, 1, 0) x (0, 0, 1) = (1, -1, 0) / sqrt 2.
    f.set("ab.vector1", v3(1, 1, 0));
    f.set("ab.vector2", v3(0, 0, 5));
    CHECK(f.num("ab.angle") == doctest::Approx(pi / 2));
    CHECK(near(f.vec("ab.axis"), v3(1, -1, 0) / std::sqrt(2.0)));
    const Eigen::Matrix3d turn = rig::eulerToMatrix(f.vec("ab.euler"), rig::RotateOrder::xyz);
    CHECK(near(turn * v3(1, 1, 0).normalized(), v3(0, 0, 1)));

    SUBCASE("a zero vector gives no turn")
    {
        f.set("ab.vector1", v3(0, 0, 0));
        CHECK(f.num("ab.angle") == 0.0);
        CHECK(near(f.vec("ab.axis"), v3(0, 0, 1)));
        CHECK(near(f.vec("ab.euler"), v3(0, 0, 0)));
    }
    SUBCASE("opposite vectors turn half a turn about a perpendicular axis")
    {
        f.set("ab.vector1", v3(0, 2, 1));
        f.set("ab.vector2", v3(0, -4, -2));
        CHECK(f.num("ab.angle") == doctest::Approx(pi));
        CHECK(std::abs(f.vec("ab.axis").dot(v3(0, 2, 1))) < tolerance);
        CHECK(f.vec("ab.axis").norm() == doctest::Approx(1.0));
        const Eigen::Matrix3d half = rig::eulerToMatrix(f.vec("ab.euler"), rig::RotateOrder::xyz);
        CHECK(near(half * v3(0, 2, 1).normalized(), v3(0, -2, -1).normalized()));
    }
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: eulerToQuat and quatToEuler")
{
    Fixture f;
    f.add("eulerToQuat", "eq");
    f.add("quatToEuler", "qe");
    auto quat = [&] {
        return Eigen::Vector4d(f.num("eq.outputQuatX"), f.num("eq.outputQuatY"), f.num("eq.outputQuatZ"),
                               f.num("eq.outputQuatW"));
    };
    f.set("eq.inputRotate", v3(0, 0, pi / 2));
    const double h = std::sqrt(0.5);
    CHECK(near(quat(), Eigen::Vector4d(0, 0, h, h)));
    f.set("eq.inputRotate", v3(0, 0, deg(270)));  // past a half turn: w < 0, as the angle gives it
    CHECK(near(quat(), Eigen::Vector4d(0, 0, h, -h)));

    for (const char* c : {"X", "Y", "Z", "W"})
        f.connect(std::string("eq.outputQuat") + c, std::string("qe.inputQuat") + c);
    f.connect("eq.inputRotateOrder", "qe.inputRotateOrder");
    // Every angle within its principal range in every order (middle axis within 90 degrees).
    const Eigen::Vector3d angles(deg(20), deg(-35), deg(70));
    f.set("eq.inputRotate", angles);
    for (int order = 0; order < 6; ++order) {
        CAPTURE(order);
        f.set("eq.inputRotateOrder", order);
        const auto ro = *rig::rotateOrderFromIndex(order);
        const Eigen::Quaterniond q(f.num("eq.outputQuatW"), f.num("eq.outputQuatX"), f.num("eq.outputQuatY"),
                                   f.num("eq.outputQuatZ"));
        CHECK(near(q.toRotationMatrix(), rig::eulerToMatrix(angles, ro)));
        CHECK(near(f.vec("qe.outputRotate"), angles));
    }
    Fixture g;
    g.add("quatToEuler", "qe");
    g.set("qe.inputQuatW", 0.0);  // all four zero: no rotation
    CHECK(near(g.vec("qe.outputRotate"), v3(0, 0, 0)));
    g.set("qe.inputQuatY", 3.0);  // not normalized: half a turn about Y
    CHECK(near(rig::eulerToMatrix(g.vec("qe.outputRotate"), rig::RotateOrder::xyz), rot(1, pi)));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: blendMatrix blends each target in turn")
{
    Fixture f;
    f.add("blendMatrix", "bm");
    const Eigen::Matrix4d from = affine(Eigen::Matrix3d::Identity(), v3(0, 0, 0));
    const Eigen::Matrix4d to = affine(rot(2, pi / 2) * Eigen::Vector3d(3, 3, 3).asDiagonal(), v3(10, -4, 2));
    f.set("bm.inputMatrix", from);
    CHECK(near(f.mat("bm.outputMatrix"), from));  // no targets
    f.set("bm.targetMatrix[0]", to);
    CHECK(near(f.mat("bm.outputMatrix"), to));  // weights default to 1
    f.set("bm.weight[0]", 0.5);
    CHECK(near(f.mat("bm.outputMatrix"), affine(rot(2, pi / 4) * 2.0, v3(5, -2, 1))));
    f.set("bm.rotateWeight[0]", 0.0);
    f.set("bm.scaleWeight[0]", 2.0);  // times the target's 0.5: all of the scale
    CHECK(near(f.mat("bm.outputMatrix"), affine(Eigen::Matrix3d::Identity() * 3.0, v3(5, -2, 1))));
    f.set("bm.envelope", 0.0);
    CHECK(near(f.mat("bm.outputMatrix"), from));
    f.set("bm.envelope", 1.0);
    f.set("bm.rotateWeight[0]", 1.0);
    f.set("bm.scaleWeight[0]", 1.0);
    // A second target at weight 1 overrides the first (an ordered blend, not an average).
    const Eigen::Matrix4d last = affine(rot(0, 0.4), v3(1, 1, 1));
    f.set("bm.targetMatrix[2]", last);
    CHECK(near(f.mat("bm.outputMatrix"), last));
    f.set("bm.translateWeight[2]", 0.0);  // the translation stays where target 0 left it
    CHECK(near(f.mat("bm.outputMatrix"), affine(rot(0, 0.4), v3(5, -2, 1))));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: animation layers sum as Maya's animBlendNode types")
{
    Fixture f;
    f.add("animBlendNodeAdditive", "add");
    f.set("add.inputA", 2.0);
    f.set("add.inputB", 3.0);
    CHECK(f.num("add.output") == 5.0);  // both weights default to 1
    f.set("add.weightB", 0.5);
    f.set("add.weightA", 0.25);
    CHECK(f.num("add.output") == 0.5 + 1.5);

    f.add("animBlendNodeAdditiveDA", "da");  // angles: degrees in a file, radians inside, summed alike
    f.set("da.inputA", deg(30));
    f.set("da.inputB", deg(15));
    f.set("da.weightB", 2.0);
    CHECK(f.num("da.output") == doctest::Approx(deg(60)));

    f.add("animBlendNodeAdditiveI32", "i32");
    f.set("i32.inputA", 3);
    f.set("i32.inputB", 4);
    f.set("i32.weightB", 0.4);
    CHECK(f.integer("i32.output") == 5);  // 4.6, the nearest integer

    f.add("animBlendNodeAdditiveScale", "sc");
    f.set("sc.inputA", 2.0);
    f.set("sc.inputB", 3.0);
    CHECK(f.num("sc.output") == doctest::Approx(6.0));  // multiply
    f.set("sc.weightB", 0.5);
    CHECK(f.num("sc.output") == doctest::Approx(2.0 * std::sqrt(3.0)));
    f.set("sc.weightB", 0.0);
    CHECK(f.num("sc.output") == doctest::Approx(2.0));  // a layer at weight 0 scales by 1
    f.set("sc.accumulationMode", 1);
    f.set("sc.weightB", 0.5);
    CHECK(f.num("sc.output") == doctest::Approx(3.5));  // additive
    f.set("sc.accumulationMode", 0);
    f.set("sc.inputA", -2.0);  // a negative scale to a fractional weight has no value
    f.set("sc.weightA", 0.5);
    CHECK(f.num("sc.output") == 0.0);

    f.add("animBlendNodeEnum", "en");
    f.set("en.inputA", 2);
    f.set("en.inputB", 5);
    CHECK(f.integer("en.output") == 5);
    f.set("en.weightB", 0.0);
    CHECK(f.integer("en.output") == 2);
    f.add("animBlendNodeBoolean", "bo");
    f.set("bo.inputB", true);
    CHECK(std::get<bool>(f.graph.getValue(f.graph.plug("bo.output"))));
    f.set("bo.weightB", 0.0);
    CHECK_FALSE(std::get<bool>(f.graph.getValue(f.graph.plug("bo.output"))));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: animBlendNodeAdditiveRotation by component and by layer")
{
    Fixture f;
    f.add("animBlendNodeAdditiveRotation", "r");
    const Eigen::Vector3d a(deg(90), 0, 0);
    const Eigen::Vector3d b(0, deg(90), 0);
    f.set("r.inputA", a);
    f.set("r.inputB", b);
    f.set("r.weightB", 0.5);
    CHECK(near(f.vec("r.output"), a + 0.5 * b));  // by component: Euler angles summed

    f.set("r.accumulationMode", 1);
    // By layer: this layer's half of a quarter turn about Y, after the layers below' quarter turn about X.
    CHECK(near(rig::eulerToMatrix(f.vec("r.output"), rig::RotateOrder::xyz), rot(1, deg(45)) * rot(0, deg(90))));
    f.set("r.rotateOrder", 2);  // zxy: the inputs are read, and the output written, in that order
    const auto zxy = rig::RotateOrder::zxy;
    const Eigen::Quaterniond qa(rig::eulerToMatrix(a, zxy));
    const Eigen::Quaterniond qb(rig::eulerToMatrix(b, zxy));
    CHECK(near(rig::eulerToMatrix(f.vec("r.output"), zxy),
               (Eigen::Quaterniond::Identity().slerp(0.5, qb) * qa).toRotationMatrix()));
    // About one axis, by layer and by component agree.
    f.set("r.inputA", v3(0, 0, deg(30)));
    f.set("r.inputB", v3(0, 0, deg(60)));
    f.set("r.weightB", 1.0);
    CHECK(near(f.vec("r.output"), v3(0, 0, deg(90))));
    CHECK(f.graph.checkEvaluation().empty());
}

TEST_CASE("maya utility nodes: remapValue's Maya ramp entries (value[i] flattened)")
{
    Fixture f;
    f.add("remapValue", "rv");
    // Entries by index, not in position order: [0] at 0 holds (none), [1] at 1, [2] at 0.5 linear to [1].
    f.set("rv.valuePosition[0]", 0.0);
    f.set("rv.valueFloatValue[0]", 0.0);
    f.set("rv.valueInterp[0]", 0);
    f.set("rv.valuePosition[1]", 1.0);
    f.set("rv.valueFloatValue[1]", 0.0);
    f.set("rv.valuePosition[2]", 0.5);
    f.set("rv.valueFloatValue[2]", 1.0);
    f.set("rv.inputValue", 0.25);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.0));  // held by entry 0
    f.set("rv.inputValue", 0.75);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.5));  // linear from entry 2 (Maya's default interp)
    f.set("rv.valueInterp[2]", 2);                        // smooth: a smoothstep from entry 2 down to entry 1
    f.set("rv.inputValue", 0.625);                        // a quarter of that span: 1 - (3s^2 - 2s^3) at s = 0.25
    CHECK(f.num("rv.outValue") == doctest::Approx(1.0 - (3 * 0.0625 - 2 * 0.015625)));
    // An entry given only its position has Maya's value 0.
    f.set("rv.valuePosition[5]", 0.625);
    CHECK(f.num("rv.outValue") == doctest::Approx(0.0));
    CHECK(f.graph.checkEvaluation().empty());

    // The flat pairs are the same entries by index: a field given replaces that entry's.
    Fixture g;
    g.add("remapValue", "rv");
    g.set("rv.value", std::vector<double>{0.0, 0.0, 1.0, 1.0});
    g.set("rv.inputValue", 0.5);
    CHECK(g.num("rv.outValue") == doctest::Approx(0.5));
    g.set("rv.valueFloatValue[1]", 0.5);  // entry 1 becomes (1, 0.5)
    CHECK(g.num("rv.outValue") == doctest::Approx(0.25));
    g.set("rv.valueInterp[0]", 0);  // entry 0 holds its value up to entry 1
    CHECK(g.num("rv.outValue") == doctest::Approx(0.0));
}

// The constraint node types read with Maya's own inputs (docs/constraints.md, "Maya's inputs"): targets wired as
// Maya wires them (target[i].targetTranslate, .targetRotatePivot, .targetParentMatrix, ...), the constrained object's
// pivots, joint orient and inverse scale, per-target offsets, interp types, rest positions, the scaleConstraint, and
// the same rig through this project's targetMatrix inputs giving the same answers.

#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <Eigen/Geometry>

#include "graph/graph.h"
#include "graph/yaml_loader.h"
#include "nodes/builtin_nodes.h"
#include "nodes/transform_math.h"

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

double deg(double degrees) { return degrees * pi / 180.0; }

Eigen::Vector3d v3(double x, double y, double z) { return Eigen::Vector3d(x, y, z); }

bool near(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol = tolerance)
{
    return a.rows() == b.rows() && a.cols() == b.cols() && (a - b).cwiseAbs().maxCoeff() <= tol;
}

Eigen::Matrix3d unscaled(const Eigen::Matrix4d& m)
{
    Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    for (int i = 0; i < 3; ++i) r.col(i).normalize();
    return r;
}

Eigen::Vector3d point(const Eigen::Matrix4d& m, const Eigen::Vector3d& p) { return (m * p.homogeneous()).head<3>(); }

Eigen::Vector3d position(const Eigen::Matrix4d& m) { return m.topRightCorner<3, 1>(); }

struct Rig {
    std::unique_ptr<rig::Graph> graph;

    explicit Rig(const std::string& yaml) : graph(rig::loadGraphText(yaml, "t.yaml", rig::makeBuiltinRegistry())) {}

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

// Maya's connections from a transform or joint `target` into element `i` of constraint `con`'s target compound.
std::string mayaTarget(const std::string& target, const std::string& con, int i,
                       const std::vector<std::string>& children)
{
    const std::map<std::string, std::string> source{{"targetTranslate", "translate"},
                                                    {"targetRotate", "rotate"},
                                                    {"targetRotateOrder", "rotateOrder"},
                                                    {"targetRotatePivot", "rotatePivot"},
                                                    {"targetRotateTranslate", "rotatePivotTranslate"},
                                                    {"targetScale", "scale"},
                                                    {"targetParentMatrix", "parentMatrix"},
                                                    {"targetJointOrient", "jointOrient"},
                                                    {"targetScaleCompensate", "segmentScaleCompensate"},
                                                    {"targetInverseScale", "inverseScale"}};
    std::string text;
    for (const std::string& child : children)
        text += fmt::format("  - {}.{} -> {}.{}[{}]\n", target, source.at(child), con, child, i);
    return text;
}

const std::vector<std::string> pointChildren{"targetTranslate", "targetRotatePivot", "targetRotateTranslate",
                                             "targetParentMatrix"};
const std::vector<std::string> orientChildren{"targetRotate", "targetRotateOrder", "targetParentMatrix",
                                              "targetJointOrient"};
const std::vector<std::string> parentChildren{
    "targetTranslate", "targetRotate",       "targetRotateOrder", "targetRotatePivot",     "targetRotateTranslate",
    "targetScale",     "targetParentMatrix", "targetJointOrient", "targetScaleCompensate", "targetInverseScale"};

// The children a joint (no pivots here) or a transform (no joint orient, inverse scale) can feed.
std::vector<std::string> without(const std::vector<std::string>& list, const std::set<std::string>& drop)
{
    std::vector<std::string> kept;
    for (const std::string& child : list)
        if (!drop.contains(child)) kept.push_back(child);
    return kept;
}
std::vector<std::string> forJoint(const std::vector<std::string>& list)
{
    return without(list, {"targetRotatePivot", "targetRotateTranslate"});
}
std::vector<std::string> forTransform(const std::vector<std::string>& list)
{
    return without(list, {"targetJointOrient", "targetScaleCompensate", "targetInverseScale"});
}

}  // namespace

TEST_CASE("Maya constraints: Maya's long and short names on every type")
{
    const auto registry = rig::makeBuiltinRegistry();
    const auto shortOf = [&](const std::string& type, const std::string& name) {
        const rig::NodeType* t = registry->find(type);
        REQUIRE(t != nullptr);
        const rig::AttrId a = t->findAttribute(name);
        REQUIRE(a >= 0);
        return t->attribute(a).shortName;
    };
    const std::map<std::string, std::vector<std::string>> targetChildren{
        {"pointConstraint", {"tw", "tt", "trp", "trt", "tpm"}},
        {"poleVectorConstraint", {"tw", "tt", "trp", "trt", "tpm"}},
        {"aimConstraint", {"tw", "tt", "trp", "trt", "tpm"}},
        {"orientConstraint", {"tw", "tr", "tro", "tpm", "tjo"}},
        {"parentConstraint", {"tw", "tt", "tr", "tro", "trp", "trt", "ts", "tpm", "tjo", "tsc", "tis", "tot", "tor"}},
        {"scaleConstraint", {"tw", "ts", "tpm"}}};
    for (const auto& [type, expected] : targetChildren) {
        CAPTURE(type);
        const rig::NodeType* t = registry->find(type);
        REQUIRE(t != nullptr);
        std::vector<std::string> shorts;
        for (rig::AttrId a : t->mayaCompoundChildren("tg")) shorts.push_back(t->attribute(a).shortName);
        CHECK(std::set<std::string>(shorts.begin(), shorts.end()) ==
              std::set<std::string>(expected.begin(), expected.end()));
        CHECK(t->mayaCompoundChildren("target") == t->mayaCompoundChildren("tg"));
        // Every Maya name is findable; targetMatrix (this project's) has none.
        CHECK(t->findMayaAttribute("cpim") == t->findAttribute("constraintParentInverseMatrix"));
        CHECK(t->findMayaAttribute("erp") == t->findAttribute("enableRestPosition"));
        CHECK(t->attribute(t->findAttribute("targetMatrix")).shortName.empty());
    }
    CHECK(shortOf("parentConstraint", "constraintTranslate") == "ct");
    CHECK(shortOf("parentConstraint", "constraintRotate") == "cr");
    CHECK(shortOf("parentConstraint", "constraintRotatePivot") == "crp");
    CHECK(shortOf("parentConstraint", "constraintRotateTranslate") == "crt");
    CHECK(shortOf("parentConstraint", "constraintRotateOrder") == "cro");
    CHECK(shortOf("parentConstraint", "constraintJointOrient") == "cjo");
    CHECK(shortOf("parentConstraint", "restTranslate") == "rst");
    CHECK(shortOf("parentConstraint", "restRotate") == "rsrr");
    CHECK(shortOf("parentConstraint", "interpType") == "int");
    CHECK(shortOf("orientConstraint", "inverseScale") == "is");
    CHECK(shortOf("aimConstraint", "aimVector") == "a");
    CHECK(shortOf("aimConstraint", "upVector") == "u");
    CHECK(shortOf("aimConstraint", "worldUpType") == "wut");
    CHECK(shortOf("aimConstraint", "worldUpVector") == "wu");
    CHECK(shortOf("aimConstraint", "worldUpMatrix") == "wum");
    CHECK(shortOf("aimConstraint", "constraintTranslate") == "ct");
    CHECK(shortOf("pointConstraint", "offset") == "o");
    CHECK(shortOf("poleVectorConstraint", "pivotSpace") == "ps");
    CHECK(shortOf("scaleConstraint", "constraintScale") == "cs");
    CHECK(shortOf("scaleConstraint", "constraintScaleCompensate") == "tsc");
    // A vector3's children: ctx from ct, Maya's own rrx for restRotate (not rsrrx).
    const rig::NodeType* parent = registry->find("parentConstraint");
    const auto& ct = parent->attribute(parent->findAttribute("constraintTranslate"));
    CHECK(rig::mayaChildIndex(ct, "cty") == 1);
    const auto& rr = parent->attribute(parent->findAttribute("restRotate"));
    CHECK(rig::mayaChildIndex(rr, "rrz") == 2);
    CHECK(registry->find("parentConstraint")->mayaCompoundChildren("tg").size() == 13);
}

TEST_CASE("Maya pointConstraint: the constrained pivot lands on the weighted target pivot, in a turned, scaled parent")
{
    // Targets with rotate pivots (their scale pivots on them, as Maya's insert mode moves both) under turned,
    // scaled parents; the object has its own pivots under a turned, non-uniformly scaled parent.
    const std::string yaml = R"(
nodes:
  - {name: tp0, type: transform, translate: [3, -2, 5], rotate: [20, 40, -10], scale: [2, 2, 2]}
  - {name: a, type: transform, parent: tp0, translate: [1, 2, 3], rotate: [30, 0, 45], scale: [1.5, 0.5, 2],
     rotatePivot: [0.5, -1, 2], scalePivot: [0.5, -1, 2], rotatePivotTranslate: [0.25, 0, -0.5]}
  - {name: tp1, type: transform, translate: [-4, 1, 0], rotate: [0, -70, 0]}
  - {name: b, type: joint, parent: tp1, translate: [2, 0, 1], jointOrient: [0, 0, 30], rotate: [10, 0, 0]}
  - {name: op, type: transform, translate: [1, 1, 1], rotate: [0, 30, 60], scale: [1, 2, 3]}
  - {name: obj, type: transform, parent: op, rotate: [15, 25, 35], rotatePivot: [1, 0, -1], scalePivot: [1, 0, -1],
     rotatePivotTranslate: [0, 2, 0]}
  - name: pc
    type: pointConstraint
    targetWeight: [1, 3]
    constraintRotatePivot: [1, 0, -1]           # = obj.rotatePivot
    constraintRotateTranslate: [0, 2, 0]        # = obj.rotatePivotTranslate
connections:
)" + mayaTarget("a", "pc", 0, pointChildren) +
                             mayaTarget("b", "pc", 1, {"targetTranslate", "targetParentMatrix"}) + R"(
  - op.worldInverseMatrix -> pc.constraintParentInverseMatrix
  - pc.constraintTranslate -> obj.translate
)";
    Rig r(yaml);
    const Eigen::Vector3d pa = point(r.mat("a.worldMatrix"), v3(0.5, -1, 2));  // a's rotate pivot in the world
    const Eigen::Vector3d pb = position(r.mat("b.worldMatrix"));
    const Eigen::Vector3d expected = (1.0 * pa + 3.0 * pb) / 4.0;
    CHECK(near(point(r.mat("obj.worldMatrix"), v3(1, 0, -1)), expected));
    SUBCASE("offset is added in the parent's space")
    {
        r.set("pc.offset", v3(1, -2, 0.5));
        CHECK(near(r.vec("obj.translate"), Eigen::Vector3d(point(r.mat("op.worldInverseMatrix"), expected) -
                                                           v3(1, 0, -1) - v3(0, 2, 0) + v3(1, -2, 0.5))));
    }
    CHECK(r.check() == "");
}

TEST_CASE("Maya parentConstraint: the target's world matrix times its offset (tot, tor)")
{
    // A joint target with joint orient, rotate order, scale compensation of a scaled parent; the object under a
    // turned parent, in rotate order yzx, with the offsets Maya stores per target.
    const std::string yaml = R"(
nodes:
  - {name: root, type: transform, translate: [0, 10, 0], rotate: [0, 0, 30]}
  - {name: chest, type: joint, parent: root, translate: [2, 3, 4], rotate: [10, 20, 30], scale: [2, 3, 0.5]}
  - {name: ctrl, type: joint, parent: chest, translate: [5, 0, 0], rotate: [40, -10, 25], rotateOrder: zxy,
     jointOrient: [0, 90, 15]}
  - {name: op, type: transform, translate: [-3, 0, 2], rotate: [45, 0, 10]}
  - {name: obj, type: transform, parent: op, rotateOrder: yzx}
  - name: prc
    type: parentConstraint
    constraintRotateOrder: yzx                  # = obj.rotateOrder
    targetOffsetTranslate: [[1, 2, -3]]
    targetOffsetRotate: [[10, 50, -30]]
connections:
)" + mayaTarget("ctrl", "prc", 0, forJoint(parentChildren)) +
                             R"(
  - op.worldInverseMatrix -> prc.constraintParentInverseMatrix
  - prc.constraintTranslate -> obj.translate
  - prc.constraintRotate -> obj.rotate
)";
    Rig r(yaml);
    Eigen::Matrix4d offset = Eigen::Matrix4d::Identity();
    offset.topLeftCorner<3, 3>() = rig::eulerToMatrix(v3(deg(10), deg(50), deg(-30)), rig::RotateOrder::yzx);
    offset.topRightCorner<3, 1>() = v3(1, 2, -3);
    const Eigen::Matrix4d expected = r.mat("ctrl.worldMatrix") * offset;
    const Eigen::Matrix4d world = r.mat("obj.worldMatrix");
    CHECK(near(position(world), position(expected)));
    CHECK(near(world.topLeftCorner<3, 3>(), unscaled(expected)));
    SUBCASE("two targets: positions blend linearly")
    {
        r.connect("root.worldMatrix", "prc.targetParentMatrix[1]");
        r.set("prc.targetTranslate[1]", v3(4, 0, 0));
        r.set("prc.targetWeight[1]", 3.0);
        const Eigen::Vector3d second = point(r.mat("root.worldMatrix"), v3(4, 0, 0));
        CHECK(near(position(r.mat("obj.worldMatrix")), Eigen::Vector3d((position(expected) + 3.0 * second) / 4.0)));
    }
    CHECK(r.check() == "");
}

TEST_CASE("Maya orientConstraint: joint orients on target and object, inverse scale of a scaled parent")
{
    const std::string yaml = R"(
nodes:
  - {name: tp, type: transform, rotate: [30, 60, 0], scale: [2, 2, 2]}
  - {name: target, type: joint, parent: tp, rotate: [10, 20, 30], rotateOrder: yxz, jointOrient: [0, 0, 90]}
  - {name: hip, type: joint, rotate: [0, 0, 40], scale: [1, 2, 3]}
  - {name: knee, type: joint, parent: hip, translate: [5, 0, 0], jointOrient: [20, -30, 10], rotateOrder: zyx}
  - name: oc
    type: orientConstraint
    constraintJointOrient: [20, -30, 10]        # = knee.jointOrient
    constraintRotateOrder: zyx                  # = knee.rotateOrder
    offset: [0, 0, 15]
connections:
  - hip.scale -> oc.inverseScale               # what feeds knee.inverseScale (a joint's parent's scale)
)" + mayaTarget("target", "oc", 0, orientChildren) +
                             R"(
  - hip.worldInverseMatrix -> oc.constraintParentInverseMatrix
  - oc.constraintRotate -> knee.rotate
)";
    Rig r(yaml);
    const Eigen::Matrix3d expected =
        unscaled(r.mat("target.worldMatrix")) * rig::eulerToMatrix(v3(0, 0, deg(15)), rig::RotateOrder::xyz);
    // hip's non-uniform scale is compensated: knee's frame is a rotation, and exactly the target's.
    CHECK(near(unscaled(r.mat("knee.worldMatrix")), expected));
    CHECK(near(Eigen::Matrix3d(r.mat("knee.worldMatrix").topLeftCorner<3, 3>()), expected));
    CHECK(r.check() == "");
}

TEST_CASE("Maya orientConstraint: interpType average, shortest and longest")
{
    Rig r(R"(
nodes:
  - {name: oc, type: orientConstraint, targetRotate: [[0, 0, 0], [0, 0, 90]]}
)");
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(45))));  // average, the default
    r.set("oc.interpType", 2);                                     // shortest
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(45))));
    r.set("oc.interpType", 3);  // longest: the other way round, through 225 = -135
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(-135))));
    r.set("oc.interpType", 2);
    r.set("oc.targetWeight[1]", 3.0);  // slerp a quarter of the way back from 90: 67.5 (average gives less)
    CHECK(near(r.vec("oc.constraintRotate"), v3(0, 0, deg(67.5))));
    r.set("oc.interpType", 1);  // the normalized sum: half angle atan2(3 sin 45, 1 + 3 cos 45)
    CHECK(near(r.vec("oc.constraintRotate"),
               v3(0, 0, 2.0 * std::atan2(3.0 * std::sin(pi / 4), 1.0 + 3.0 * std::cos(pi / 4)))));
}

TEST_CASE("Maya aimConstraint: every worldUpType, the object's pivot aiming")
{
    const std::string yaml = R"(
nodes:
  - {name: tp, type: transform, translate: [0, 5, 0], rotate: [0, 30, 0]}
  - {name: look, type: transform, parent: tp, translate: [10, 2, -3], rotatePivot: [0, 1, 0]}
  - {name: op, type: transform, translate: [1, 2, 3], rotate: [0, 0, 20]}
  - {name: upObj, type: transform, translate: [3, 40, 7], rotate: [0, 0, 90]}
  - {name: obj, type: transform, parent: op, translate: [2, 0, 1], rotatePivot: [0, 0, 1], rotateOrder: zxy}
  - name: ac
    type: aimConstraint
    aimVector: [0, 0, 1]
    upVector: [0, 1, 0]
    worldUpVector: [1, 1, 0]
    constraintTranslate: [2, 0, 1]              # = obj.translate
    constraintRotatePivot: [0, 0, 1]            # = obj.rotatePivot
    constraintRotateOrder: zxy
connections:
)" + mayaTarget("look", "ac", 0, pointChildren) +
                             R"(
  - upObj.worldMatrix -> ac.worldUpMatrix
  - op.worldInverseMatrix -> ac.constraintParentInverseMatrix
  - ac.constraintRotate -> obj.rotate
)";
    Rig r(yaml);
    const Eigen::Vector3d target = point(r.mat("tp.worldMatrix"), v3(10, 3, -3));
    const Eigen::Vector3d pivot = point(r.mat("op.worldMatrix"), v3(2, 0, 2));
    const Eigen::Vector3d A = (target - pivot).normalized();
    const std::vector<std::pair<int, Eigen::Vector3d>> ups{
        {0, v3(0, 1, 0)},                                                    // scene
        {1, Eigen::Vector3d(position(r.mat("upObj.worldMatrix")) - pivot)},  // object
        {2, unscaled(r.mat("upObj.worldMatrix")) * v3(1, 1, 0)},             // objectRotation
        {3, v3(1, 1, 0)},                                                    // vector
        {4, Eigen::Vector3d::Zero()}};                                       // none
    for (const auto& [type, worldUp] : ups) {
        CAPTURE(type);
        r.set("ac.worldUpType", type);
        const Eigen::Matrix3d w = unscaled(r.mat("obj.worldMatrix"));
        CHECK(near(Eigen::Vector3d(w * v3(0, 0, 1)), A));
        CHECK(near(point(r.mat("obj.worldMatrix"), v3(0, 0, 1)), pivot));  // the pivot stays put
        if (type == 4) continue;
        // The up axis lies in the plane of A and the world up, on the world up's side.
        const Eigen::Vector3d up = w * v3(0, 1, 0);
        CHECK(std::abs(up.dot(A.cross(worldUp).normalized())) < 1e-9);
        CHECK(up.dot(worldUp - worldUp.dot(A) * A) > 0.0);
    }
    CHECK(r.check() == "");
}

TEST_CASE("Maya poleVectorConstraint: the pole's pivot minus the start joint's position, as Maya wires it")
{
    // Maya connects startJoint.parentMatrix -> pivotSpace, startJoint.translate -> constraintRotatePivot, the pole
    // control's t/rp/rpt/pm -> target[0], and the ikHandle's parentInverseMatrix -> constraintParentInverseMatrix.
    const std::string yaml = R"(
nodes:
  - {name: chest, type: joint, translate: [0, 140, 0], rotate: [0, 0, 30]}
  - {name: shoulder, type: joint, parent: chest, translate: [0, 10, 2]}
  - {name: ctrls, type: transform, translate: [5, 0, 5], rotate: [0, 45, 0]}
  - {name: pole, type: transform, parent: ctrls, translate: [25, 170, -20], rotatePivot: [1, 2, 3],
     rotatePivotTranslate: [0, -1, 0]}
  - {name: handleParent, type: transform, rotate: [90, 0, 0], translate: [7, 8, 9]}
  - {name: pvc, type: poleVectorConstraint, constraintRotatePivot: [0, 10, 2]}
connections:
  - chest.worldMatrix -> pvc.pivotSpace
)" + mayaTarget("pole", "pvc", 0, pointChildren);
    Rig r(yaml);
    const Eigen::Vector3d pole = point(r.mat("ctrls.worldMatrix"), v3(26, 171, -17));
    const Eigen::Vector3d start = position(r.mat("shoulder.worldMatrix"));
    CHECK(near(r.vec("pvc.constraintTranslate"), Eigen::Vector3d(pole - start)));
    r.connect("handleParent.worldInverseMatrix", "pvc.constraintParentInverseMatrix");
    const Eigen::Matrix3d L = r.mat("handleParent.worldInverseMatrix").topLeftCorner<3, 3>();
    CHECK(near(r.vec("pvc.constraintTranslate"), Eigen::Vector3d(L * (pole - start))));
    CHECK(r.check() == "");
}

TEST_CASE("Maya scaleConstraint: weighted geometric mean of the world scales, the parent's divided out")
{
    const std::string yaml = R"(
nodes:
  - {name: tp, type: transform, scale: [2, 2, 2], rotate: [10, 20, 30]}
  - {name: a, type: transform, parent: tp, scale: [1, 3, 0.5]}
  - {name: b, type: transform, scale: [4, 1, 2]}
  - {name: op, type: transform, rotate: [0, 0, 45], scale: [0.5, 0.5, 0.5]}
  - {name: obj, type: transform, parent: op}
  - {name: sc, type: scaleConstraint, targetWeight: [1, 3], offset: [1, 2, 1]}
connections:
  - a.scale -> sc.targetScale[0]
  - tp.worldMatrix -> sc.targetParentMatrix[0]
  - b.scale -> sc.targetScale[1]
  - op.worldInverseMatrix -> sc.constraintParentInverseMatrix
  - sc.constraintScale -> obj.scale
)";
    Rig r(yaml);
    const auto mean = [](double s0, double s1) { return std::pow(s0, 0.25) * std::pow(s1, 0.75); };
    const Eigen::Vector3d expected(mean(2, 4), 2.0 * mean(6, 1), mean(1, 2));
    CHECK(near(rig::decomposeMatrix(r.mat("obj.worldMatrix"), rig::RotateOrder::xyz).scale, expected));
    CHECK(near(r.vec("obj.scale"), Eigen::Vector3d(2.0 * expected)));
    SUBCASE("rest position with every weight zero; the output's default with enableRestPosition off")
    {
        r.set("sc.restScale", v3(3, 4, 5));
        r.set("sc.targetWeight[0]", 0.0);
        r.set("sc.targetWeight[1]", 0.0);
        CHECK(near(r.vec("sc.constraintScale"), v3(3, 4, 5)));
        r.set("sc.enableRestPosition", false);
        CHECK(near(r.vec("sc.constraintScale"), v3(1, 1, 1)));
    }
    CHECK(r.check() == "");
}

TEST_CASE("Maya constraints: rest position when every weight is zero, and with enableRestPosition off")
{
    Rig r(R"(
nodes:
  - {name: t, type: transform, translate: [1, 2, 3], rotate: [10, 20, 30]}
  - {name: pc, type: pointConstraint, targetWeight: [0], restTranslate: [4, 5, 6]}
  - {name: oc, type: orientConstraint, targetWeight: [0], restRotate: [7, 8, 9]}
  - {name: prc, type: parentConstraint, targetWeight: [0], restTranslate: [4, 5, 6], restRotate: [7, 8, 9]}
  - {name: ac, type: aimConstraint, targetWeight: [0], restRotate: [7, 8, 9]}
  - {name: pvc, type: poleVectorConstraint, targetWeight: [0], restTranslate: [4, 5, 6]}
connections:
  - t.translate -> pc.targetTranslate[0]
  - t.rotate -> oc.targetRotate[0]
  - t.translate -> prc.targetTranslate[0]
  - t.rotate -> prc.targetRotate[0]
  - t.translate -> ac.targetTranslate[0]
  - t.translate -> pvc.targetTranslate[0]
)");
    const Eigen::Vector3d rest = v3(4, 5, 6);
    const Eigen::Vector3d restRotate = v3(deg(7), deg(8), deg(9));
    CHECK(near(r.vec("pc.constraintTranslate"), rest));
    CHECK(near(r.vec("oc.constraintRotate"), restRotate));
    CHECK(near(r.vec("prc.constraintTranslate"), rest));
    CHECK(near(r.vec("prc.constraintRotate"), restRotate));
    CHECK(near(r.vec("ac.constraintRotate"), restRotate));
    CHECK(near(r.vec("pvc.constraintTranslate"), rest));
    for (const char* node : {"pc", "oc", "prc", "ac", "pvc"}) r.set(fmt::format("{}.enableRestPosition", node), false);
    const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
    CHECK(near(r.vec("pc.constraintTranslate"), zero));
    CHECK(near(r.vec("oc.constraintRotate"), zero));
    CHECK(near(r.vec("prc.constraintTranslate"), zero));
    CHECK(near(r.vec("prc.constraintRotate"), zero));
    CHECK(near(r.vec("ac.constraintRotate"), zero));
    CHECK(near(r.vec("pvc.constraintTranslate"), zero));
    // A positive weight: the target again.
    r.set("pc.targetWeight[0]", 0.5);
    CHECK(near(r.vec("pc.constraintTranslate"), v3(1, 2, 3)));
}

TEST_CASE("Maya constraints: Maya's inputs give what targetMatrix gives on the same rig")
{
    // Two constraints of each type on the same targets, one reading their worldMatrix (this project's input), one
    // wired as Maya wires them; zero target pivots, uniform target scales.
    std::string yaml = R"(
nodes:
  - {name: tp, type: transform, translate: [1, 2, 3], rotate: [20, -30, 40], scale: [1.5, 1.5, 1.5]}
  - {name: a, type: joint, parent: tp, translate: [4, 0, 1], rotate: [10, 20, 30], rotateOrder: zxy,
     jointOrient: [0, 45, 0], scale: [2, 2, 2]}
  - {name: b, type: transform, translate: [-3, 6, 2], rotate: [0, 80, 10], scale: [0.5, 0.5, 0.5]}
  - {name: op, type: transform, translate: [0, 1, 0], rotate: [5, 10, 15], scale: [1, 2, 1]}
  - {name: start, type: joint, parent: op, translate: [1, 1, 1]}
)";
    std::string connections = "connections:\n";
    const std::map<std::string, std::vector<std::string>> children{
        {"pointConstraint", pointChildren},      {"orientConstraint", orientChildren},
        {"parentConstraint", parentChildren},    {"aimConstraint", pointChildren},
        {"poleVectorConstraint", pointChildren}, {"scaleConstraint", {"targetScale", "targetParentMatrix"}}};
    for (const auto& [type, list] : children) {
        for (const char* path : {"Old", "Maya"}) {
            const std::string name = type + path;
            yaml += fmt::format("  - {{name: {}, type: {}, targetWeight: [1, 2]}}\n", name, type);
            connections += fmt::format("  - op.worldInverseMatrix -> {}.constraintParentInverseMatrix\n", name);
            if (type == "poleVectorConstraint")
                connections += fmt::format("  - op.worldMatrix -> {}.pivotSpace\n", name);
            for (int i = 0; i < 2; ++i) {
                const std::string target = i == 0 ? "a" : "b";
                if (std::string(path) == "Old")
                    connections += fmt::format("  - {}.worldMatrix -> {}.targetMatrix[{}]\n", target, name, i);
                else connections += mayaTarget(target, name, i, i == 0 ? forJoint(list) : forTransform(list));
            }
        }
    }
    Rig r(yaml + connections);
    for (const char* offset : {"Old", "Maya"})
        r.set(fmt::format("aimConstraint{}.constraintTranslate", offset), v3(1, 1, 1));
    for (const char* offset : {"Old", "Maya"})
        r.set(fmt::format("poleVectorConstraint{}.constraintRotatePivot", offset), v3(1, 1, 1));
    // parentConstraint: the old path's per-target offset matrix against Maya's tot / tor.
    Eigen::Matrix4d offset = Eigen::Matrix4d::Identity();
    offset.topLeftCorner<3, 3>() = rig::eulerToMatrix(v3(deg(30), deg(-20), deg(70)), rig::RotateOrder::xyz);
    offset.topRightCorner<3, 1>() = v3(2, -1, 0.5);
    for (int i = 0; i < 2; ++i) {
        r.set(fmt::format("parentConstraintOld.targetOffset[{}]", i), offset);
        r.set(fmt::format("parentConstraintMaya.targetOffsetTranslate[{}]", i), v3(2, -1, 0.5));
        r.set(fmt::format("parentConstraintMaya.targetOffsetRotate[{}]", i), v3(deg(30), deg(-20), deg(70)));
    }
    const std::vector<std::pair<std::string, std::string>> outputs{
        {"pointConstraint", "constraintTranslate"},  {"orientConstraint", "constraintRotate"},
        {"parentConstraint", "constraintTranslate"}, {"parentConstraint", "constraintRotate"},
        {"aimConstraint", "constraintRotate"},       {"poleVectorConstraint", "constraintTranslate"},
        {"scaleConstraint", "constraintScale"}};
    for (const auto& [type, output] : outputs) {
        CAPTURE(type);
        CAPTURE(output);
        const Eigen::Vector3d old = r.vec(type + "Old." + output);
        CHECK(near(old, r.vec(type + "Maya." + output)));
        CHECK(old.norm() > 1e-3);  // a real answer, not two defaults
    }
    CHECK(r.check() == "");
}

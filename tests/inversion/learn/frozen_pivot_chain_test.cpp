// Maya IK chains whose controls were frozen (Freeze Transformations: translate 0, the control's place held in its
// rotatePivot), as the public scenes' tongue and legs are (docs/maya.md, "The scenes' IK chains in the learner"). A
// pole-vector constraint reads its target at translate + rotatePivot + rotatePivotTranslate, never at the target's
// worldMatrix origin, which a frozen control leaves at its parent's: the helper frames are read at their rotate pivots
// (GraphRigFunction::outputs), and the chains are planar chains again. Before, the pole the learner read was the
// parent's origin, the chain's plane turned about its line by the angle between the two, and the joints were left
// unmodelled (the tongue 0.119, the robot's legs 0.054 cm per unit off). Then the public scenes themselves, where
// ../shared/maya is present.
#include <doctest/doctest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "adapter/graph_rig_function.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/learn/maya_chain_scene.h"
#include "inversion/model/approximation.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

namespace fs = std::filesystem;

// A two-bone chain j1 -> j2 -> j3 along +x, straight at rest with its goal at its full reach (the tongue): j2's
// preferred angle bends it about z. Its start joint is point-constrained to shoulder_ctrl, the ikHandle hangs under
// hand_ctrl, the pole vector is constrained to pole_ctrl. The three controls are frozen: translate 0, their places
// in rotatePivot and scalePivot, so that each one's worldMatrix origin is the world's origin.
const std::string straightChain = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "shoulder_ctrl";
	setAttr ".rp" -type "double3" 0 10 0 ;
	setAttr ".sp" -type "double3" 0 10 0 ;
createNode transform -n "hand_ctrl";
	setAttr ".rp" -type "double3" 9 10 0 ;
	setAttr ".sp" -type "double3" 9 10 0 ;
createNode transform -n "pole_ctrl";
	setAttr ".rp" -type "double3" 4 14 -6 ;
	setAttr ".sp" -type "double3" 4 14 -6 ;
createNode joint -n "root_jnt";
createNode joint -n "j1" -p "root_jnt";
	setAttr ".t" -type "double3" 0 10 0 ;
createNode joint -n "j2" -p "j1";
	setAttr ".t" -type "double3" 5 0 0 ;
	setAttr ".pa" -type "double3" 0 0 90 ;
createNode joint -n "j3" -p "j2";
	setAttr ".t" -type "double3" 4 0 0 ;
createNode ikEffector -n "effector1" -p "j2";
createNode ikHandle -n "ikHandle1" -p "hand_ctrl";
	setAttr ".t" -type "double3" 9 10 0 ;
	setAttr ".roc" yes;
)";

// The same chain bent at rest, its handle under the ankle joint of a reverse foot (heel -> ball -> ankle, joints
// under a frozen foot control that turns about the heel), as C_Robot_Rig's legs: the goal goes past the leg's reach
// on most random poses of the foot, and the knee control is frozen.
const std::string reverseFootChain = R"(//Maya ASCII 2023 scene
requires maya "2023";
currentUnit -l centimeter -a degree -t film;
createNode transform -n "shoulder_ctrl";
	setAttr ".rp" -type "double3" 0 10 0 ;
	setAttr ".sp" -type "double3" 0 10 0 ;
createNode transform -n "hand_ctrl";
	setAttr ".rp" -type "double3" 6 14 0 ;
	setAttr ".sp" -type "double3" 6 14 0 ;
createNode joint -n "heel" -p "hand_ctrl";
	setAttr ".t" -type "double3" 6 14 0 ;
createNode joint -n "ball" -p "heel";
	setAttr ".t" -type "double3" 2 0 1 ;
createNode joint -n "ankle" -p "ball";
	setAttr ".t" -type "double3" -1 -1 -1 ;
createNode transform -n "pole_ctrl";
	setAttr ".rp" -type "double3" 4 14 -6 ;
	setAttr ".sp" -type "double3" 4 14 -6 ;
createNode joint -n "root_jnt";
createNode joint -n "j1" -p "root_jnt";
	setAttr ".t" -type "double3" 0 10 0 ;
createNode joint -n "j2" -p "j1";
	setAttr ".t" -type "double3" 5 0 0 ;
	setAttr ".r" -type "double3" 0 0 90 ;
createNode joint -n "j3" -p "j2";
	setAttr ".t" -type "double3" 4 0 0 ;
createNode ikEffector -n "effector1" -p "j2";
createNode ikHandle -n "ikHandle1" -p "ankle";
	setAttr ".roc" yes;
)";

GraphRigOptions chainOptions(std::vector<std::string> parameters)
{
    GraphRigOptions options{std::move(parameters), {"root_jnt", "j1", "j2", "j3"}, {}, {}};
    options.autoHelpers = true;
    return options;
}

// The scene written with the chain's connections, its rig, and what the learner makes of it.
struct Learned {
    fs::path file;
    GraphRigFunction rig;
    Approximation approximation;

    Learned(const std::string& name, const std::string& scene, std::vector<std::string> parameters)
        : file(test::writeFile(test::scratchDir(fmt::format("frozen-pivot.{}", ::getpid())) / name,
                               scene + test::mayaChainConnections)),
          rig(file, chainOptions(std::move(parameters))),
          approximation(learnApproximation(rig, LearnOptions{}, file.string()))
    {
    }
};

// Every chain joint a planar chain on the pole control, its goal one of `goals` (the ikHandle, or the transform or
// joint it hangs from at the same point), the approximation within epsilon, and random poses (the goal past the chain's
// reach on most) solved from rest on the real rig.
void checkChain(Learned& learned, const std::vector<std::string>& goals)
{
    const Approximation& a = learned.approximation;
    for (const ApproximationOutput& o : a.outputs)
        if (!o.modelled) MESSAGE(o.name << " is not modelled");
    CHECK_FALSE(a.hasUnmodelledOutputs());
    CHECK(a.validation.withinEpsilon);
    const auto name = [&](int k) { return k < 0 ? std::string("-") : a.outputs[static_cast<std::size_t>(k)].name; };
    for (const char* joint : {"j1", "j2"}) {
        CAPTURE(joint);
        const ApproximationOutput& o = a.outputs[static_cast<std::size_t>(test::outputIndex(a, joint))];
        REQUIRE(o.constraint >= 0);
        const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
        CHECK(name(c.anchor) == "shoulder_ctrl");
        CHECK(std::find(goals.begin(), goals.end(), name(c.goal)) != goals.end());
        CHECK(name(c.pole) == "pole_ctrl");
    }
    RigBinding binding(a, learned.rig);
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(5);
    const int poses = 20;
    CHECK(test::posesReachedFromRest(a, solver, binding, rng, poses, 0.5) >= poses * 95 / 100);
}

}  // namespace

TEST_CASE("frozen pivots: a helper frame is read at its rotate pivot, where the rig's constraints read it")
{
    const fs::path file = test::writeFile(test::scratchDir(fmt::format("frozen-pivot.{}", ::getpid())) / "pivots.ma",
                                          straightChain + test::mayaChainConnections);
    GraphRigOptions options{{"pole_ctrl.translate?", "pole_ctrl.rotate?"}, {"root_jnt", "j1", "j2", "j3"}, {}, {}};
    options.autoHelpers = true;
    GraphRigFunction rig(file, options);
    const auto index = [&](const std::string& name) {
        for (std::size_t k = 0; k < rig.outputs().size(); ++k)
            if (rig.outputs()[k] == name) return static_cast<int>(k);
        return -1;
    };
    const int pole = index("pole_ctrl"), j2 = index("j2");
    REQUIRE(j2 >= 0);
    REQUIRE(pole >= 0);
    CHECK(rig.helperOutputs()[static_cast<std::size_t>(pole)]);
    // Turned about its pivot and moved: the frame's origin is the pivot's world place (translate + rotatePivot), its
    // axes the worldMatrix's.
    std::vector<double> values(rig.parameters().size(), 0.0);
    values[0] = 1.0;  // translateX
    values[4] = 0.7;  // rotateY (radians)
    std::vector<Eigen::Matrix4d> worlds;
    rig.evaluate(values, worlds);
    const Eigen::Matrix4d& w = worlds[static_cast<std::size_t>(pole)];
    CHECK((w.block<3, 1>(0, 3) - Eigen::Vector3d(5, 14, -6)).norm() < 1e-12);
    CHECK((w.block<3, 3>(0, 0) - Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()).toRotationMatrix()).norm() < 1e-12);
    // The joints are outputs as their worldMatrix.
    CHECK((worlds[static_cast<std::size_t>(j2)].block<3, 1>(0, 3) - Eigen::Vector3d(5, 10, 0)).norm() < 1e-9);
}

TEST_CASE("frozen pivots: a chain straight at rest turned by its frozen pole control is a planar chain")
{
    // The goal past the reach (9 cm) on most poses of the controls' +-50 cm: the straight chain turns with the pole
    // in its preferred angles' plane.
    Learned learned("straight.ma", straightChain,
                    {"shoulder_ctrl.translate?", "hand_ctrl.translate?", "pole_ctrl.translate?"});
    checkChain(learned, {"hand_ctrl", "ikHandle1"});
}

TEST_CASE("frozen pivots: a leg whose goal hangs from a reverse foot, its knee control frozen, is a planar chain")
{
    Learned learned("reverse_foot.ma", reverseFootChain,
                    {"shoulder_ctrl.translate?", "hand_ctrl.translate?", "hand_ctrl.rotate?", "pole_ctrl.translate?"});
    // The goal is the ankle joint of the reverse foot or the handle on it: both are the same point.
    checkChain(learned, {"ankle", "ikHandle1"});
}

TEST_CASE("frozen pivots: the public scenes' tongue and legs are modelled with --params auto, where present")
{
    const fs::path folder = test::sourceDir() / "../shared/maya";
    const fs::path tongue = folder / "I-LoveBees__Maya/mimic_RigTestAnim.ma";
    const fs::path robot = folder / "sweet4lorie__MonsterRobotRunner/ART/C_Robot/C_Robot_Rig.ma";
    if (!fs::exists(tongue) || !fs::exists(robot)) {
        MESSAGE("[skipped] ../shared/maya's mimic_RigTestAnim.ma or C_Robot_Rig.ma is absent");
        return;
    }
    struct Scene {
        fs::path file;
        std::vector<std::string> chainJoints;
        std::string pole;
    };
    for (const Scene& scene : {Scene{tongue, {"tounge_01_jnt", "tounge_02_jnt"}, "tounge_02_ctrl"},
                               Scene{robot, {"L_hip_joint", "L_knee_joint", "R_hip_joint", "R_knee_joint"}, ""}}) {
        CAPTURE(scene.file.filename().string());
        GraphRigOptions options;
        options.autoParameters = true;
        options.autoOutputs = true;
        options.autoHelpers = true;
        options.cutTimeCurves = true;
        GraphRigFunction rig(scene.file, options);
        const Approximation a = learnApproximation(rig, LearnOptions{}, scene.file.string());
        for (const ApproximationOutput& o : a.outputs)
            if (!o.modelled) MESSAGE(o.name << " is not modelled");
        CHECK_FALSE(a.hasUnmodelledOutputs());
        CHECK(a.validation.withinEpsilon);
        for (const std::string& joint : scene.chainJoints) {
            CAPTURE(joint);
            const ApproximationOutput& o = a.outputs[static_cast<std::size_t>(test::outputIndex(a, joint))];
            REQUIRE(o.constraint >= 0);
            const ConstraintBase& c = a.constraints[static_cast<std::size_t>(o.constraint)];
            CHECK(c.kind == ConstraintKind::planarChain);
            REQUIRE(c.pole >= 0);
            if (!scene.pole.empty()) CHECK(a.outputs[static_cast<std::size_t>(c.pole)].name == scene.pole);
        }
    }
}

}  // namespace rig

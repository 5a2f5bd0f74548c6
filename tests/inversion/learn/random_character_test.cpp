// Random production-style characters (the developers' guide: "test on rigs you did not tune for"): a whole rig
// combining every constraint family of issue #32 as rigs/creature.yaml does (IK arms with and without poles behind
// held ikFk switches, aimed eyes, forearm twist shares, a spine bend shared by fractions, finger curls), each part at
// random, written as a rig file and a spec (the generator: bench/random_character.h), learned as rig-learn learns it
// (helper frames found) and solved on the real rig.
#include <doctest/doctest.h>

#include <unistd.h>

#include <fmt/format.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "adapter/graph_rig_function.h"
#include "bench/random_character.h"
#include "inversion/clip/clip_inversion.h"
#include "inversion/clip/hybrid_solve.h"
#include "inversion/clip/rig_binding.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation.h"
#include "inversion/model/approximation_io.h"
#include "inversion/model/constraint.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"
#include "test_support.h"

namespace rig {
namespace {

using bench::Character;
using bench::CharacterParts;
using bench::Construction;
using bench::leggedCharacter;
using bench::loadCharacter;
using bench::randomCharacter;
using bench::smoothClip;

struct FamilyCounts {
    int chains = 0, aims = 0, shares = 0, oriented = 0, orientedChains = 0;
};

// Planar chains read an IK goal (those turning as another output counted apart too), aims are planar chains whose
// goal is the eye target, twist shares, oriented bases.
FamilyCounts familyCounts(const Approximation& a)
{
    FamilyCounts counts;
    for (const ConstraintBase& c : a.constraints) {
        if (c.kind == ConstraintKind::twistShare) ++counts.shares;
        else if (c.kind == ConstraintKind::oriented) ++counts.oriented;
        else if (c.kind == ConstraintKind::blend) continue;
        else if (a.outputs[static_cast<std::size_t>(c.goal)].name == "eye_target_ctrl") ++counts.aims;
        else {
            ++counts.chains;
            counts.orientedChains += c.orient >= 0 ? 1 : 0;
        }
    }
    return counts;
}

// The most an IK arm without stretch is straight in these worlds: 0 where one is (its goal at or past its reach, where
// moving the goal along the arm changes nothing), else the least of |shoulder-elbow| + |elbow-wrist| -
// |shoulder-wrist|.
double rigidArmSlack(const Approximation& a, const CharacterParts& parts, const std::vector<Eigen::Matrix4d>& worlds)
{
    double least = std::numeric_limits<double>::infinity();
    for (const std::string& side : parts.rigidIkSides) {
        const auto at = [&](const std::string& joint) -> Eigen::Vector3d {
            return worlds[static_cast<std::size_t>(test::outputIndex(a, side + joint))].block<3, 1>(0, 3);
        };
        const Eigen::Vector3d s = at("upperArm"), e = at("forearm"), h = at("hand");
        least = std::min(least, std::max(0.0, (e - s).norm() + (h - e).norm() - (h - s).norm()));
    }
    return least;
}

// A missed pose: whether the solve from rest left a rigid arm straight where the truth bends it.
bool straightenedRigidArm(const Approximation& a, const Solver& solver, RigBinding& binding,
                          const CharacterParts& parts, const std::vector<JointTarget>& targets)
{
    std::vector<Eigen::Matrix4d> truth, solved;
    for (const JointTarget& t : targets) truth.push_back(t.world);
    std::vector<double> values = a.defaults();
    solver.initialGuess(targets, values);
    solver.solve(targets, values);
    binding.evaluate(values, solved);
    return rigidArmSlack(a, parts, truth) > 1e-3 && rigidArmSlack(a, parts, solved) < 1e-6;
}

}  // namespace

TEST_CASE("random character: the generator's IK arms rest where their FK arms do")
{
    std::mt19937 rng(2028);
    const auto dir = test::scratchDir(fmt::format("random-character-rest.{}", ::getpid()));
    for (int c = 0; c < 8; ++c) {
        Character character = randomCharacter(rng);
        CAPTURE(character.parts.summary);
        std::array<std::vector<Eigen::Matrix4d>, 2> worlds;
        for (const int ikFk : {0, 1}) {
            character.spec = character.specAt[static_cast<std::size_t>(ikFk)];
            std::filesystem::path rigFile;
            GraphRigFunction rig = loadCharacter(character, dir, c * 2 + ikFk, rigFile);
            std::vector<double> rest;
            for (const RigParameter& p : rig.parameters()) rest.push_back(p.defaultValue);
            rig.evaluate(rest, worlds[static_cast<std::size_t>(ikFk)]);
        }
        REQUIRE(worlds[0].size() == worlds[1].size());
        double worst = 0.0;
        for (std::size_t k = 0; k < worlds[0].size(); ++k)
            worst = std::max(worst, (worlds[0][k] - worlds[1][k]).cwiseAbs().maxCoeff());
        // Equal up to the rounding of the file's nine digits through the IK (1e-6 measured).
        CHECK(worst < 1e-5);
    }
}

TEST_CASE(
    "random character: random production-style characters (IK and FK arms, poles, stretch, IK hands turned by their "
    "controls, aimed eyes, twist shares, shared spines, curled fingers) are learned within epsilon and their poses "
    "reached on the real rig")
{
    std::mt19937 rng(2028);
    const auto dir = test::scratchDir(fmt::format("random-character.{}", ::getpid()));
    const int characters = 10;
    // Poses on characters whose IK arms all stretch (or that have none), and on those with a rigid IK arm.
    int modelled = 0, withinEpsilon = 0, reached = 0, poses = 0, rigidReached = 0, rigidPoses = 0, straightened = 0;
    for (int c = 0; c < characters; ++c) {
        const Character character = randomCharacter(rng);
        CAPTURE(c);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        std::vector<UnmodelledOutput> unmodelled;
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string(), &unmodelled);
        const FamilyCounts counts = familyCounts(a);
        MESSAGE("character " << c << ": " << character.parts.summary << "planar chains " << counts.chains << ", aims "
                             << counts.aims << ", twist shares " << counts.shares << "; unmodelled "
                             << unmodelled.size() << "; worst " << a.validation.maxRelativeError << " cm per unit ("
                             << a.validation.worstRelativeOutput << ")");
        for (const UnmodelledOutput& u : unmodelled) MESSAGE("  " << u.name << ": " << u.reason);
        withinEpsilon += a.validation.withinEpsilon ? 1 : 0;
        if (a.hasUnmodelledOutputs()) continue;
        ++modelled;
        // Every family as built: the IK arms' upper arm and forearm (and their hand, as a chain or relative to the
        // forearm), each eye, every forearm's roll joint (under an IK forearm, a share of the chain hand's twist).
        CHECK(counts.chains >= 2 * character.parts.ikArms);
        CHECK(counts.chains <= 3 * character.parts.ikArms);
        CHECK(counts.aims == character.parts.eyes);
        CHECK(counts.shares == character.parts.fkArms + character.parts.ikArms);
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        for (int pose = 0; pose < 6; ++pose) {
            const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.4));
            const double worst = test::solvedFromRest(a, solver, binding, targets);
            const bool rigid = !character.parts.rigidIkSides.empty(), hit = worst < 1e-3;
            if (!hit) {
                const bool straight = straightenedRigidArm(a, solver, binding, character.parts, targets);
                MESSAGE(
                    "  pose " << pose << " missed by " << worst << " cm"
                              << std::string(straight ? ", a rigid arm left straight where the truth bends it" : ""));
                straightened += straight ? 1 : 0;
            }
            (rigid ? rigidReached : reached) += hit ? 1 : 0;
            ++(rigid ? rigidPoses : poses);
        }
    }
    MESSAGE("random characters: " << withinEpsilon << " of " << characters << " within epsilon, " << modelled
                                  << " fully modelled; poses reached from rest on the real rig: " << reached << " of "
                                  << poses << " where every IK arm stretches, " << rigidReached << " of " << rigidPoses
                                  << " with a rigid IK arm (" << straightened
                                  << " of the misses a rigid arm left straight where the truth bends it)");
    // Measured (seed 2028, 10 characters, in 8 of them a hand orient-constrained to its IK control): 10 of 10
    // within epsilon, 10 of 10 fully modelled, every such hand a planar chain turning as its control, every forearm's
    // roll joint a twist share (under an IK forearm, of the hand's twist relative to the forearm, both planar chain
    // outputs); 30 of 30 poses reached where every IK arm stretches, 29 of 30 with a rigid one (the miss 0.0011 cm).
    // Before the orient input, those hands and their roll joints were left unmodelled (7 of 10 characters).
    // (Earlier, with hands turned by FK controls alone: character 1's
    // R_forearm was 0.00114 cm per unit off while the planar chain's shape stopped at a fifth of the rest reach,
    // docs/rig-learn.md.)
    // - With a rigid (no stretch) IK arm, before goal holds (GoalHold, docs/solver.md) 4 poses (3.4 to 15.5 cm) ended
    //   with the arm straight where the truth bends it: the solve took the goal past the chain's reach, where the shape
    //   is flat and no step brings it back. One more (0.029 cm, that arm straight in the truth too) was missed
    //   while the roll joints under IK forearms were left out of the outputs, and is reached with them.
    // - The roll joints under IK forearms were first learned as planar chains on the arm's goal and pole, 0.03 to 0.06
    //   cm per unit over epsilon: tried before the hand that drives them had its own chain, and checked only on what
    //   moves the chain's inputs. The learner now tries a chain over epsilon as a twist share again, its inputs
    //   constraint outputs too.
    CHECK(withinEpsilon == characters);
    CHECK(modelled == characters);
    CHECK(reached >= poses * 95 / 100);
    CHECK(rigidReached >= rigidPoses * 95 / 100);
    CHECK(straightened == 0);
}

TEST_CASE(
    "random character: with a restart every frame, each frame of a clip of random poses is the clip of that pose "
    "alone, "
    "bit for bit, with and without the hybrid solve")
{
    // A restart makes a frame independent of the frames before it: a chunk solves as the whole clip does, a cold frame
    // as it would alone. Before continuity shifts met only warm frames, each restart frame was shifted to meet the one
    // before: over 25 random poses of a creature, 24 frames were up to 720 degrees off their own clip's values and
    // rotation controls wound past 360 degrees (issue #45).
    std::mt19937 rng(45);
    const auto dir = test::scratchDir(fmt::format("random-character-restarts.{}", ::getpid()));
    const int characters = 3, poses = 10;
    int frames = 0, differing = 0;
    double furthest = 0.0;  // the largest rotation control, degrees from its rest value
    for (int c = 0; c < characters; ++c) {
        const Character character = randomCharacter(rng);
        CAPTURE(c);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string());
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        ClipTargets targets;
        for (int pose = 0; pose < poses; ++pose)
            targets.frames.push_back(test::realTargetsAt(a, binding, test::randomValues(a, rng, 1.0)));
        for (const bool hybridSolve : {false, true}) {
            CAPTURE(hybridSolve);
            HybridSolver hybrid(solver, binding, 1);
            ChainScratch scratch;
            ClipInversionOptions options;
            options.restartInterval = 1;
            if (hybridSolve)
                options.frameSolve = [&](std::span<const JointTarget> t, std::vector<double>& values,
                                         double previousCost, ChainFrame& frame) {
                    hybrid.solveFrame(t, values, previousCost, scratch, frame);
                };
            std::vector<std::vector<double>> whole, alone;
            invertClip(solver, binding, targets, 0, poses - 1, options, whole);
            for (int f = 0; f < poses; ++f) {
                CAPTURE(f);
                invertClip(solver, binding, targets, f, f, options, alone);
                REQUIRE(alone.size() == 1);
                const bool same = alone[0] == whole[static_cast<std::size_t>(f)];
                CHECK(same);
                differing += same ? 0 : 1;
                ++frames;
                for (std::size_t p = 0; p < a.parameters.size(); ++p)
                    if (rotationPeriod(a.parameters[p]) > 0.0)
                        furthest = std::max(furthest, std::abs(whole[static_cast<std::size_t>(f)][p] -
                                                               a.parameters[p].parameter.defaultValue) *
                                                          180.0 / std::numbers::pi);
            }
        }
    }
    MESSAGE("restart every frame: " << frames - differing << " of " << frames
                                    << " frames equal their own clip's, bit for bit; the furthest rotation control "
                                    << furthest << " degrees from rest");
    CHECK(furthest <= 360.0);
}

namespace {

// One construction of issue #46 on random characters: learned, and random poses of the real rig solved from rest.
struct ConstructionResult {
    int characters = 0, modelled = 0, withinEpsilon = 0, poses = 0, reached = 0;
    int oriented = 0, orientedChains = 0;  // the bases of outputs turning as another output, over the characters
    std::uint64_t evaluations = 0;         // the rig evaluations learning took, over the characters
    double restError = 0.0;
    double jacobianGap = 0.0;  // the analytic Jacobian's largest difference from central differences, relative
    // The normal equations' largest difference from J^T J and J^T r (relative), and the poses where they came from
    // twists through the chains' bases (ResidualStructure::twistNormals: J never formed).
    double normalGap = 0.0;
    int twistNormalPoses = 0;
    double fileGap = 0.0;  // the largest difference of the worlds after a round trip through a file
};

// J^T J and J^T r from the workspace's normal equations against the products of the analytic Jacobian.
void checkNormalEquations(JacobianEvaluator& evaluator, const std::vector<double>& values,
                          const Eigen::MatrixXd& analytic, const Eigen::VectorXd& residuals, ConstructionResult& r)
{
    Eigen::MatrixXd h;
    Eigen::VectorXd g, again;
    evaluator.normalEquations(values, JacobianMethod::analytic, 0.0, g, h, again);
    const Eigen::MatrixXd product = analytic.transpose() * analytic;
    const Eigen::VectorXd gradient = analytic.transpose() * residuals;
    const Eigen::MatrixXd lower = product.triangularView<Eigen::Lower>();
    const Eigen::MatrixXd formed = h.triangularView<Eigen::Lower>();
    r.normalGap = std::max({r.normalGap, (formed - lower).norm() / std::max(1.0, product.norm()),
                            (g - gradient).norm() / std::max(1.0, gradient.norm())});
    r.twistNormalPoses += evaluator.structure().twistNormals() ? 1 : 0;
}

// What the approximation's analytic Jacobian and its file must keep: central differences (relative to the largest
// entry) and the worlds read back, at random poses.
void checkJacobianAndFile(const Approximation& a, RigBinding& binding, std::mt19937& rng, ConstructionResult& r)
{
    const Approximation read = approximationFromYaml(approximationToYaml(a), "round trip");
    for (int pose = 0; pose < 3; ++pose) {
        const std::vector<double> values = test::randomValues(a, rng, 0.4);
        const std::vector<JointTarget> targets = test::realTargetsAt(a, binding, test::randomValues(a, rng, 0.4));
        JacobianEvaluator evaluator(a, targets, 10.0);
        Eigen::MatrixXd analytic, numeric;
        Eigen::VectorXd r1, r2;
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, analytic, r1);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-5, numeric, r2);
        r.jacobianGap = std::max(
            r.jacobianGap, (analytic - numeric).cwiseAbs().maxCoeff() / std::max(1.0, analytic.cwiseAbs().maxCoeff()));
        checkNormalEquations(evaluator, values, analytic, r1, r);
        std::vector<Eigen::Matrix4d> worlds, again;
        a.evaluate(values, worlds);
        read.evaluate(values, again);
        for (std::size_t k = 0; k < worlds.size(); ++k)
            r.fileGap = std::max(r.fileGap, (worlds[k] - again[k]).cwiseAbs().maxCoeff());
    }
}

ConstructionResult learnAndSolve(Construction construction, unsigned seed, int characters, int posesEach)
{
    std::mt19937 rng(seed);
    const auto dir = test::scratchDir(fmt::format("random-character-legs.{}.{}", seed, ::getpid()));
    ConstructionResult r;
    for (int c = 0; c < characters; ++c) {
        const Character character = leggedCharacter(rng, construction);
        CAPTURE(c);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        std::vector<double> defaults;
        for (const RigParameter& p : rig.parameters()) defaults.push_back(p.defaultValue);
        std::vector<Eigen::Matrix4d> rest;
        rig.evaluate(defaults, rest);
        for (std::size_t k = 0; k < character.rest.size(); ++k) {
            const double e = (rest[k] - character.rest[k]).cwiseAbs().maxCoeff();
            if (e > 1e-5) MESSAGE("  " << rig.outputs()[k] << " rests " << e << " from where the builder put it");
            r.restError = std::max(r.restError, e);
        }
        std::vector<UnmodelledOutput> unmodelled;
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string(), &unmodelled);
        const FamilyCounts counts = familyCounts(a);
        MESSAGE("character " << c << ": " << character.parts.summary << "planar chains " << counts.chains << " ("
                             << counts.orientedChains << " turning as another output), oriented bases "
                             << counts.oriented << ", twist shares " << counts.shares << "; unmodelled "
                             << unmodelled.size() << "; worst " << a.validation.maxRelativeError << " cm per unit ("
                             << a.validation.worstRelativeOutput << ")");
        for (const UnmodelledOutput& u : unmodelled) MESSAGE("  " << u.name << ": " << u.reason);
        ++r.characters;
        r.evaluations += a.training.evaluations;
        r.withinEpsilon += a.validation.withinEpsilon ? 1 : 0;
        if (a.hasUnmodelledOutputs()) continue;
        ++r.modelled;
        r.oriented += counts.oriented;
        r.orientedChains += counts.orientedChains;
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        // Poses from their own stream: a character's draws do not depend on whether the one before was modelled.
        std::mt19937 poseRng(seed * 31u + static_cast<unsigned>(c));
        checkJacobianAndFile(a, binding, poseRng, r);
        for (int pose = 0; pose < posesEach; ++pose) {
            const std::vector<JointTarget> targets =
                test::realTargetsAt(a, binding, test::randomValues(a, poseRng, 0.4));
            const double worst = test::solvedFromRest(a, solver, binding, targets);
            if (worst >= 1e-3) MESSAGE("  pose " << pose << " missed by " << worst << " cm");
            r.reached += worst < 1e-3 ? 1 : 0;
            ++r.poses;
        }
    }
    MESSAGE(r.withinEpsilon << " of " << r.characters << " within epsilon, " << r.modelled
                            << " fully modelled; poses reached from rest on the real rig: " << r.reached << " of "
                            << r.poses << "; " << r.evaluations << " training evaluations; rest " << r.restError
                            << " from the builder's; analytic Jacobian " << r.jacobianGap
                            << " from central differences, worlds " << r.fileGap << " off after a file");
    return r;
}

// Each construction on three random characters (or `characters`), 8 random poses each solved from rest on the real
// rig: every output modelled within epsilon, 95% of the poses reached within 1e-3 cm (issue #46's goal).
ConstructionResult expectAll(Construction construction, unsigned seed, int characters = 3)
{
    const ConstructionResult r = learnAndSolve(construction, seed, characters, 8);
    CHECK(r.restError < 1e-5);
    CHECK(r.withinEpsilon == r.characters);
    CHECK(r.modelled == r.characters);
    CHECK(r.reached * 100 >= r.poses * 95);
    CHECK(r.jacobianGap < 1e-5);
    CHECK(r.normalGap < 1e-10);
    CHECK(r.twistNormalPoses > 0);  // the twist form through the bases, not only the Jacobian's products
    CHECK(r.fileGap < 1e-9);
    return r;
}

}  // namespace

TEST_CASE("random character: production leg constructions of Maya rigs (issue #46) learned and solved on the real rig")
{
    // Measured: reverse feet 3 of 3 modelled, 24 of 24 poses; three bones 3 of 3, 24 of 24; spaces 3 of 3, 24 of 24;
    // FK/IK blends through parent and orient constraints (held at IK) 3 of 3, 24 of 24. Every analytic Jacobian within
    // 2e-9 of central differences, every file read back to the same worlds.
    // Before poles turned by a helper (poleTurns), every mayaIkHandle leg without a pole control was left unmodelled
    // (its pole vector turns with the foot), and a three-bone chain's side was no rest plane. While any moved helper
    // could carry a pole, the blended legs' thighs and knees were left unmodelled (36.8 and 10.6 cm per unit): a pole
    // turned by the IK control passed the fit's poses, which never turn it, and not the validation, which does.
    SUBCASE("reverse foot")
    {
        expectAll(Construction::reverseFoot, 4601);
        // On 8 more characters (seed 4701) 8 of 8 modelled and 64 of 64 poses reached (about 5 s), with 57634 training
        // evaluations. Before a roll's flat stretch inside its range (heel keyed below 0, toe above 5) broke the
        // curves at its ends (CubicSpline breaks), 60 of 64 (the misses 0.0014 to 0.215 cm, one character's
        // driven-key roll near the kinks its natural spline rounded) with 59950.
        expectAll(Construction::reverseFoot, 4701, 8);
    }
    SUBCASE("three bones under one IK") { expectAll(Construction::threeBones, 4603); }
    SUBCASE("space switch") { expectAll(Construction::spaceSwitch, 4606); }
    SUBCASE("FK/IK blend through constraints") { expectAll(Construction::constraintBlend, 4605); }
    SUBCASE("ikSCsolver chains: one-bone ankles and balls, two-bone legs")
    {
        // Measured with Maya's ikSCsolver (the chain turned about its line toward the handle's orientation): 3 of 3
        // modelled (the SC legs' thighs, knees and ankles planar chains on the rest plane turned by the goal, then
        // minimally; the one-bone SC ankles and balls carried by their parent and turned the same way onto their
        // handles), worst 3.7e-6 cm per unit; 24 of 24 poses reached; the analytic Jacobian within 3.6e-10 of central
        // differences. On 8 more characters (seed 4707, every goal kind drawn: own controls, the toe pivot, the foot
        // control) 8 of 8 modelled, worst 5.8e-6 cm per unit, and 63 of 64 poses reached (the miss 12.8 cm, a solve
        // from rest stuck; the run takes 13 s).
        // Before the one-bone chain carried by its parent was also tried turned by its goal, all 8 of those characters
        // left SC ankles or balls unmodelled (0.07 to 0.27 cm per unit off, turned minimally from the anchor's turn).
        // Before the initial guess solved again a step whose free combination of parameters (the foot control's
        // rotation and rolls, of which an SC leg reads the goal's origin and its turn about the line alone) an output's
        // target fixes (fewer free combinations at rest together than apart), 60 of 64 (the misses 2.7 to 12.8 cm,
        // rolls guessed at their limits) and 23 of 24 here.
        const ConstructionResult r = expectAll(Construction::singleChain, 4607);
        CHECK(r.reached == r.poses);
        expectAll(Construction::singleChain, 4707, 8);
    }
    SUBCASE("ankles and balls orient-constrained to the foot or a pivot")
    {
        // Measured: 3 of 3 modelled, 4 ankles planar chains turning as their foot's goal; 24 of 24 poses reached. On 8
        // more characters (seed 4702) 8 of 8 modelled, 3 balls orient-constrained under an FK ankle oriented bases, and
        // 63 of 64 poses reached (about 5 s; 64 while a failed Gauss-Newton step was damped to the end of the solve,
        // docs/solver.md), with 53686 training evaluations. Before the curves broke at the ends of a
        // roll's flat stretch, 58 of 64 with 59118: the 6 misses, of 0.001 to 0.019 cm on one character, were where the
        // solve moved a driven-key roll near its keys' kink, which the sampled curve rounded; and here an FK ball (not
        // constrained) under an ankle turned by such a roll was an oriented base, where it is now relative to its
        // ankle (the simplest frame, validated; that character's learning 4341 evaluations instead of 5344). Before
        // the initial guess placed a goal whose control also moves the foot an orient constraint reads (pole_hold.h,
        // placeChain), it left the foot control where the thigh's target alone put it, up to 16 cm low, and the solves
        // from there stuck: 22 of 24 (19.0 and 12.0 cm), 54 of 64 on seed 4702 (4 of them 5 to 12 cm). Before the
        // oriented base, a ball orient-constrained under an FK ankle was left unmodelled (and, with the generator's
        // constraint writing angles in another rotate order than the ball's, it was no orient at all).
        const ConstructionResult r = expectAll(Construction::orientEnd, 4602);
        CHECK(r.orientedChains >= 3);
        const ConstructionResult more = expectAll(Construction::orientEnd, 4702, 8);
        CHECK(more.oriented >= 1);
    }
}

TEST_CASE("random character: smooth clips of ikSCsolver legs converge on every frame, none at the iteration limit")
{
    // A one-bone ikSCsolver chain only aims, so its goal moved along the chain's line changes no joint: the foot
    // control is redundant there, and where the approximation misses the real rig's targets a little, the solve
    // could slide that control along the valley of the miss, lowering a cost already far within the tolerance by
    // fractions of a percent a step, to maxIterations (docs/solver.md, Stop tests).
    std::mt19937 rng(4607);
    const auto dir = test::scratchDir(fmt::format("random-character-sc-clips.{}", ::getpid()));
    const int characters = 3, frames = 60;
    int solved = 0, reached = 0, atLimit = 0, iterations = 0;
    for (int c = 0; c < characters; ++c) {
        const Character character = leggedCharacter(rng, Construction::singleChain);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string());
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        std::mt19937 clipRng(4607u * 31u + static_cast<unsigned>(c));
        const ClipTargets clip = smoothClip(a, binding, frames, clipRng);
        std::vector<std::vector<double>> values;
        const ClipInversionSummary s = invertClip(solver, binding, clip, 0, frames - 1, {}, values);
        for (const FrameInversion& f : s.perFrame) {
            ++solved;
            reached += f.status == FrameStatus::reached ? 1 : 0;
            atLimit += f.solve.termination == TerminationType::noConvergence ? 1 : 0;
            iterations += f.solve.iterations;
        }
    }
    MESSAGE(reached << " of " << solved << " frames reached on the real rig, " << atLimit
                    << " unconverged at the iteration limit, " << static_cast<double>(iterations) / solved
                    << " iterations a frame");
    // Measured: 180 of 180 reached, none unconverged, 9.0 iterations a frame; without the creeping step's stop, 3
    // frames unconverged at the iteration limit and 10.4 a frame. (How many iterations the frames that start far take
    // moves with the rounding of the minimum-norm steps: 7.2 a frame with the step's former arithmetic.)
    CHECK(reached == solved);
    CHECK(atLimit == 0);
}

}  // namespace rig

namespace rig {
namespace {

TEST_CASE("random character: every frame of smooth clips of legs in a space, solved alone from rest, is reached")
{
    // A leg whose IK handle turns the thigh and the knee alone: its ankle is a joint of its own under the knee, the
    // chain's effector but no member of it. The cold start placed the goal by the knee's target (the member nearest
    // the goal) and at a straight target on the reach where the chain's shape flattens (pole_hold.h, placeChain).
    std::mt19937 rng(4606);
    const auto dir = test::scratchDir(fmt::format("random-character-space-clips.{}", ::getpid()));
    const int characters = 3, frames = 30;
    int solved = 0, reached = 0;
    for (int c = 0; c < characters; ++c) {
        const Character character = leggedCharacter(rng, Construction::spaceSwitch);
        CAPTURE(character.parts.summary);
        std::filesystem::path rigFile;
        GraphRigFunction rig = loadCharacter(character, dir, c, rigFile);
        const Approximation a = learnApproximation(rig, LearnOptions{}, rigFile.string());
        REQUIRE_FALSE(a.hasUnmodelledOutputs());
        RigBinding binding(a, rig);
        const Solver solver(a, SolverOptions{});
        std::mt19937 clipRng(4606u * 31u + static_cast<unsigned>(c));
        const ClipTargets clip = smoothClip(a, binding, frames, clipRng);
        for (int f = 0; f < frames; ++f) {
            const double worst = test::solvedFromRest(a, solver, binding, clip.frames[static_cast<std::size_t>(f)]);
            if (worst >= 1e-3) MESSAGE("character " << c << " frame " << f << " missed by " << worst << " cm");
            reached += worst < 1e-3 ? 1 : 0;
            ++solved;
        }
    }
    MESSAGE(reached << " of " << solved << " frames reached from rest on the real rig");
    CHECK(reached == solved);
}

}  // namespace
}  // namespace rig

// Residuals and Jacobians on the approximation: the analytic Jacobian (operator product with prefix
// and suffix products) against central finite differences, ours and an independent one built in this
// file from Approximation::evaluate, at random poses (the momentum library's way of testing derivatives).
#include <doctest/doctest.h>

#include <numbers>
#include <random>

#include <oneapi/tbb/task_arena.h>
#include <Eigen/Dense>

#include "inversion/solve/jacobian.h"
#include "inversion/solve/solve_plan.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

constexpr double rotationScale = 10.0;

// The residuals of jacobian.h, written again from their definition: position difference, and
// 2 sin(theta / 2) times the axis of Q_target^T Q (theta in [0, pi]) with Q the polar part of the world's 3x3 block.
Eigen::VectorXd referenceResiduals(const Approximation& a, const std::vector<JointTarget>& targets,
                                   std::span<const double> values)
{
    std::vector<Eigen::Matrix4d> worlds;
    a.evaluate(values, worlds);
    auto orthonormal = [](const Eigen::Matrix3d& m) {
        const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
        return Eigen::Matrix3d(svd.matrixU() * svd.matrixV().transpose());
    };
    std::vector<double> r;
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active) continue;
        const Eigen::Vector3d dp = worlds[k].block<3, 1>(0, 3) - targets[k].world.block<3, 1>(0, 3);
        const Eigen::AngleAxisd aa(Eigen::Matrix3d(orthonormal(targets[k].world.block<3, 3>(0, 0)).transpose() *
                                                   orthonormal(worlds[k].block<3, 3>(0, 0))));
        const double angle = std::remainder(aa.angle(), 2 * std::numbers::pi);  // [-pi, pi]: the same rotation
        const Eigen::Vector3d e = 2 * std::sin(angle / 2) * aa.axis();
        for (int i = 0; i < 3; ++i) r.push_back(targets[k].positionWeight * dp[i]);
        for (int i = 0; i < 3; ++i) r.push_back(targets[k].rotationWeight * rotationScale * e[i]);
    }
    return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<Eigen::Index>(r.size()));
}

Eigen::MatrixXd referenceJacobian(const Approximation& a, const std::vector<JointTarget>& targets,
                                  std::vector<double> values, double h)
{
    const Eigen::Index rows = referenceResiduals(a, targets, values).size();
    Eigen::MatrixXd j(rows, static_cast<Eigen::Index>(values.size()));
    for (std::size_t c = 0; c < values.size(); ++c) {
        const double v = values[c];
        values[c] = v + h;
        const Eigen::VectorXd plus = referenceResiduals(a, targets, values);
        values[c] = v - h;
        const Eigen::VectorXd minus = referenceResiduals(a, targets, values);
        values[c] = v;
        j.col(static_cast<Eigen::Index>(c)) = (plus - minus) / (2 * h);
    }
    return j;
}

// Targets from the approximation at another random pose, with random weights, a target rotation
// scaled and sheared, and outputs whose rotation error would come near pi (where the half-angle
// residual changes sign) left inactive.
std::vector<JointTarget> randomTargets(const Approximation& a, std::span<const double> values, std::mt19937& rng)
{
    const std::vector<double> other = test::randomValues(a, rng);
    std::vector<JointTarget> targets = test::targetsAt(a, other);
    std::vector<Eigen::Matrix4d> worlds;
    a.evaluate(values, worlds);
    std::uniform_real_distribution<double> weight(0.2, 2.0);
    for (std::size_t k = 0; k < targets.size(); ++k) {
        targets[k].positionWeight = weight(rng);
        targets[k].rotationWeight = weight(rng);
        const Eigen::AngleAxisd aa(
            Eigen::Matrix3d(targets[k].world.block<3, 3>(0, 0).transpose() * worlds[k].block<3, 3>(0, 0)));
        if (aa.angle() > 2.8) targets[k].active = false;
        if (k % 3 == 1) {
            Eigen::Matrix3d shear = Eigen::Matrix3d::Identity();
            shear(0, 1) = 0.3;
            targets[k].world.block<3, 3>(0, 0) =
                targets[k].world.block<3, 3>(0, 0) * shear * Eigen::Vector3d(1.5, 0.7, 1.1).asDiagonal();
        }
    }
    return targets;
}

double relativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b)
{
    return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, a.cwiseAbs().maxCoeff());
}

// Analytic against our finite differences and against the reference, at `poses` random poses.
void checkJacobians(const Approximation& a, int poses, std::uint32_t seed, double tolerance = 1e-6)
{
    std::mt19937 rng(seed);
    for (int pose = 0; pose < poses; ++pose) {
        CAPTURE(pose);
        const std::vector<double> values = test::randomValues(a, rng);
        const std::vector<JointTarget> targets = randomTargets(a, values, rng);
        JacobianEvaluator evaluator(a, targets, rotationScale);
        Eigen::MatrixXd analytic, finite;
        Eigen::VectorXd r, rFinite;
        evaluator.jacobian(values, JacobianMethod::analytic, 1e-6, analytic, r);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, finite, rFinite);
        const Eigen::VectorXd reference = referenceResiduals(a, targets, values);
        REQUIRE(r.size() == reference.size());
        CHECK((r - reference).cwiseAbs().maxCoeff() < 1e-9 * std::max(1.0, reference.cwiseAbs().maxCoeff()));
        CHECK(r == rFinite);
        // The fallback for singular operators: the same matrix from prefix and suffix products.
        Eigen::MatrixXd suffixes;
        Eigen::VectorXd rSuffixes;
        evaluator.jacobianFromSuffixes(values, suffixes, rSuffixes);
        CHECK(relativeDifference(analytic, suffixes) < 1e-12);
        CHECK((r - rSuffixes).cwiseAbs().maxCoeff() < 1e-12 * std::max(1.0, r.cwiseAbs().maxCoeff()));
        const Eigen::MatrixXd referenceJ = referenceJacobian(a, targets, values, 1e-6);
        const double vsFinite = relativeDifference(analytic, finite);
        const double vsReference = relativeDifference(analytic, referenceJ);
        if (vsFinite > tolerance || vsReference > tolerance) {
            Eigen::Index row, column;
            (analytic - referenceJ).cwiseAbs().maxCoeff(&row, &column);
            MESSAGE("worst entry: row " << row << ", parameter "
                                        << a.parameters[static_cast<std::size_t>(column)].parameter.name << " ("
                                        << a.parameters[static_cast<std::size_t>(column)].form << "): analytic "
                                        << analytic(row, column) << ", finite differences " << referenceJ(row, column));
        }
        CHECK(vsFinite < tolerance);
        CHECK(vsReference < tolerance);
        // Something was measured: not every column is zero.
        CHECK(analytic.cwiseAbs().maxCoeff() > 0.1);
        // The normal equations the solver steps with, twists or not: J^T J (lower triangle) and J^T r.
        for (const JacobianMethod method : {JacobianMethod::analytic, JacobianMethod::finiteDifference}) {
            CAPTURE(jacobianMethodName(method));
            const Eigen::MatrixXd& j = method == JacobianMethod::analytic ? analytic : finite;
            Eigen::VectorXd g, rNormal;
            Eigen::MatrixXd h;
            evaluator.normalEquations(values, method, 1e-6, g, h, rNormal);
            CHECK(rNormal == r);
            const Eigen::MatrixXd jtj = j.transpose() * j;
            const Eigen::VectorXd jtr = j.transpose() * r;
            CHECK(relativeDifference(h.triangularView<Eigen::Lower>().toDenseMatrix(),
                                     jtj.triangularView<Eigen::Lower>().toDenseMatrix()) < 1e-12);
            CHECK(h.triangularView<Eigen::StrictlyUpper>().toDenseMatrix().cwiseAbs().maxCoeff() == 0.0);
            CHECK(relativeDifference(g, jtr) < 1e-12);
        }
    }
}

// One parameter of every operator kind on a chain of outputs, by hand (no learner): curves,
// scales and sampled operators make the world's 3x3 block non-orthonormal.
Approximation everyOperatorKind()
{
    Approximation a;
    for (int k = 0; k < 4; ++k) {
        ApproximationOutput o;
        o.name = "out" + std::to_string(k);
        o.rest = test::translation(10.0 * k, 5.0, -2.0 * k) * test::rotation(Eigen::Vector3d(1, 2, 3), 0.3 * k);
        a.outputs.push_back(o);
    }
    auto add = [&](const std::string& name, Operator op, std::vector<int> outputs) {
        ModelledParameter m;
        m.parameter = {name, 0.1, -1.0, 1.2, true};
        m.outputs = std::move(outputs);
        m.operators.push_back(std::move(op));
        m.operatorOfOutput.assign(m.outputs.size(), 0);
        m.form = std::string(operatorKindName(m.operators[0].kind));
        a.parameters.push_back(std::move(m));
    };
    Operator translate;
    translate.kind = OperatorKind::translation;
    translate.axis = Eigen::Vector3d(1, 1, 0).normalized();
    translate.slope = 3.0;
    add("translate", translate, {0, 1, 2, 3});
    Operator rotate;
    rotate.kind = OperatorKind::rotation;
    rotate.axis = Eigen::Vector3d(0.2, 1, 0.1).normalized();
    rotate.pivot = Eigen::Vector3d(1, 2, 3);
    rotate.curve = CubicSpline<1>({-1.1, 0.0, 0.5, 1.1}, {CubicSpline<1>::Vector(-0.9), CubicSpline<1>::Vector(0.0),
                                                          CubicSpline<1>::Vector(0.7), CubicSpline<1>::Vector(1.0)});
    add("rotateCurve", rotate, {1, 2, 3});
    Operator scale;
    scale.kind = OperatorKind::axisScale;
    scale.axis = Eigen::Vector3d(0, 0.6, 0.8);
    scale.pivot = Eigen::Vector3d(10, 5, 0);
    scale.slope = 0.4;
    add("axisScale", scale, {1, 2});
    Operator uniform;
    uniform.kind = OperatorKind::uniformScale;
    uniform.pivot = Eigen::Vector3d(20, 5, -4);
    uniform.slope = 0.3;
    add("uniformScale", uniform, {2, 3});
    Operator rigid;
    rigid.kind = OperatorKind::sampledRigid;
    std::vector<double> x{-1.2, -0.4, 0.0, 0.6, 1.3};
    std::vector<CubicSpline<6>::Vector> rv;
    for (const double s : x) {
        CubicSpline<6>::Vector v;
        v << 0.8 * s, 0.1 * s * s, -0.3 * s, 2.0 * s, s * s, 0.5 * s;
        rv.push_back(v);
    }
    rigid.rigid = CubicSpline<6>(x, rv);
    add("sampledRigid", rigid, {2, 3});
    Operator affine;
    affine.kind = OperatorKind::sampledAffine;
    std::vector<CubicSpline<12>::Vector> av;
    for (const double s : x) {
        CubicSpline<12>::Vector v = CubicSpline<12>::Vector::Zero();
        v[0] = -0.2 * s;  // x scale
        v[5] = 0.5 * s;   // y scale
        v[10] = -0.2 * s;
        v[1] = 0.1 * s * s;  // shear
        v[7] = 3.0 * s;      // translate y
        av.push_back(v);
    }
    affine.affine = CubicSpline<12>(x, av);
    add("sampledAffine", affine, {3});
    return a;
}

}  // namespace

TEST_CASE("jacobian: analytic equals finite differences for every operator kind, scaled outputs and sheared targets")
{
    const Approximation a = everyOperatorKind();
    checkJacobians(a, 20, 11);
    // Scales and sampled affine operators: the normal equations above came from the Jacobian.
    CHECK(!JacobianEvaluator(a, test::targetsAt(a, a.defaults()), rotationScale).structure().twistForm());
}

TEST_CASE("jacobian: analytic equals finite differences on approximations learned from the test rigs")
{
    for (auto make : {test::fkArm, test::twoArms, test::redundantRig, test::slidingKnee}) {
        auto rig = make();
        const Approximation a = test::learn(rig, "test rig");
        CAPTURE(rig.outputs().front());
        REQUIRE(!a.parameters.empty());
        checkJacobians(a, 10, 5);
    }
}

TEST_CASE("jacobian: target scale and shear do not change residuals or Jacobian")
{
    auto rig = test::fkArm();
    const Approximation a = test::learn(rig, "arm");
    std::mt19937 rng(2);
    const std::vector<double> values = test::randomValues(a, rng);
    std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.3));
    std::vector<JointTarget> scaled = targets;
    for (auto& t : scaled) t.world.block<3, 3>(0, 0) *= Eigen::Vector3d(2.0, 0.5, 1.3).asDiagonal();
    JacobianEvaluator plain(a, targets, rotationScale), skewed(a, scaled, rotationScale);
    Eigen::MatrixXd j1, j2;
    Eigen::VectorXd r1, r2;
    plain.jacobian(values, JacobianMethod::analytic, 1e-6, j1, r1);
    skewed.jacobian(values, JacobianMethod::analytic, 1e-6, j2, r2);
    CHECK(r1.cwiseAbs().maxCoeff() > 1.0);
    CHECK((r1 - r2).cwiseAbs().maxCoeff() < 1e-12);
    CHECK((j1 - j2).cwiseAbs().maxCoeff() < 1e-12);
}

TEST_CASE("jacobian: finite-difference columns in parallel equal them computed on one thread, bit for bit")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    std::mt19937 rng(4);
    const std::vector<double> values = test::randomValues(a, rng);
    const std::vector<JointTarget> targets = randomTargets(a, values, rng);
    Eigen::MatrixXd parallel, serial;
    Eigen::VectorXd r;
    {
        JacobianEvaluator evaluator(a, targets, rotationScale);
        tbb::task_arena(2).execute(
            [&] { evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, parallel, r); });
    }
    {
        JacobianEvaluator evaluator(a, targets, rotationScale);
        tbb::task_arena(1).execute(
            [&] { evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, serial, r); });
    }
    CHECK(parallel.cwiseAbs().maxCoeff() > 1.0);
    CHECK(parallel == serial);
}

TEST_CASE("jacobian: a block's own J formed again in place equals J formed afresh, bit for bit")
{
    // A block's J is zeroed only where the tree adds into it once the tree formed it last (clearTreeEntries): after
    // another pose, and after finite differences wrote it, it must hold what a fresh matrix gets.
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    std::mt19937 rng(12);
    const std::vector<JointTarget> targets = randomTargets(a, test::randomValues(a, rng), rng);
    JacobianEvaluator evaluator(a, targets, rotationScale);
    BlockWorkspace block(evaluator.structure(), nullptr);
    block.residual.holdParameters(a.defaults());
    for (std::size_t o = 0; o < evaluator.structure().outputs().size(); ++o) {
        PreparedTarget prepared;
        REQUIRE(prepareTarget(targets[static_cast<std::size_t>(evaluator.structure().outputs()[o])], rotationScale,
                              prepared));
        block.residual.setTarget(static_cast<int>(o), prepared);
    }
    Eigen::VectorXd r(evaluator.rows()), fresh_r;
    Eigen::MatrixXd fresh;
    for (int pose = 0; pose < 4; ++pose) {
        CAPTURE(pose);
        const std::vector<double> values = test::randomValues(a, rng);
        if (pose == 2) block.residual.jacobian(values, JacobianMethod::finiteDifference, 1e-6, false, r, block.J);
        block.residual.jacobian(values, JacobianMethod::analytic, 0.0, false, r, block.J);
        evaluator.jacobian(values, JacobianMethod::analytic, 0.0, fresh, fresh_r);
        CHECK(fresh.cwiseAbs().maxCoeff() > 1.0);
        CHECK(block.J == fresh);
    }
}

TEST_CASE("jacobian: held matrices made again only where a held value changed give a fresh workspace's residuals")
{
    // holdParameters keeps each held operator's matrix and each constant product until its value, or a constant
    // ancestor's, changes (the initial guess holds the same values for every start of a step). One column, the
    // rest held: every held value is changed alone, then back, and the residuals must be a fresh workspace's to the
    // bit (they are not if a constant product below the changed value is left as it was).
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    std::mt19937 rng(31);
    const std::vector<double> pose = test::randomValues(a, rng);
    const std::vector<JointTarget> targets = randomTargets(a, pose, rng);
    const int column = static_cast<int>(a.parameters.size()) - 1;
    std::vector<int> outputs(a.outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k) outputs[k] = static_cast<int>(k);
    const ResidualStructure structure(a, {column}, outputs);
    std::vector<PreparedTarget> prepared(outputs.size());
    for (std::size_t k = 0; k < outputs.size(); ++k) REQUIRE(prepareTarget(targets[k], rotationScale, prepared[k]));
    const auto residualsOf = [&](ResidualWorkspace& w, std::span<const double> values) {
        w.holdParameters(values);
        w.setTargets(prepared);
        Eigen::VectorXd r(structure.rows());
        w.residuals(std::span(values).subspan(static_cast<std::size_t>(column), 1), r);
        return r;
    };
    ResidualWorkspace kept(structure);
    residualsOf(kept, pose);
    std::vector<double> values = pose;
    int changed = 0;
    for (int p = 0; p < column; ++p) {
        CAPTURE(p);
        values[static_cast<std::size_t>(p)] += 0.3;
        ResidualWorkspace fresh(structure);
        const Eigen::VectorXd expected = residualsOf(fresh, values);
        const Eigen::VectorXd got = residualsOf(kept, values);
        CHECK(got == expected);
        changed += got != residualsOf(kept, pose);
        values[static_cast<std::size_t>(p)] = pose[static_cast<std::size_t>(p)];
        CHECK(residualsOf(kept, values) == residualsOf(fresh, values));
    }
    CHECK(changed > column / 2);  // the held values move the outputs: the comparisons see them
}

TEST_CASE("jacobian: columns of parameters that reach no active target are zero, and refused targets are named")
{
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    std::vector<JointTarget> targets = test::targetsAt(a, a.defaults());
    for (std::size_t k = 0; k < targets.size(); ++k) targets[k].active = a.outputs[k].name.starts_with("L_");
    JacobianEvaluator evaluator(a, targets, rotationScale);
    CHECK(evaluator.rows() == 4 * jointTargetRows);
    Eigen::MatrixXd j;
    Eigen::VectorXd r;
    std::mt19937 rng(9);
    evaluator.jacobian(test::randomValues(a, rng), JacobianMethod::analytic, 1e-6, j, r);
    for (std::size_t p = 0; p < a.parameters.size(); ++p) {
        CAPTURE(a.parameters[p].parameter.name);
        const bool right = a.parameters[p].parameter.name.starts_with("R_");
        CHECK((j.col(static_cast<Eigen::Index>(p)).cwiseAbs().maxCoeff() == 0.0) == right);
    }
    targets[2].world(0, 3) = std::nan("");
    CHECK_THROWS_WITH_AS(JacobianEvaluator(a, targets, rotationScale),
                         "JacobianEvaluator: the target of L_elbow is not usable", Error);
}

TEST_CASE("jacobian: analytic equals finite differences on approximations learned from the bundled rigs")
{
    SUBCASE("rigs/examples/arm.yaml")
    {
        test::GraphRig rig("rigs/examples/arm.yaml", {"arm_ctrl.bend", "shoulder.rotate?", "wrist.rotate?"});
        const Approximation a = test::learn(rig, "arm");
        REQUIRE(a.parameters.size() == 7);
        checkJacobians(a, 10, 21);
    }
    SUBCASE("rigs/nasty.yaml")
    {
        test::GraphRig rig("rigs/nasty.yaml", test::nastyGlobs());
        const Approximation a = test::learn(rig, "nasty");
        REQUIRE(a.parameters.size() > 10);
        checkJacobians(a, 10, 22);
    }
    SUBCASE("rigs/biped.yaml")
    {
        test::GraphRig rig("rigs/biped.yaml", test::bipedInversionGlobs(), test::bipedCmuJoints());
        REQUIRE(rig.parameters().size() == 79);
        const Approximation a = test::learn(rig, "biped");
        REQUIRE(a.parameters.size() > 70);
        checkJacobians(a, 3, 23);
        // A skeleton of rigid joints: its normal equations above came from twists, without J.
        const std::vector<JointTarget> targets = test::targetsAt(a, a.defaults());
        CHECK(JacobianEvaluator(a, targets, rotationScale).structure().twistForm());
    }
}

// Residual terms (inversion/solve/residual_term.h): each kind's twist Jacobian and world-change rows against central
// differences of its own residual, the position term (three rows) and a kind registered here through
// ResidualWorkspace on random FK approximations, and solves with position-only targets.
#include <doctest/doctest.h>

#include <random>

#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/learn/learner.h"
#include "inversion/random_fk.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/partition.h"
#include "inversion/solve/residual_term.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

// A kind written here as a studio would: the height (world y) of an output, one row.
class HeightTerm final : public ResidualTerm {
public:
    std::string_view name() const override { return "test.height"; }
    int rows() const override { return 1; }
    unsigned char counted(const JointTarget& t) const override { return t.positionWeight > 0 ? positionRows : noRows; }
    double weight(const PreparedTarget& t, int) const override { return t.positionWeight; }
    void residual(const Eigen::Matrix4d& world, const PreparedTarget& t, TermRows& rows) const override
    {
        rows.resize(1);
        rows[0] = t.positionWeight * (world(1, 3) - t.position.y());
    }
    void twistJacobian(const Eigen::Matrix4d& world, const PreparedTarget& t, TermTwistRows& jacobian) const override
    {
        // y of omega x p + v: omega_z p_x - omega_x p_z + v_y.
        const Eigen::Vector3d p = world.block<3, 1>(0, 3);
        jacobian.resize(1, 6);
        jacobian << -t.positionWeight * p.z(), 0.0, t.positionWeight * p.x(), 0.0, t.positionWeight, 0.0;
    }
    void change(const Eigen::Matrix4d&, const PreparedTarget& t, const Eigen::Matrix<double, 3, 4>& dWorld,
                TermRows& rows) const override
    {
        rows.resize(1);
        rows[0] = t.positionWeight * dWorld(1, 3);
    }
    TargetError error(const Eigen::Matrix4d& world, const PreparedTarget& t) const override
    {
        return {std::abs(world(1, 3) - t.position.y()), 0.0};
    }
};

const ResidualTerm& heightTerm()
{
    static const ResidualTerm* const term = [] {
        registerResidualTerm(std::make_unique<HeightTerm>());
        return &residualTerm("test.height");
    }();
    return *term;
}

Eigen::Matrix3d randomRotation(std::mt19937& rng)
{
    std::normal_distribution<double> normal;
    return Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized().toRotationMatrix();
}

Eigen::Matrix4d randomWorld(std::mt19937& rng, bool rigid)
{
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    Eigen::Matrix4d w = Eigen::Matrix4d::Identity();
    w.block<3, 3>(0, 0) = randomRotation(rng);
    if (!rigid) {  // a stretch: scale and shear, as a non-rigid operator's output has
        Eigen::Matrix3d stretch =
            Eigen::Matrix3d::Identity() + 0.3 * Eigen::Matrix3d::NullaryExpr([&] { return unit(rng); });
        w.block<3, 3>(0, 0) = w.block<3, 3>(0, 0) * stretch;
    }
    w.block<3, 1>(0, 3) = 30.0 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    return w;
}

// A target near `world` (within about 100 degrees, so the half-angle rows stay away from half a turn).
PreparedTarget randomTarget(const Eigen::Matrix4d& world, std::mt19937& rng)
{
    std::uniform_real_distribution<double> unit(-1.0, 1.0), weight(0.2, 2.0);
    JointTarget target;
    target.active = true;
    const Eigen::Vector3d turn(unit(rng), unit(rng), unit(rng));
    target.world.block<3, 3>(0, 0) =
        Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix() * polarRotation(world.block<3, 3>(0, 0));
    target.world.block<3, 1>(0, 3) = world.block<3, 1>(0, 3) + 10.0 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    target.positionWeight = weight(rng);
    target.rotationWeight = weight(rng);
    PreparedTarget prepared;
    REQUIRE(prepareTarget(target, 10.0, prepared));
    return prepared;
}

// The world moved by the world-space twist eps * (omega, v): exp(eps [omega]x) turns it about the origin.
Eigen::Matrix4d twisted(const Eigen::Matrix4d& world, const Eigen::Matrix<double, 6, 1>& twist, double eps)
{
    Eigen::Matrix4d motion = Eigen::Matrix4d::Identity();
    const Eigen::Vector3d omega = eps * twist.head<3>();
    if (omega.norm() > 0)
        motion.block<3, 3>(0, 0) = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
    motion.block<3, 1>(0, 3) = eps * twist.tail<3>();
    return motion * world;
}

TermRows rowsAt(const ResidualTerm& term, const Eigen::Matrix4d& world, const PreparedTarget& target)
{
    TermRows rows;
    term.residual(world, target, rows);
    REQUIRE(rows.size() == term.rows());
    return rows;
}

double relativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b)
{
    return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

// Targets at `pose` of the approximation, each output's term from `termOf`.
template <class TermOf>
std::vector<JointTarget> termTargets(const Approximation& a, std::span<const double> pose, TermOf termOf)
{
    std::vector<JointTarget> targets = test::targetsAt(a, pose);
    for (std::size_t k = 0; k < targets.size(); ++k) targets[k].term = termOf(k);
    return targets;
}

}  // namespace

TEST_CASE("residual terms: twist Jacobian rows and world-change rows against central differences of the residual")
{
    std::mt19937 rng(33);
    const double h = 1e-6;
    for (const ResidualTerm* term : {&jointTargetTerm(), &positionTerm(), &heightTerm()}) {
        CAPTURE(term->name());
        for (int trial = 0; trial < 50; ++trial) {
            CAPTURE(trial);
            const bool rigid = trial % 2 == 0;
            const Eigen::Matrix4d world = randomWorld(rng, rigid);
            const PreparedTarget target = randomTarget(world, rng);
            TermTwistRows b;
            term->twistJacobian(world, target, b);
            REQUIRE(b.rows() == term->rows());
            // Each twist direction, and a random twist, against the residual's central differences.
            Eigen::MatrixXd numeric(term->rows(), 6);
            for (int i = 0; i < 6; ++i) {
                const Eigen::Matrix<double, 6, 1> unit = Eigen::Matrix<double, 6, 1>::Unit(i);
                numeric.col(i) =
                    (rowsAt(*term, twisted(world, unit, h), target) - rowsAt(*term, twisted(world, unit, -h), target)) /
                    (2 * h);
            }
            CHECK(relativeDifference(b, numeric) < 1e-6);
            const Eigen::Matrix<double, 6, 1> twist = Eigen::Matrix<double, 6, 1>::Random();
            const TermRows along =
                (rowsAt(*term, twisted(world, twist, h), target) - rowsAt(*term, twisted(world, twist, -h), target)) /
                (2 * h);
            CHECK(relativeDifference(b * twist, along) < 1e-6);
            // Any change of the world's top rows (a stretch's velocity is no twist).
            const Eigen::Matrix<double, 3, 4> change = Eigen::Matrix<double, 3, 4>::Random();
            Eigen::Matrix4d plus = world, minus = world;
            plus.topRows<3>() += h * change;
            minus.topRows<3>() -= h * change;
            TermRows rows;
            term->change(world, target, change, rows);
            CHECK(relativeDifference(rows, (rowsAt(*term, plus, target) - rowsAt(*term, minus, target)) / (2 * h)) <
                  1e-6);
        }
    }
}

TEST_CASE("residual terms: the position term is the joint target's position rows, weighted by its weight alone")
{
    std::mt19937 rng(4);
    for (int trial = 0; trial < 20; ++trial) {
        const Eigen::Matrix4d world = randomWorld(rng, trial % 2 == 0);
        const PreparedTarget target = randomTarget(world, rng);
        const TermRows joint = rowsAt(jointTargetTerm(), world, target);
        const TermRows position = rowsAt(positionTerm(), world, target);
        CHECK(position == joint.head<3>());
        CHECK(positionTerm().weight(target, 0) == target.positionWeight);
        CHECK(jointTargetTerm().weight(target, 4) == target.rotationWeight);
        const TargetError e = positionTerm().error(world, target);
        CHECK(e.positionCm == doctest::Approx(position.norm() / target.positionWeight).epsilon(1e-12));
        CHECK(e.rotationRad == 0.0);
    }
}

TEST_CASE("residual terms: kinds by name, and an unknown name refused naming the known ones")
{
    CHECK(&residualTerm("jointTarget") == &jointTargetTerm());
    CHECK(&residualTerm("position") == &positionTerm());
    CHECK(jointTargetTerm().index() == 0);
    CHECK(positionTerm().index() == 1);
    CHECK(&termOfKey(0) == &jointTargetTerm());
    JointTarget t;
    t.term = &positionTerm();
    CHECK(termRowsKey(t) == (positionRows | (1 << 2)));
    CHECK(&termOfKey(termRowsKey(t)) == &positionTerm());
    t.positionWeight = 0.0;
    CHECK(termRowsKey(t) == noRows);  // nothing counted: no rows, whatever the kind
    try {
        residualTerm("aim");
        FAIL("no error");
    }
    catch (const Error& e) {
        CHECK(e.kind() == ErrorKind::userInput);
        CHECK(std::string(e.what()).starts_with("unknown residual term 'aim': use one of jointTarget, position"));
    }
    heightTerm();
    CHECK_THROWS_WITH_AS(registerResidualTerm(std::make_unique<HeightTerm>()),
                         "registerResidualTerm: a term named test.height is registered", Error);
}

TEST_CASE("residual terms: position and height terms through ResidualWorkspace on random FK approximations")
{
    std::mt19937 rng(20261127);
    for (int trial = 0; trial < 16; ++trial) {
        CAPTURE(trial);
        const test::RandomFk fk = test::randomFk(rng);
        test::LambdaRig rig = test::lambdaRig(fk, trial % 2 == 0);
        LearnOptions options;
        options.validationPoses = 5;
        const Approximation a = learnApproximation(rig, options, "random");
        REQUIRE(a.discarded.empty());
        std::uniform_real_distribution<double> unit(-1.0, 1.0);
        std::vector<double> values(a.parameters.size()), pose(a.parameters.size());
        for (std::size_t p = 0; p < values.size(); ++p) {
            values[p] = unit(rng);
            pose[p] = unit(rng);
        }
        // Every kind on some output: three, six and one rows meet, so the row offsets are a table.
        const ResidualTerm* kinds[] = {&positionTerm(), nullptr, &heightTerm()};
        const std::vector<JointTarget> targets =
            termTargets(a, pose, [&](std::size_t k) { return kinds[(k + static_cast<std::size_t>(trial)) % 3]; });
        JacobianEvaluator evaluator(a, targets, 10.0);
        int rows = 0;
        for (int o = 0; o < static_cast<int>(a.outputs.size()); ++o) {
            CHECK(evaluator.structure().rowOffset(o) == rows);
            rows += evaluator.structure().term(o).rows();
        }
        REQUIRE(evaluator.rows() == rows);
        Eigen::MatrixXd analytic, finite, suffixes;
        Eigen::VectorXd r, rFinite, rSuffixes;
        evaluator.jacobian(values, JacobianMethod::analytic, 1e-6, analytic, r);
        evaluator.jacobian(values, JacobianMethod::finiteDifference, 1e-6, finite, rFinite);
        evaluator.jacobianFromSuffixes(values, suffixes, rSuffixes);
        CHECK(r == rFinite);
        CHECK(relativeDifference(rSuffixes, r) < 1e-12);
        CHECK(relativeDifference(analytic, finite) < 1e-6);
        CHECK(relativeDifference(suffixes, analytic) < 1e-9);
        // The normal equations from twists (B^T B of each term) against J^T J and J^T r.
        REQUIRE(evaluator.structure().twistForm());
        Eigen::VectorXd g;
        Eigen::MatrixXd hessian;
        evaluator.normalEquations(values, JacobianMethod::analytic, 1e-6, g, hessian, r);
        const Eigen::MatrixXd jtj = analytic.transpose() * analytic;
        CHECK(relativeDifference(hessian.triangularView<Eigen::Lower>().toDenseMatrix(),
                                 jtj.triangularView<Eigen::Lower>().toDenseMatrix()) < 1e-9);
        CHECK(relativeDifference(g, analytic.transpose() * r) < 1e-9);
        // The approximation is the rig: every term's rows vanish at the pose its target came from.
        evaluator.residuals(pose, r);
        CHECK(r.cwiseAbs().maxCoeff() < 1e-9);
    }
}

TEST_CASE("residual terms: position-only targets on the biped reach reachable positions as rotationWeight 0 does")
{
    test::GraphRig rig("rigs/biped.yaml", test::bipedInversionGlobs(), test::bipedCmuJoints());
    const Approximation a = test::learn(rig, "biped");
    const Solver solver(a, SolverOptions{});
    std::mt19937 rng(12);
    for (int pose = 0; pose < 4; ++pose) {
        CAPTURE(pose);
        const std::vector<double> known = test::randomValues(a, rng, 0.5);
        const std::vector<JointTarget> positionOnly =
            termTargets(a, known, [](std::size_t) { return &positionTerm(); });
        std::vector<JointTarget> noRotation = test::targetsAt(a, known);
        for (JointTarget& t : noRotation) t.rotationWeight = 0.0;
        const JacobianEvaluator three(a, positionOnly, 10.0), six(a, noRotation, 10.0);
        CHECK(2 * three.rows() == six.rows());  // three rows per target, not six with three of them zero
        // A previous frame: the known values moved a little, within the limits.
        std::vector<double> start = known;
        for (std::size_t p = 0; p < start.size(); ++p) {
            const RigParameter& param = a.parameters[p].parameter;
            start[p] =
                std::clamp(start[p] + std::uniform_real_distribution<double>(-0.15, 0.15)(rng), param.min, param.max);
        }
        std::vector<double> v3 = start, v6 = start;
        const SolveSummary s3 = solver.solve(positionOnly, v3);
        const SolveSummary s6 = solver.solve(noRotation, v6);
        CAPTURE(s3.briefReport());
        CAPTURE(s6.briefReport());
        CHECK(s3.converged());
        CHECK(s6.converged());
        CHECK(s3.maxPositionErrorCm < 1e-6);
        CHECK(s3.maxRotationErrorDeg == 0.0);  // the position term measures no rotation
        // A cold start on position terms makes a guess, and the solve from it lowers the cost (positions alone
        // leave a cold start far more local minima than joint targets do: a knee bent the other way).
        std::vector<double> cold = a.defaults();
        CHECK(solver.initialGuess(positionOnly, cold) == TerminationType::converged);
        const SolveSummary fromGuess = solver.solve(positionOnly, cold);
        CAPTURE(fromGuess.briefReport());
        CHECK(fromGuess.finalCost < fromGuess.initialCost);
        CHECK(s3.finalCost < 1e-12);
        std::vector<Eigen::Matrix4d> w3, w6;
        a.evaluate(v3, w3);
        a.evaluate(v6, w6);
        for (std::size_t k = 0; k < w3.size(); ++k) {
            if (!positionOnly[k].active || !a.outputs[k].modelled) continue;
            CAPTURE(a.outputs[k].name);
            CHECK((w3[k].block<3, 1>(0, 3) - positionOnly[k].world.block<3, 1>(0, 3)).norm() < 1e-6);
            CHECK((w3[k].block<3, 1>(0, 3) - w6[k].block<3, 1>(0, 3)).norm() < 1e-6);
        }
    }
}

// The partition's blocks solved together (SolverOptions::coupledBlocks, inversion/solve/block_elimination.h):
// on unreachable targets the partitioned solve must stop at the whole problem's optimum, where solving
// the blocks one after another (the outer block fitted first, then held) stops at a worse one. And
// curves must not flip: a clip through gimbal lock is followed without a control jumping more than the
// targets move.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "inversion/clip/clip_inversion.h"
#include "inversion/learn/learner.h"
#include "inversion/model/approximation_io.h"
#include "inversion/random_fk.h"
#include "inversion/solve/block_elimination.h"
#include "inversion/solve/solver.h"
#include "inversion/solve/step_strategy.h"
#include "inversion/solver_rigs.h"
#include "learned_fixtures.h"

using namespace rig;

namespace {

// The approximation's worlds at a random pose, each moved by up to `cm` and turned by up to `degrees`:
// out of the rig's exact reach.
std::vector<JointTarget> unreachableTargets(const Approximation& a, std::mt19937& rng, double cm, double degrees)
{
    std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.6));
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (auto& t : targets) {
        t.world.block<3, 1>(0, 3) += cm * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
        const Eigen::Vector3d axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
        t.world.block<3, 3>(0, 0) =
            Eigen::AngleAxisd(degrees * test::degree * unit(rng), axis).toRotationMatrix() * t.world.block<3, 3>(0, 0);
    }
    return targets;
}

// Every block's parameters as columns and outputs as rows: the coupled system of the partition.
ResidualStructure wholeStructure(const Approximation& a, const Partition& partition)
{
    std::vector<int> columns, outputs;
    for (const PartitionBlock& b : partition.blocks) {
        columns.insert(columns.end(), b.parameters.begin(), b.parameters.end());
        outputs.insert(outputs.end(), b.outputs.begin(), b.outputs.end());
    }
    std::sort(columns.begin(), columns.end());
    std::sort(outputs.begin(), outputs.end());
    return ResidualStructure(a, columns, outputs);
}

// The targets as a ResidualWorkspace takes them, and `values` at the structure's columns.
std::vector<PreparedTarget> preparedTargets(const std::vector<JointTarget>& targets)
{
    std::vector<PreparedTarget> prepared(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) REQUIRE(prepareTarget(targets[k], SolverOptions{}.rotationScaleCm, prepared[k]));
    return prepared;
}

std::vector<double> columnValues(const ResidualStructure& structure, const std::vector<double>& values)
{
    std::vector<double> x;
    for (const int c : structure.columns()) x.push_back(values[static_cast<std::size_t>(c)]);
    return x;
}

struct Costs {
    double coupled = 0.0, whole = 0.0, blockByBlock = 0.0;
};

Costs solveThreeWays(const Approximation& a, const std::vector<JointTarget>& targets)
{
    SolverOptions coupled, whole, sequential;
    whole.partition = false;
    sequential.coupledBlocks = false;
    Costs costs;
    for (auto [options, cost] :
         {std::pair{coupled, &costs.coupled}, {whole, &costs.whole}, {sequential, &costs.blockByBlock}}) {
        std::vector<double> values = a.defaults();
        const SolveSummary s = Solver(a, options).solve(targets, values);
        CAPTURE(s.briefReport());
        CHECK(s.termination == TerminationType::stuck);  // stationary with a residual: out of reach
        *cost = s.finalCost;
    }
    return costs;
}

}  // namespace

TEST_CASE("coupled blocks: on unreachable targets the partitioned solve reaches the whole problem's optimum")
{
    SUBCASE("two arms on a root")
    {
        auto rig = test::twoArms();
        const Approximation a = test::learn(rig, "two arms");
        REQUIRE(Solver(a, SolverOptions{}).partition(test::targetsAt(a, a.defaults())).blocks.size() == 3);
        std::mt19937 rng(3);
        int worseBlockByBlock = 0;
        for (int pose = 0; pose < 20; ++pose) {
            CAPTURE(pose);
            const Costs c = solveThreeWays(a, unreachableTargets(a, rng, 3.0, 10.0));
            CHECK(c.coupled == doctest::Approx(c.whole).epsilon(1e-6));
            CHECK(c.blockByBlock >= c.coupled * (1 - 1e-9));
            worseBlockByBlock += c.blockByBlock > 1.005 * c.coupled;
        }
        CHECK(worseBlockByBlock > 10);  // the case the coupled solve is for
    }
    SUBCASE("the biped")
    {
        const Approximation a = readApproximationFile(test::bipedApproximation());
        std::mt19937 rng(11);
        double coupled = 0, whole = 0, blockByBlock = 0;
        for (int pose = 0; pose < 20; ++pose) {
            CAPTURE(pose);
            const Costs c = solveThreeWays(a, unreachableTargets(a, rng, 2.0, 8.0));
            CHECK(c.coupled <= 1.005 * c.whole);  // the issue's 0.5%, pose by pose
            coupled += c.coupled;
            whole += c.whole;
            blockByBlock += c.blockByBlock;
        }
        MESSAGE("biped, 20 unreachable poses: mean cost coupled " << coupled / 20 << ", whole " << whole / 20
                                                                  << ", block by block " << blockByBlock / 20);
        CHECK(blockByBlock > 1.01 * coupled);
    }
}

TEST_CASE("coupled blocks: a crowd's summary from its trees equals the approximation's own measure")
{
    // Three characters (twoArms, 60 cm apart) sharing nothing: three trees, whose evaluations give the costs and
    // errors. Checked against the approximation evaluated at the values given and returned: costs, worst errors,
    // the worst output and the missed ones, from within the limits and from outside them (clamped first).
    const test::LambdaRig one = test::twoArms();
    const std::size_t n = one.parameters().size();
    test::LambdaRig crowdRig = test::crowdOf(one, 3, 60.0);
    const Approximation a = test::learn(crowdRig, "crowd");
    REQUIRE(a.parameters.size() == 3 * n);
    std::mt19937 rng(21);
    const Solver solver(a, SolverOptions{});
    REQUIRE(solver.partition(unreachableTargets(a, rng, 3.0, 20.0)).roots.size() == 3);
    const auto measured = [&](std::span<const JointTarget> targets, std::span<const double> values, double& cost,
                              double& worstCm, double& worstDeg, std::string& worstOutput, std::vector<int>& missed) {
        std::vector<Eigen::Matrix4d> worlds;
        a.evaluate(values, worlds);
        cost = worstCm = worstDeg = 0.0;
        double worst = -1.0;
        missed.clear();
        for (std::size_t k = 0; k < targets.size(); ++k) {
            PreparedTarget prepared;
            REQUIRE(prepareTarget(targets[k], solver.options().rotationScaleCm, prepared));
            cost += 0.5 * targetResidual(worlds[k], prepared).squaredNorm();
            const TargetError e = targetError(worlds[k], prepared);
            worstCm = std::max(worstCm, e.positionCm);
            worstDeg = std::max(worstDeg, e.rotationRad / test::degree);
            const double combined = std::max(e.positionCm, solver.options().rotationScaleCm * e.rotationRad);
            if (!(combined <= solver.options().targetTolerance)) missed.push_back(static_cast<int>(k));
            if (combined > worst) {
                worst = combined;
                worstOutput = a.outputs[k].name;
            }
        }
    };
    for (int trial = 0; trial < 6; ++trial) {
        CAPTURE(trial);
        // Odd trials: reachable targets but one moved 2 cm (one miss), and a root started past its limits (the
        // initial cost is then the whole's, at the values as given).
        std::vector<JointTarget> targets = unreachableTargets(a, rng, trial % 2 ? 0.0 : 3.0, trial % 2 ? 0.0 : 20.0);
        std::vector<double> values = test::randomValues(a, rng, 0.5);
        if (trial % 2) {
            targets = test::targetsAt(a, test::randomValues(a, rng, 0.5));
            targets[4].world(0, 3) += 2.0;
            values[static_cast<std::size_t>(test::parameterIndex(a, "c1_root.rotateY"))] = 4.0;
        }
        const std::vector<double> start = values;
        const SolveSummary s = solver.solve(targets, values);
        double cost = 0.0, worstCm = 0.0, worstDeg = 0.0;
        std::string worstOutput;
        std::vector<int> missed;
        measured(targets, start, cost, worstCm, worstDeg, worstOutput, missed);
        CHECK(s.initialCost == doctest::Approx(cost).epsilon(1e-12));
        measured(targets, values, cost, worstCm, worstDeg, worstOutput, missed);
        CHECK(s.finalCost == doctest::Approx(cost).epsilon(1e-12));
        CHECK(s.maxPositionErrorCm == doctest::Approx(worstCm).epsilon(1e-9));
        CHECK(s.maxRotationErrorDeg == doctest::Approx(worstDeg).epsilon(1e-9));
        CHECK(s.worstOutput == worstOutput);
        CHECK(s.missedOutputs == missed);
        CHECK(s.termination == (missed.empty() ? TerminationType::converged : TerminationType::stuck));
    }
}

TEST_CASE("coupled blocks: a crowd's trees one after another (the next one prefetched) give the parallel values")
{
    // On one thread the trees are solved in turn, each with the next tree's workspace borrowed and fetched into
    // the cache meanwhile; on several, in parallel. Values and summaries must be the same, bit for bit, along a
    // warm-started chain of frames.
    test::LambdaRig crowdRig = test::crowdOf(test::twoArms(), 4, 60.0);
    const Approximation a = test::learn(crowdRig, "crowd");
    SolverOptions serialOptions;
    serialOptions.threads = 1;
    SolverOptions parallelOptions;
    parallelOptions.threads = 2;
    const Solver serial(a, serialOptions), parallel(a, parallelOptions);
    std::mt19937 rng(8);
    REQUIRE(serial.partition(unreachableTargets(a, rng, 3.0, 20.0)).roots.size() == 4);
    std::vector<double> one = a.defaults(), two = a.defaults();
    for (int frame = 0; frame < 6; ++frame) {
        CAPTURE(frame);
        const std::vector<JointTarget> targets = unreachableTargets(a, rng, frame % 2 ? 0.0 : 3.0, 10.0);
        const SolveSummary s1 = serial.solve(targets, one);
        const SolveSummary s2 = parallel.solve(targets, two);
        CHECK(one == two);
        CHECK(s1.termination == s2.termination);
        CHECK(s1.iterations == s2.iterations);
        CHECK(s1.finalCost == s2.finalCost);
        CHECK(s1.missedOutputs == s2.missedOutputs);
    }
}

namespace {

// The biped's J^T J (`h`, lower triangle, and `g`) with a leaf block's columns scaled by 1e-7 (J D, D = 1e-7 on them:
// its curvatures 1e-14 of the rest's). To the dense factor those directions are null. Judged against the block's own
// scale they were of full rank, and the step was 1e8 off: the rounding of a redundant foot's null
// direction taken for a curvature. The block's step must be the step with those columns left out.
void checkPivotsAtWholeScale(const Partition& partition, const ResidualStructure& structure,
                             const BlockElimination& elimination, const Eigen::MatrixXd& h, const Eigen::VectorXd& g)
{
    const PartitionBlock& leaf = partition.blocks.back();  // parents come before their children
    REQUIRE(leaf.children.empty());
    REQUIRE_FALSE(elimination.folded());
    const Eigen::Index n = structure.columnCount();
    Eigen::VectorXd d = Eigen::VectorXd::Ones(n);
    for (const int p : leaf.parameters) {
        const auto& columns = structure.columns();
        d[std::lower_bound(columns.begin(), columns.end(), p) - columns.begin()] = 1e-7;
    }
    const Eigen::MatrixXd scaled = d.asDiagonal() * Eigen::MatrixXd(h.selfadjointView<Eigen::Lower>()) * d.asDiagonal();
    const Eigen::VectorXd gradient = d.asDiagonal() * g;

    BlockEliminationWorkspace step(elimination);
    const std::vector<int>& layout = elimination.layout();
    for (Eigen::Index col = 0; col < n; ++col)
        for (Eigen::Index row = col; row < n; ++row)
            if (const int at = layout[static_cast<std::size_t>(col * n + row)]; at >= 0)
                step.entries()[static_cast<std::size_t>(at)] = scaled(row, col);
    DenseSystem system(n);
    Eigen::Map<Eigen::MatrixXd>(system.entries().data(), n, n) = scaled;
    const std::vector<char> fixed(static_cast<std::size_t>(n), 0);
    Eigen::VectorXd denseStep(n), delta(n);
    REQUIRE(system.solve(gradient, 0.0, fixed, denseStep));
    REQUIRE(step.solve(gradient, 0.0, delta, fixed));
    // The step with the scaled columns left out (held at zero): the other columns' system is of full rank.
    std::vector<Eigen::Index> kept;
    for (Eigen::Index c = 0; c < n; ++c)
        if (d[c] == 1.0) kept.push_back(c);
    const Eigen::Index m = static_cast<Eigen::Index>(kept.size());
    Eigen::MatrixXd reduced(m, m);
    Eigen::VectorXd reducedGradient(m), expected = Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < m; ++i) {
        reducedGradient[i] = gradient[kept[i]];
        for (Eigen::Index k = 0; k < m; ++k) reduced(i, k) = scaled(kept[i], kept[k]);
    }
    const Eigen::VectorXd reducedStep = reduced.ldlt().solve(-reducedGradient);
    for (Eigen::Index i = 0; i < m; ++i) expected[kept[i]] = reducedStep[i];
    CHECK((delta - expected).norm() <= 1e-9 * expected.norm());
    // The dense range factor keeps the null rows' 1e-7 couplings (its L2), which move its step by about as much.
    CHECK((denseStep - expected).norm() <= 1e-5 * expected.norm());
}

}  // namespace

TEST_CASE(
    "block elimination: J^T J in blocks, and the step equal to the dense system's, with held columns and damping, "
    "every block's pivots judged against the whole system's scale")
{
    const Approximation a = readApproximationFile(test::bipedApproximation());
    std::mt19937 rng(5);
    const std::vector<JointTarget> targets = unreachableTargets(a, rng, 2.0, 8.0);
    const Partition partition = Solver(a, SolverOptions{}).partition(targets);
    REQUIRE(partition.blocks.size() > 5);
    const ResidualStructure structure = wholeStructure(a, partition);
    REQUIRE(structure.twistForm());
    const BlockElimination elimination(partition, structure);
    const std::vector<PreparedTarget> prepared = preparedTargets(targets);
    const std::vector<double> values = test::randomValues(a, rng, 0.5);
    const std::vector<double> x = columnValues(structure, values);

    const Eigen::Index n = structure.columnCount();
    ResidualWorkspace dense(structure), blocks(structure);
    blocks.useLayout(elimination.layout());
    BlockEliminationWorkspace step(elimination);
    for (ResidualWorkspace* w : {&dense, &blocks}) {
        w->holdParameters(values);
        w->setTargets(prepared);
    }
    Eigen::VectorXd r(structure.rows()), g(n), rBlocks(structure.rows()), gBlocks(n);
    Eigen::MatrixXd h(n, n), j(structure.rows(), n);
    const auto entries = [](Eigen::MatrixXd& m) {
        return std::span<double>(m.data(), static_cast<std::size_t>(m.size()));
    };
    dense.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, g, entries(h), j);
    blocks.normalEquations(x, JacobianMethod::analytic, 1e-6, false, rBlocks, gBlocks, step.entries(), j);
    CHECK(rBlocks == r);
    CHECK(gBlocks == g);
    const Eigen::MatrixXd full = h.selfadjointView<Eigen::Lower>();
    for (Eigen::Index c = 0; c < n; ++c) CHECK(step.diagonal(static_cast<int>(c)) == h(c, c));
    const Eigen::VectorXd v = Eigen::VectorXd::Random(n);
    Eigen::VectorXd product(n);
    step.multiply(v, product);
    CHECK((product - full * v).norm() <= 1e-12 * (full * v).norm());

    // At an accepted trial point the solver reuses the trial's evaluation: the same equations, bit for bit.
    std::vector<double> trial = x;
    for (double& t : trial) t += 0.01;
    Eigen::VectorXd rTrial(structure.rows()), gTrial(n), gAgain(n);
    Eigen::MatrixXd hTrial(n, n), hAgain(n, n);
    dense.residuals(trial, rTrial);
    dense.normalEquationsAtLast(rTrial, gTrial, entries(hTrial));
    dense.normalEquations(trial, JacobianMethod::analytic, 1e-6, false, r, gAgain, entries(hAgain), j);
    CHECK(r == rTrial);
    CHECK(gAgain == gTrial);
    CHECK(hAgain == hTrial);

    // Columns held at a limit become identity rows and columns; the damped step is the dense one's.
    Eigen::MatrixXd held = full;
    Eigen::VectorXd gradient = g;
    for (const int c : {0, 4, 17, static_cast<int>(n) - 1}) {
        step.hold(c);
        held.row(c).setZero();
        held.col(c).setZero();
        held(c, c) = 1.0;
        gradient[c] = 0.0;
    }
    for (const double mu : {0.0, 0.3, 50.0}) {
        CAPTURE(mu);
        Eigen::VectorXd delta(n);
        REQUIRE(step.solve(gradient, mu, delta));
        const Eigen::VectorXd expected = (held + mu * Eigen::MatrixXd::Identity(n, n)).ldlt().solve(-gradient);
        CHECK((delta - expected).norm() <= 1e-9 * expected.norm());
        CHECK(delta[4] == 0.0);
    }
    checkPivotsAtWholeScale(partition, structure, elimination, h, g);
}

namespace {

// An elimination of `partition` (folded in twist space where it can be, with `twists`) against the dense
// system: J^T J v, and the damped step with held columns. Returns whether it folded; `steps` gets its steps.
bool eliminationMatchesDense(const Approximation& a, const Partition& partition,
                             const std::vector<JointTarget>& targets, const std::vector<double>& values, bool twists,
                             std::vector<Eigen::VectorXd>& steps)
{
    const ResidualStructure structure = wholeStructure(a, partition);
    const BlockElimination elimination(partition, structure, twists);
    const std::vector<PreparedTarget> prepared = preparedTargets(targets);
    const std::vector<double> x = columnValues(structure, values);

    const Eigen::Index n = structure.columnCount();
    ResidualWorkspace dense(structure), blocks(structure);
    blocks.useLayout(elimination.layout());
    BlockEliminationWorkspace step(elimination, &blocks);
    for (ResidualWorkspace* w : {&dense, &blocks}) {
        w->holdParameters(values);
        w->setTargets(prepared);
    }
    Eigen::VectorXd r(structure.rows()), g(n), rBlocks(structure.rows()), gBlocks(n);
    Eigen::MatrixXd h(n, n), j(structure.rows(), n);
    dense.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, g, std::span<double>(h.data(), h.size()), j);
    blocks.normalEquations(x, JacobianMethod::analytic, 1e-6, false, rBlocks, gBlocks, step.entries(), j);
    CHECK(gBlocks == g);
    const Eigen::MatrixXd full = h.selfadjointView<Eigen::Lower>();
    for (Eigen::Index c = 0; c < n; ++c) CHECK(step.diagonal(static_cast<int>(c)) == h(c, c));
    Eigen::VectorXd v = Eigen::VectorXd::Random(n), product(n);
    step.multiply(v, product);
    CHECK((product - full * v).norm() <= 1e-10 * (full * v).norm());

    Eigen::MatrixXd held = full;
    Eigen::VectorXd gradient = g;
    std::vector<int> holds{0, static_cast<int>(n) / 2, static_cast<int>(n) - 1};
    holds.erase(std::unique(holds.begin(), holds.end()), holds.end());
    for (const int c : holds) {
        step.hold(c);
        held.row(c).setZero();
        held.col(c).setZero();
        held(c, c) = 1.0;
        gradient[c] = 0.0;
    }
    step.multiply(v, product);
    CHECK((product - held * v).norm() <= 1e-10 * (held * v).norm());
    steps.clear();
    for (const double mu : {0.0, 0.3, 50.0}) {
        CAPTURE(mu);
        Eigen::VectorXd delta(n);
        REQUIRE(step.solve(gradient, mu, delta));
        const Eigen::VectorXd expected = (held + mu * Eigen::MatrixXd::Identity(n, n)).ldlt().solve(-gradient);
        CHECK((delta - expected).norm() <= 1e-9 * expected.norm());
        for (const int c : holds) CHECK(std::abs(delta[c]) <= 1e-12 * delta.norm());
        steps.push_back(delta);
    }
    return elimination.folded();
}

void checkFoldedAgainstUnfolded(const Approximation& a, const Partition& partition,
                                const std::vector<JointTarget>& targets, const std::vector<double>& values,
                                bool expectFolded)
{
    std::vector<Eigen::VectorXd> folded, unfolded;
    CHECK(eliminationMatchesDense(a, partition, targets, values, true, folded) == expectFolded);
    CHECK_FALSE(eliminationMatchesDense(a, partition, targets, values, false, unfolded));
    for (std::size_t s = 0; s < folded.size(); ++s)
        CHECK((folded[s] - unfolded[s]).norm() <= 1e-10 * unfolded[s].norm());
}

}  // namespace

TEST_CASE(
    "block elimination folded in twist space: the step and J^T J v of the dense system and of the unfolded "
    "elimination")
{
    SUBCASE("the biped")
    {
        const Approximation a = readApproximationFile(test::bipedApproximation());
        std::mt19937 rng(17);
        for (int pose = 0; pose < 5; ++pose) {
            CAPTURE(pose);
            const std::vector<JointTarget> targets = unreachableTargets(a, rng, 2.0, 8.0);
            const Partition partition = Solver(a, SolverOptions{}).partition(targets);
            REQUIRE(partition.blocks.size() > 5);
            checkFoldedAgainstUnfolded(a, partition, targets, test::randomValues(a, rng, 0.5), true);
        }
    }
    SUBCASE("random FK trees")
    {
        std::mt19937 rng(20261126);
        int folded = 0, coupled = 0;
        for (int trial = 0; trial < 40; ++trial) {
            CAPTURE(trial);
            const test::RandomFk fk = test::randomFk(rng);
            for (const bool relative : {true, false}) {
                CAPTURE(relative);
                test::LambdaRig rig = test::lambdaRig(fk, true);
                LearnOptions options;
                options.relativeFrames = relative;
                options.validationPoses = 5;
                const Approximation a = learnApproximation(rig, options, "random");
                const std::vector<JointTarget> targets = unreachableTargets(a, rng, 3.0, 10.0);
                const Partition partition = Solver(a, SolverOptions{}).partition(targets);
                if (partition.blocks.size() < 2 || partition.roots.size() != 1) continue;
                ++coupled;
                std::vector<Eigen::VectorXd> steps;
                const std::vector<double> values = test::randomValues(a, rng, 0.5);
                folded += eliminationMatchesDense(a, partition, targets, values, true, steps);
            }
        }
        MESSAGE(coupled << " random partitions of several blocks, " << folded << " folded");
        CHECK(coupled >= 10);
        CHECK(folded >= 5);
    }
}

TEST_CASE("block elimination: the fold falls back where a block's nodes do not hang below one node of its parent")
{
    // The biped's hip alone as a child of everything else: the knee (the parent's) hangs below it.
    const Approximation a = readApproximationFile(test::bipedApproximation());
    std::mt19937 rng(23);
    const std::vector<JointTarget> targets = unreachableTargets(a, rng, 2.0, 8.0);
    const Partition solved = Solver(a, SolverOptions{}).partition(targets);
    PartitionBlock all;
    for (const PartitionBlock& b : solved.blocks) {
        all.parameters.insert(all.parameters.end(), b.parameters.begin(), b.parameters.end());
        all.outputs.insert(all.outputs.end(), b.outputs.begin(), b.outputs.end());
    }
    std::sort(all.parameters.begin(), all.parameters.end());
    std::sort(all.outputs.begin(), all.outputs.end());
    const ResidualStructure structure(a, all.parameters, all.outputs);
    // A leg block's column that moves the most outputs: its hip.
    const PartitionBlock* leg = nullptr;
    for (const PartitionBlock& b : solved.blocks)
        if (b.parent >= 0 && b.children.empty() && (!leg || b.parameters.size() > leg->parameters.size())) leg = &b;
    REQUIRE(leg);
    int hip = -1;
    std::size_t most = 0;
    for (const int p : leg->parameters) {
        const int c = static_cast<int>(std::lower_bound(all.parameters.begin(), all.parameters.end(), p) -
                                       all.parameters.begin());
        if (structure.outputsOfColumn(c).size() > most) {
            most = structure.outputsOfColumn(c).size();
            hip = c;
        }
    }
    REQUIRE(hip >= 0);
    Partition partition;
    PartitionBlock outer, inner;
    inner.parameters = {all.parameters[static_cast<std::size_t>(hip)]};
    for (const int o : structure.outputsOfColumn(hip))
        inner.outputs.push_back(all.outputs[static_cast<std::size_t>(o)]);
    for (const int p : all.parameters)
        if (p != inner.parameters[0]) outer.parameters.push_back(p);
    for (const int k : all.outputs)
        if (!std::binary_search(inner.outputs.begin(), inner.outputs.end(), k)) outer.outputs.push_back(k);
    outer.children = {1};
    inner.parent = 0;
    partition.blocks = {outer, inner};
    partition.roots = {0};
    checkFoldedAgainstUnfolded(a, partition, targets, test::randomValues(a, rng, 0.5), false);
}

TEST_CASE("continuity: a clip through gimbal lock is followed without a control jumping")
{
    // A shoulder whose rotate channels reach half a turn either way (R = Rx Ry Rz), an elbow below.
    test::LambdaRig rig({test::angle("shoulder.rotateX", -3.2, 3.2), test::angle("shoulder.rotateY", -3.2, 3.2),
                         test::angle("shoulder.rotateZ", -3.2, 3.2)},
                        {"shoulder", "elbow", "hand"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                            w[0] = test::translation(0, 100, 0) * test::rotation(Eigen::Vector3d::UnitX(), v[0]) *
                                   test::rotation(Eigen::Vector3d::UnitY(), v[1]) *
                                   test::rotation(Eigen::Vector3d::UnitZ(), v[2]);
                            w[1] = w[0] * test::translation(10, 0, 0);
                            w[2] = w[1] * test::translation(10, 2, 1);
                        });
    const Approximation a = test::learn(rig, "shoulder");
    const int shoulderX = test::parameterIndex(a, "shoulder.rotateX"),
              shoulderY = test::parameterIndex(a, "shoulder.rotateY"),
              shoulderZ = test::parameterIndex(a, "shoulder.rotateZ");
    REQUIRE(shoulderY >= 0);
    // R = Rx Ry Rz with Y from 60 to 120 degrees: through gimbal lock at 90, where X and Z turn about
    // one axis; X and Z keep moving slowly.
    constexpr int frames = 201;
    ClipTargets clip;
    double largestTargetStep = 0.0;
    std::vector<double> previous;
    for (int f = 0; f < frames; ++f) {
        std::vector<double> pose = a.defaults();
        const double t = static_cast<double>(f) / (frames - 1);
        pose[static_cast<std::size_t>(shoulderX)] = 20 * test::degree * std::sin(2 * std::numbers::pi * t);
        pose[static_cast<std::size_t>(shoulderY)] = (60 + 60 * t) * test::degree;
        pose[static_cast<std::size_t>(shoulderZ)] = 30 * test::degree * std::cos(2 * std::numbers::pi * t);
        if (!previous.empty())
            for (std::size_t p = 0; p < pose.size(); ++p)
                largestTargetStep = std::max(largestTargetStep, std::abs(pose[p] - previous[p]));
        previous = pose;
        clip.frames.push_back(test::targetsAt(a, pose));
    }
    RigBinding binding(a, rig);
    for (const int restart : {1000, 50}) {
        CAPTURE(restart);
        ClipInversionOptions options;
        options.restartInterval = restart;
        std::vector<std::vector<double>> values;
        const ClipInversionSummary s =
            invertClip(Solver(a, options.solver), binding, clip, 0, frames - 1, options, values);
        CHECK(s.count(FrameStatus::reached) == frames);
        CHECK(s.maxPositionErrorCm < 1e-6);
        double largestStep = 0.0;
        for (int f = 1; f < frames; ++f)
            for (std::size_t p = 0; p < values[0].size(); ++p)
                largestStep = std::max(largestStep, std::abs(values[static_cast<std::size_t>(f)][p] -
                                                             values[static_cast<std::size_t>(f - 1)][p]));
        MESSAGE("restart every " << restart << ": largest control step " << largestStep / test::degree
                                 << " deg per frame; the pose's largest " << largestTargetStep / test::degree);
        // In one warm-start chain the curves follow the pose; a restart in gimbal lock (frame 100 is at
        // Y = 90 degrees) may split X and Z anew: the pose is exact, the curves jump (docs/solver.md).
        if (restart > frames) CHECK(largestStep < 1.5 * largestTargetStep);
    }
}

namespace {

// A world control's translation above a root (translated and turned) and two arms that hang from the world control,
// not the root, each with a translation of its own (as IK goals under a world control): the world's translation,
// the root's opposite and the arms' opposite move nothing, a direction free across the blocks.
test::LambdaRig worldArms()
{
    using test::angle, test::distance;
    std::vector<RigParameter> parameters{distance("world.translateX"),    distance("world.translateY"),
                                         distance("world.translateZ"),    distance("root.translateX"),
                                         distance("root.translateY"),     distance("root.translateZ"),
                                         angle("root.rotateY", -2.5, 2.5)};
    for (const char* side : {"L", "R"})
        for (const std::string name :
             {"arm.translateX", "arm.translateY", "arm.translateZ", "arm.rotateX", "arm.rotateZ", "elbow.rotateZ"})
            parameters.push_back(name.find("translate") != std::string::npos
                                     ? distance(std::string(side) + "_" + name)
                                     : angle(std::string(side) + "_" + name, -1.5, 1.5));
    return test::LambdaRig(std::move(parameters), {"hips", "L_arm", "L_elbow", "L_hand", "R_arm", "R_elbow", "R_hand"},
                           [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
                               using test::translation, test::rotation;
                               const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                                                     z = Eigen::Vector3d::UnitZ();
                               const Eigen::Matrix4d world = translation(v[0], v[1], v[2]);
                               w[0] = world * translation(v[3], 100 + v[4], v[5]) * rotation(y, v[6]);
                               for (std::size_t side = 0; side < 2; ++side) {
                                   const double s = side == 0 ? 1.0 : -1.0;
                                   const std::size_t p = 7 + 6 * side, o = 1 + 3 * side;
                                   w[o] = world * translation(s * 15 + v[p], 140 + v[p + 1], v[p + 2]) *
                                          rotation(x, v[p + 3]) * rotation(z, v[p + 4]);
                                   w[o + 1] = w[o] * translation(s * 25, 0, 0) * rotation(z, v[p + 5]);
                                   w[o + 2] = w[o + 1] * translation(s * 25, 0, 0);
                               }
                           });
}

}  // namespace

TEST_CASE("coupled blocks: an outer block its own outputs do not determine splits, and the step is the whole's")
{
    // The root under two arms, with no target of its own or its rotation alone: the arms' outputs determine it
    // together. Solved together, the partition splits it from them; the steps are the dense system's.
    auto rig = test::twoArms();
    const Approximation a = test::learn(rig, "two arms");
    const int hips = test::outputIndex(a, "hips");
    SolverOptions whole;
    whole.partition = false;
    const Solver coupled(a, SolverOptions{}), dense(a, whole);
    std::mt19937 rng(5);
    for (int pose = 0; pose < 10; ++pose) {
        CAPTURE(pose);
        std::vector<JointTarget> reachable = test::targetsAt(a, test::randomValues(a, rng, 0.5));
        std::vector<JointTarget> unreachable = unreachableTargets(a, rng, 3.0, 10.0);
        for (auto* targets : {&reachable, &unreachable}) {
            if (pose % 2 == 0) (*targets)[static_cast<std::size_t>(hips)].active = false;
            else (*targets)[static_cast<std::size_t>(hips)].positionWeight = 0.0;
        }
        REQUIRE(coupled.partition(reachable).blocks.size() == 3);
        REQUIRE(dense.partition(reachable).blocks.size() == 1);
        std::vector<double> x = a.defaults(), y = a.defaults();
        const SolveSummary s = coupled.solve(reachable, x), t = dense.solve(reachable, y);
        CHECK(s.converged());
        CHECK(s.iterations == t.iterations);
        for (std::size_t p = 0; p < x.size(); ++p) CHECK(x[p] == doctest::Approx(y[p]).epsilon(1e-7).scale(1.0));
        x = y = a.defaults();
        const double c = coupled.solve(unreachable, x).finalCost, d = dense.solve(unreachable, y).finalCost;
        CHECK(c == doctest::Approx(d).epsilon(1e-6));
    }
}

TEST_CASE("coupled blocks: a direction free across the blocks (a world control above the root and the arms)")
{
    // The world's translation against the root's and the arms' opposite ones moves nothing: the root's block does
    // not determine it, and its null direction reaches the arms' blocks. The coupled step is then a Gauss-Newton
    // step other than the dense system's minimum-norm one; every pose is reached all the same, on the real rig.
    auto rig = worldArms();
    const Approximation a = test::learn(rig, "world arms");
    RigBinding binding(a, rig);
    const Solver coupled(a, SolverOptions{});
    SolverOptions sequential;
    sequential.coupledBlocks = false;
    std::mt19937 rng(9);
    const std::vector<JointTarget> rest = test::realTargetsAt(a, binding, a.defaults());
    CHECK(coupled.partition(rest).blocks.size() == 3);
    CHECK(Solver(a, sequential).partition(rest).blocks.size() == 1);  // one after another: the root undetermined
    CHECK(test::posesReachedFromRest(a, coupled, binding, rng, 20, 0.5) == 20);
}

// Long blocks eliminated node by node (BlockElimination::nodeByNode, inversion/solve/block_elimination.h): on chains
// and trees the step must be the dense system's (damped, with held columns), mixed with blocks kept whole; on
// a singular chain (a straight one, positions only) it must still solve the normal equations, differing from the
// minimum-norm step only in directions that change nothing; and a chain rig must solve from rest as the dense
// solve does.
#include <doctest/doctest.h>

#include <algorithm>
#include <random>

#include <fmt/format.h>

#include "inversion/learn/learner.h"
#include "inversion/random_fk.h"
#include "inversion/solve/block_elimination.h"
#include "inversion/solve/minimum_norm_step.h"
#include "inversion/solve/solver.h"
#include "inversion/solver_rigs.h"

using namespace rig;

namespace {

// An FK hierarchy on `parent` (parents first) with random offsets, joint orients and rotate orders, every rotate
// channel a parameter and some translate channels; `straight`: every joint one unit of 10 cm along x of its parent,
// no orients (a straight limb at rest).
test::RandomFk fkOn(std::mt19937& rng, std::vector<int> parent, bool straight = false)
{
    test::RandomFk fk;
    fk.parent = std::move(parent);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const std::array<std::array<int, 3>, 6> orders{{{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}}};
    for (std::size_t j = 0; j < fk.parent.size(); ++j) {
        const Eigen::Vector3d o(unit(rng), unit(rng), unit(rng));
        fk.offset.push_back(straight ? Eigen::Vector3d(j == 0 ? 0.0 : 10.0, 0.0, 0.0)
                                     : Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 10.0);
        fk.orient.push_back(straight || std::bernoulli_distribution(0.5)(rng)
                                ? Eigen::Matrix3d::Identity()
                                : Eigen::AngleAxisd(0.5 * o.norm(), o.normalized()).toRotationMatrix());
        fk.order.push_back(orders[static_cast<std::size_t>(std::uniform_int_distribution<int>(0, 5)(rng))]);
        for (int axis = 0; axis < 3; ++axis) {
            fk.channels.push_back({static_cast<int>(j), false, axis});
            if (!straight && (j == 0 || std::bernoulli_distribution(0.1)(rng)))
                fk.channels.push_back({static_cast<int>(j), true, axis});
        }
    }
    std::shuffle(fk.channels.begin(), fk.channels.end(), rng);
    return fk;
}

// Parents of a serial chain of `joints`, hung from `from` (-1: a root).
void appendChain(std::vector<int>& parent, int joints, int from)
{
    for (int j = 0; j < joints; ++j) parent.push_back(j == 0 ? from : static_cast<int>(parent.size()) - 1);
}

Approximation learned(const test::RandomFk& fk)
{
    test::LambdaRig rig = test::lambdaRig(fk, true);
    LearnOptions options;
    options.validationPoses = 5;
    return learnApproximation(rig, options, "long");
}

// Every parameter and output of `a` as one block.
Partition oneBlock(const Approximation& a)
{
    Partition p;
    PartitionBlock all;
    for (std::size_t i = 0; i < a.parameters.size(); ++i) all.parameters.push_back(static_cast<int>(i));
    for (std::size_t k = 0; k < a.outputs.size(); ++k) all.outputs.push_back(static_cast<int>(k));
    p.blocks.push_back(all);
    p.roots.push_back(0);
    return p;
}

// The system of `partition` at `values` on `targets`, dense and by elimination (folded: node by node where a block
// is long).
struct Systems {
    Systems(const Approximation& a, const Partition& partition, const std::vector<JointTarget>& targets,
            const std::vector<double>& values)
        : structure(a, indices(partition, &PartitionBlock::parameters), indices(partition, &PartitionBlock::outputs)),
          elimination(partition, structure, true),
          dense(structure),
          blocks(structure),
          step(elimination, &blocks)
    {
        std::vector<PreparedTarget> prepared(targets.size());
        for (std::size_t k = 0; k < targets.size(); ++k)
            if (targets[k].active) REQUIRE(prepareTarget(targets[k], SolverOptions{}.rotationScaleCm, prepared[k]));
        blocks.useLayout(elimination.layout());
        std::vector<double> x;
        for (const int c : structure.columns()) x.push_back(values[static_cast<std::size_t>(c)]);
        const Eigen::Index n = structure.columnCount();
        for (ResidualWorkspace* w : {&dense, &blocks}) {
            w->holdParameters(values);
            w->setTargets(prepared);
        }
        Eigen::VectorXd r(structure.rows()), gBlocks(n);
        Eigen::MatrixXd h(n, n), j(structure.rows(), n);
        g.resize(n);
        dense.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, g, std::span<double>(h.data(), h.size()), j);
        blocks.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, gBlocks, step.entries(), j);
        CHECK(gBlocks == g);
        full = h.selfadjointView<Eigen::Lower>();
    }

    // Every block's parameters (or outputs), increasing.
    static std::vector<int> indices(const Partition& partition, std::vector<int> PartitionBlock::*field)
    {
        std::vector<int> all;
        for (const PartitionBlock& b : partition.blocks) all.insert(all.end(), (b.*field).begin(), (b.*field).end());
        std::sort(all.begin(), all.end());
        return all;
    }

    ResidualStructure structure;
    BlockElimination elimination;
    ResidualWorkspace dense, blocks;
    BlockEliminationWorkspace step;
    Eigen::VectorXd g;
    Eigen::MatrixXd full;  // J^T J
};

// The elimination's J^T J v and damped steps, with held columns, against the dense system's.
void checkAgainstDense(Systems& s)
{
    const Eigen::Index n = s.structure.columnCount();
    for (Eigen::Index c = 0; c < n; ++c) CHECK(s.step.diagonal(static_cast<int>(c)) == s.full(c, c));
    const Eigen::VectorXd v = Eigen::VectorXd::Random(n);
    Eigen::VectorXd product(n);
    s.step.multiply(v, product);
    CHECK((product - s.full * v).norm() <= 1e-10 * (s.full * v).norm());
    for (const bool hold : {false, true}) {
        CAPTURE(hold);
        Eigen::MatrixXd held = s.full;
        Eigen::VectorXd gradient = s.g;
        const std::vector<int> holds{0, static_cast<int>(n) / 3, static_cast<int>(n) - 1};
        for (const int c : hold ? holds : std::vector<int>{}) {
            s.step.hold(c);
            held.row(c).setZero();
            held.col(c).setZero();
            held(c, c) = 1.0;
            gradient[c] = 0.0;
        }
        for (const double mu : {0.0, 0.3, 50.0}) {
            CAPTURE(mu);
            Eigen::VectorXd delta(n);
            REQUIRE(s.step.solve(gradient, mu, delta));
            const Eigen::VectorXd expected = test::minimumNormStep(held, mu, gradient);
            CHECK((delta - expected).norm() <= 1e-9 * expected.norm());
            if (hold)
                for (const int c : holds) CHECK(std::abs(delta[c]) <= 1e-12 * delta.norm());
        }
    }
}

// The approximation's worlds at a random pose, moved by up to 2 cm and 8 degrees: out of exact reach.
std::vector<JointTarget> offTargets(const Approximation& a, std::mt19937& rng)
{
    std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.4));
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (auto& t : targets) {
        t.world.block<3, 1>(0, 3) += 2.0 * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
        const Eigen::Vector3d axis = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized();
        t.world.block<3, 3>(0, 0) =
            Eigen::AngleAxisd(8.0 * test::degree * unit(rng), axis).toRotationMatrix() * t.world.block<3, 3>(0, 0);
    }
    return targets;
}

}  // namespace

TEST_CASE("node by node: a long block's step is the dense system's, alone or between blocks kept whole")
{
    std::mt19937 rng(20261127);
    struct Shape {
        const char* name;
        std::vector<int> parent;
    };
    std::vector<Shape> shapes;
    appendChain(shapes.emplace_back("a chain of 12 joints").parent, 12, -1);
    shapes.push_back({"a random tree of 12 joints", {-1}});
    for (int j = 1; j < 12; ++j) shapes.back().parent.push_back(std::uniform_int_distribution<int>(0, j - 1)(rng));
    appendChain(shapes.emplace_back("a root with two tails of 10 joints").parent, 1, -1);
    appendChain(shapes.back().parent, 10, 0);
    appendChain(shapes.back().parent, 10, 0);
    appendChain(shapes.emplace_back("a spine of 10 joints with two arms of 3").parent, 10, -1);
    appendChain(shapes.back().parent, 3, 9);
    appendChain(shapes.back().parent, 3, 9);
    int split = 0;
    for (const Shape& shape : shapes) {
        CAPTURE(shape.name);
        const test::RandomFk fk = fkOn(rng, shape.parent);
        const Approximation a = learned(fk);
        for (int pose = 0; pose < 2; ++pose) {
            CAPTURE(pose);
            const std::vector<JointTarget> targets = offTargets(a, rng);
            const std::vector<double> values = test::randomValues(a, rng, 0.5);
            for (const Partition& partition : {oneBlock(a), Solver(a, SolverOptions{}).partition(targets)}) {
                CAPTURE(partition.blocks.size());
                Systems s(a, partition, targets, values);
                REQUIRE(s.elimination.folded());
                std::size_t longest = 0;
                for (const PartitionBlock& b : partition.blocks) longest = std::max(longest, b.parameters.size());
                CHECK(s.elimination.nodeByNode() ==
                      (longest > static_cast<std::size_t>(BlockElimination::recursiveAbove)));
                split += s.elimination.nodeByNode();
                checkAgainstDense(s);
            }
        }
    }
    CHECK(split >= 12);
}

namespace {

// The step of the unfolded elimination of `partition` (every block kept whole and factored densely, minimum-norm
// within a singular block: the step before blocks were split), at mu = 0.
Eigen::VectorXd unfoldedStep(const Approximation& a, const Partition& partition,
                             const std::vector<JointTarget>& targets, const std::vector<double>& values)
{
    const ResidualStructure structure(a, Systems::indices(partition, &PartitionBlock::parameters),
                                      Systems::indices(partition, &PartitionBlock::outputs));
    const BlockElimination elimination(partition, structure, false);
    REQUIRE_FALSE(elimination.nodeByNode());
    std::vector<PreparedTarget> prepared(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k)
        if (targets[k].active) REQUIRE(prepareTarget(targets[k], SolverOptions{}.rotationScaleCm, prepared[k]));
    ResidualWorkspace w(structure);
    w.useLayout(elimination.layout());
    w.holdParameters(values);
    w.setTargets(prepared);
    BlockEliminationWorkspace step(elimination);
    std::vector<double> x;
    for (const int c : structure.columns()) x.push_back(values[static_cast<std::size_t>(c)]);
    const Eigen::Index n = structure.columnCount();
    Eigen::VectorXd r(structure.rows()), g(n), delta(n);
    Eigen::MatrixXd j(structure.rows(), n);
    w.normalEquations(x, JacobianMethod::analytic, 1e-6, false, r, g, step.entries(), j);
    REQUIRE(step.solve(g, 0.0, delta));
    return delta;
}

// A partition by joints: block b holds the channels and outputs of joints[b], below parents[b].
Partition byJoints(const Approximation& a, const std::vector<std::vector<int>>& joints, const std::vector<int>& parents)
{
    Partition p;
    for (std::size_t b = 0; b < joints.size(); ++b) {
        PartitionBlock block;
        block.parent = parents[b];
        for (const int j : joints[b]) {
            block.outputs.push_back(test::outputIndex(a, fmt::format("j{}", j)));
            for (const char* channel : {"rotateX", "rotateY", "rotateZ"})
                block.parameters.push_back(test::parameterIndex(a, fmt::format("j{}.{}", j, channel)));
        }
        std::sort(block.parameters.begin(), block.parameters.end());
        if (block.parent < 0) p.roots.push_back(static_cast<int>(b));
        else p.blocks[static_cast<std::size_t>(block.parent)].children.push_back(static_cast<int>(b));
        p.blocks.push_back(std::move(block));
    }
    return p;
}

}  // namespace

TEST_CASE("node by node: a singular block's step is the minimum-norm step within it, as before blocks were split")
{
    // Straight limbs at rest with targets on positions only: turning a joint about the limb's axis moves no joint,
    // so J^T J has a null space; with the ends' positions alone (the tip; the spine's and the arms'), a null space
    // of all but three dimensions per end. Node by node, a pivot at or below 1e-12 of the block's largest diagonal
    // hands the step to the blocks unsplit, whose minimum-norm step leaves the null space alone (leaf first, the
    // last joints would take the whole motion: more than twenty times the minimum norm's on the tip alone).
    // Shapes: a chain of 12 joints as one block, and a spine of 10 joints (a block split node by node) with two
    // arms of 3 (blocks kept whole below it).
    std::mt19937 rng(35);
    std::vector<int> chain, spine;
    appendChain(chain, 12, -1);
    appendChain(spine, 10, -1);
    appendChain(spine, 3, 9);
    appendChain(spine, 3, 9);
    for (const bool armed : {false, true}) {
        CAPTURE(armed);
        const test::RandomFk fk = fkOn(rng, armed ? spine : chain, true);
        const Approximation a = learned(fk);
        const Partition partition =
            armed ? byJoints(a, {{0, 1, 2, 3, 4, 5, 6, 7, 8, 9}, {10, 11, 12}, {13, 14, 15}}, {-1, 0, 0}) : oneBlock(a);
        const std::vector<int> ends = armed ? std::vector<int>{9, 12, 15} : std::vector<int>{11};
        for (const bool endsOnly : {false, true}) {
            CAPTURE(endsOnly);
            std::vector<JointTarget> targets = test::targetsAt(a, test::randomValues(a, rng, 0.3));
            for (JointTarget& t : targets) t.rotationWeight = 0.0;
            for (std::size_t k = 0; k < targets.size(); ++k)
                targets[k].active = !endsOnly || std::find(ends.begin(), ends.end(),
                                                           std::stoi(a.outputs[k].name.substr(1))) != ends.end();
            Systems s(a, partition, targets, a.defaults());
            REQUIRE(s.elimination.nodeByNode());
            const Eigen::Index n = s.structure.columnCount();
            const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(s.full);
            const Eigen::VectorXd& lambda = eigen.eigenvalues();
            const Eigen::Index rank = endsOnly ? 3 * static_cast<Eigen::Index>(ends.size()) : n - 12;
            CHECK((lambda.array() <= 1e-12 * lambda.maxCoeff()).count() >= n - rank);
            Eigen::VectorXd delta(n);
            REQUIRE(s.step.solve(s.g, 0.0, delta));
            const Eigen::VectorXd before = unfoldedStep(a, partition, targets, a.defaults());
            CHECK((delta - before).norm() <= 1e-8 * before.norm());
            CHECK((s.full * delta + s.g).norm() <= 1e-8 * s.g.norm());
            if (!armed) CHECK((delta - test::minimumNormStep(s.full, 0.0, s.g)).norm() <= 1e-8 * delta.norm());
            // Held columns, and the damped system (regular: node by node): the dense system's steps.
            if (!armed) checkAgainstDense(s);
        }
    }
}

TEST_CASE("node by node: a chain rig solves from rest to its targets, as the dense solve does, on 1 and 2 threads")
{
    std::mt19937 rng(134);
    std::vector<int> parent;
    appendChain(parent, 15, -1);
    const test::RandomFk fk = fkOn(rng, parent);
    const Approximation a = learned(fk);
    REQUIRE(a.parameters.size() > static_cast<std::size_t>(BlockElimination::recursiveAbove));
    const std::vector<double> truth = test::randomValues(a, rng, 0.3);
    const std::vector<JointTarget> targets = test::targetsAt(a, truth);
    const Partition partition = Solver(a, SolverOptions{}).partition(targets);
    REQUIRE(partition.blocks.size() == 1);  // nothing partitions a chain: one long block

    // Analytic (twists: node by node), then finite differences (a dense system), from rest.
    std::vector<std::vector<double>> answers;
    for (const JacobianMethod jacobian : {JacobianMethod::analytic, JacobianMethod::finiteDifference}) {
        for (const int threads : {1, 2}) {
            CAPTURE(threads);
            SolverOptions options;
            options.jacobian = jacobian;
            options.threads = threads;
            const Solver solver(a, options);
            std::vector<double> values = a.defaults();
            const SolveSummary summary = solver.solve(targets, values);
            CAPTURE(summary.briefReport());
            CHECK(summary.termination == TerminationType::converged);
            CHECK(summary.maxPositionErrorCm < 1e-6);
            if (threads == 2) CHECK(values == answers.back());  // bit for bit
            answers.push_back(values);
        }
    }
    for (std::size_t p = 0; p < truth.size(); ++p) CHECK(answers[0][p] == doctest::Approx(answers[2][p]).epsilon(1e-6));
}

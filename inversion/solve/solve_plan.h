#pragma once
// The solver's plans (internal to solver.cpp and initial_guess.cpp): for one set of counted outputs, the
// partition into blocks, each block's residual structure and unknowns, the coupled trees' block eliminations,
// the flow graph that runs blocks in parallel, and the workspaces solves borrow from pools.

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include <oneapi/tbb/flow_graph.h>
#include <Eigen/Core>

#include "core/pool.h"
#include "inversion/model/approximation.h"
#include "inversion/solve/block_elimination.h"
#include "inversion/solve/equivalences.h"
#include "inversion/solve/jacobian.h"
#include "inversion/solve/minimizer.h"
#include "inversion/solve/partition.h"
#include "inversion/solve/solver.h"
#include "inversion/solve/step_strategy.h"

namespace rig {

// Everything one block's solve touches, sized once for the block: the approximation's side of the minimizer.
struct BlockWorkspace final : MinimizerProblem {
    BlockWorkspace(const ResidualStructure& structure, const BlockElimination* coupled);
    BlockWorkspace(const BlockWorkspace&) = delete;  // its residual workspace knows J by address (formsInPlace)
    BlockWorkspace& operator=(const BlockWorkspace&) = delete;

    // Set before each minimize(): how the normal equations are formed.
    void configure(const SolverOptions& options, bool parallel);
    bool linearize(std::span<const double> x, bool atTrial, Eigen::VectorXd& r, Eigen::VectorXd& g) override;
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override { residual.residuals(x, r); }
    double diagonal(Eigen::Index i) const override;
    void hold(Eigen::Index i) override;
    bool solveStep(const Eigen::VectorXd& gradient, double damping, std::span<const char> fixed,
                   Eigen::VectorXd& delta) override;
    void multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) override;
    void prefetch() const;

    ResidualWorkspace residual;
    MinimizerState state;
    Eigen::MatrixXd J;  // formed only where the normal equations need it (ResidualWorkspace::normalEquations)
    DenseSystem dense;  // J^T J where the step is not by elimination (empty otherwise)
    std::unique_ptr<BlockEliminationWorkspace>
        elimination;  // a coupled plan's step (inversion/solve/block_elimination.h)

private:
    std::span<double> entries() { return elimination ? elimination->entries() : dense.entries(); }
    const SolverOptions* options_ = nullptr;
    bool parallel_ = false;
    bool reuse_ = false;  // an accepted trial point's evaluation gives the normal equations (analytic, twist form)
};

struct BlockPlan {
    // `terms`: per output, its residual term (empty: every one a joint target; ResidualStructure).
    BlockPlan(const Approximation& approximation, const Equivalences& equivalences, const PartitionBlock& block,
              std::span<const ResidualTerm* const> terms);
    ResidualStructure structure;
    Unknowns unknowns;
    bool rotationsOnly = true;  // every operator of every parameter is a rotation about a pivot (an angular kind)
    // Set for a partition's coupled solve, or a long block eliminated node by node: the step by elimination
    // instead of one dense system.
    std::unique_ptr<BlockElimination> elimination;
    mutable Pool<BlockWorkspace> pool;
    std::unique_ptr<BlockWorkspace> makeWorkspace() const
    {
        return std::make_unique<BlockWorkspace>(structure, elimination.get());
    }
};

// One step of Solver::initialGuess: the parameters that the output's target fixes, solved on it alone (or with
// the later outputs only they move, where the one output leaves some of them free).
struct GuessStep {
    GuessStep(const Approximation& approximation, const Equivalences& equivalences, const PartitionBlock& b,
              std::vector<int> first, std::span<const ResidualTerm* const> terms)
        : block(b), own(std::move(first)), plan(approximation, equivalences, b, terms)
    {
    }
    PartitionBlock block;
    // The parameters first fixed at this step (all of them, but for a step solving earlier ones again): what the
    // placement of its chains' goals and poles may move (placeChain).
    std::vector<int> own;
    BlockPlan plan;
};

struct WholeWorkspace {
    explicit WholeWorkspace(const ResidualStructure& structure) : residual(structure), r(structure.rows()) {}
    ResidualWorkspace residual;
    Eigen::VectorXd r;
};

// The partition as a TBB flow graph: a node per block, an edge from each block to its children, so that
// a block runs once its parent has and independent blocks (left arm, right arm) run in parallel. Built
// once per plan and borrowed by one solve at a time (a graph runs one solve's blocks).
class BlockGraph {
public:
    explicit BlockGraph(const Partition& partition);
    // Runs body(block) for every block, parents before children; returns when all have run.
    void run(const std::function<void(int)>& body);

private:
    using Node = tbb::flow::continue_node<tbb::flow::continue_msg>;
    tbb::flow::graph graph_;
    tbb::flow::broadcast_node<tbb::flow::continue_msg> start_;
    std::vector<std::unique_ptr<Node>> nodes_;
    const std::function<void(int)>* body_ = nullptr;
};

// Hints the cache to fetch what solving `tree` in `w` touches: the workspace's arrays, the tree's limits and
// its outputs' prepared targets.
void prefetchTree(const BlockPlan& tree, const BlockWorkspace& w, std::span<const PreparedTarget> prepared);

// The partition for one set of counted rows, with what its blocks need.
struct Plan {
    // `twists`: the analytic Jacobian (the coupled systems' normal equations from twists where in twist form).
    // `terms`: per output, its residual term (empty: every one a joint target).
    Plan(const Approximation& approximation, const Equivalences& equivalences, Partition p, std::vector<int> counted,
         std::vector<const ResidualTerm*> terms, bool coupledBlocks, bool twists);
    // Tree t's plan: its system, or its one block's.
    const BlockPlan& tree(std::size_t t) const
    {
        return trees[t] ? *trees[t] : *blocks[static_cast<std::size_t>(partition.roots[t])];
    }
    // The steps of initialGuess, made when first needed: parents first, each counted output with the
    // solved parameters that reach it and no output before it. A later output left with none joins the latest
    // step that moves it when that step leaves some of its parameters free (fewer rows than parameters, or a
    // parameter moving none of its outputs at rest: a reverse foot's ankle, ball and toe). Where a step whose
    // parameters move an input of the output's constraint leaves a combination free that the output's target fixes
    // (together they leave fewer free at rest than apart: an ikSCsolver ball's goal under the foot control, after
    // the ankle's own control), a step after solves the steps from that one on that move it again, together with
    // it and its own parameters (docs/solver.md, Cold starts).
    const std::vector<std::unique_ptr<GuessStep>>& guessSteps(const Approximation& approximation,
                                                              const Equivalences& equivalences) const;

    Partition partition;
    std::vector<const ResidualTerm*> terms;
    std::vector<std::unique_ptr<BlockPlan>> blocks;
    // With SolverOptions::coupledBlocks, per root of the partition: its tree's blocks solved at once,
    // the step by block elimination; null for a tree of one block (blocks[root] solves it). Empty when
    // the blocks are solved one after another.
    std::vector<std::unique_ptr<BlockPlan>> trees;
    // The coupled solve's one system when it has every counted output as its rows: its first evaluation is
    // then the whole's (the same products in the same order), null otherwise.
    const BlockPlan* system = nullptr;
    // With several trees: whether they have every counted output as their rows between them, in twist form.
    // Their evaluations then give the whole's costs and errors (crowds), summed tree by tree.
    bool treesCover = false;
    ResidualStructure whole;  // every counted output, no unknowns: costs and errors
    mutable Pool<WholeWorkspace> wholePool;
    mutable Pool<BlockGraph> graphs;

private:
    static void eliminateNodeByNode(BlockPlan& plan);
    // One coupled system per independent tree (a crowd's members share nothing).
    void planTrees(const Approximation& approximation, const Equivalences& equivalences, bool twists);
    // Partition of tree t: its blocks renumbered from its root, and all of them as one block.
    void treeBlocks(const std::vector<int>& treeOf, int t, Partition& tree, PartitionBlock& all) const;
    mutable std::once_flag guessOnce;
    mutable std::vector<std::unique_ptr<GuessStep>> guess;
};

// The final cost and errors of some outputs' evaluation: the whole's, or one tree's share (Plan::treesCover).
struct TreeErrors {
    bool valid = false;  // set from an evaluation at the values returned
    double cost = 0.0;
    double maxPositionCm = 0.0, maxRotationDeg = 0.0;
    double worst = -1.0;  // the largest combined error, at output worstOutput (the first such)
    int worstOutput = -1;
};

// An angular unknown of Solver::initialGuess and its three starts.
struct Varied {
    std::size_t parameter;
    std::array<double, 3> starts;
};

// Per-solve scratch sized by the approximation.
struct SolveScratch {
    std::vector<PreparedTarget> prepared;
    std::vector<unsigned char> rows;
    std::string key;  // rows as the plan cache's key (a std::string: no allocation once it has grown)
    std::vector<MinimizerResult> results;
    std::vector<TreeErrors> treeErrors;  // per tree, when the trees give the whole's errors
    std::vector<char> missed;            // per output: further than targetTolerance (Solver::solve's errors)
    std::vector<double> trial, best;     // initialGuess: the start being solved, the best answer so far
    std::vector<double> held;            // Solver::solve: the first answer, while a held goal's is solved again
    std::vector<double> branches;        // Solver::solve: the inactive branches' controls at the warm start
    std::vector<double> start;           // Solver::solve: the warm start, while a switch's other branch is tried
    std::vector<double> aimReach;        // per AimHold: its target's distance from the aim's root at the start
    std::vector<Varied> varied;
};

}  // namespace rig

#include "inversion/solver.h"

#include "core/prefetch.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <oneapi/tbb/flow_graph.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "inversion/block_elimination.h"
#include "inversion/continuity.h"

namespace rig {
namespace {

// A free list of scratch objects: solves on many threads each take one, and return it, so that a
// steady stream of solves allocates nothing.
template <class T>
class Pool {
public:
    template <class Make>
    std::unique_ptr<T> acquire(Make&& make)
    {
        {
            std::lock_guard lock(mutex_);
            if (!free_.empty()) {
                std::unique_ptr<T> item = std::move(free_.back());
                free_.pop_back();
                return item;
            }
        }
        return make();
    }
    void release(std::unique_ptr<T> item)
    {
        std::lock_guard lock(mutex_);
        free_.push_back(std::move(item));
    }

private:
    std::mutex mutex_;
    std::vector<std::unique_ptr<T>> free_;
};

// Returns the item to its pool on every way out of a scope.
template <class T>
class Borrowed {
public:
    template <class Make>
    Borrowed(Pool<T>& pool, Make&& make) : pool_(pool), item_(pool.acquire(std::forward<Make>(make)))
    {
    }
    ~Borrowed() { pool_.release(std::move(item_)); }
    Borrowed(const Borrowed&) = delete;
    Borrowed& operator=(const Borrowed&) = delete;
    T& operator*() const { return *item_; }
    T* operator->() const { return item_.get(); }

private:
    Pool<T>& pool_;
    std::unique_ptr<T> item_;
};

// Everything one block's solve touches, sized once for the block.
struct BlockWorkspace {
    BlockWorkspace(const ResidualStructure& structure, const BlockElimination* coupled)
        : residual(structure),
          x(static_cast<std::size_t>(structure.columnCount())),
          trial(x.size()),
          r(structure.rows()),
          rTrial(structure.rows()),
          hStep(structure.columnCount()),
          g(structure.columnCount()),
          gFree(structure.columnCount()),
          delta(structure.columnCount()),
          step(structure.columnCount()),
          projected(structure.columnCount()),
          J(structure.rows(), structure.columnCount()),
          // Dense J^T J and its factorizations only where the step is not by elimination.
          H(coupled ? 0 : structure.columnCount(), coupled ? 0 : structure.columnCount()),
          damped(coupled ? 0 : structure.columnCount(), coupled ? 0 : structure.columnCount()),
          llt(coupled ? 0 : structure.columnCount()),
          eigen(coupled ? 0 : structure.columnCount()),
          fixed(x.size(), 0)
    {
        if (coupled) {
            elimination = std::make_unique<BlockEliminationWorkspace>(*coupled, &residual);
            residual.useLayout(coupled->layout());
        }
    }
    // Where the normal equations put J^T J: the blocks of the elimination, or the dense H.
    std::span<double> entries()
    {
        return elimination ? elimination->entries() : std::span<double>(H.data(), static_cast<std::size_t>(H.size()));
    }
    double diagonal(Eigen::Index i) const { return elimination ? elimination->diagonal(static_cast<int>(i)) : H(i, i); }
    void hold(Eigen::Index i)
    {
        if (elimination) return elimination->hold(static_cast<int>(i));
        H.row(i).head(i).setZero();
        H.col(i).tail(H.rows() - i - 1).setZero();
        H(i, i) = 1.0;
    }
    ResidualWorkspace residual;
    std::vector<double> x, trial;
    Eigen::VectorXd r, rTrial, hStep, g, gFree, delta, step, projected;
    Eigen::MatrixXd J;       // formed only where the normal equations need it (ResidualWorkspace::normalEquations)
    Eigen::MatrixXd H;       // J^T J, lower triangle (dense step only)
    Eigen::MatrixXd damped;  // H + mu I, lower triangle: what the dense step factorizes
    Eigen::LLT<Eigen::MatrixXd> llt;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen;
    std::vector<char> fixed;
    std::unique_ptr<BlockEliminationWorkspace> elimination;  // a coupled plan's step (inversion/block_elimination.h)

    void prefetch() const
    {
        residual.prefetch();
        if (elimination) elimination->prefetch();
        rig::prefetch(x);
        rig::prefetch(trial);
        rig::prefetch(fixed);
        for (const Eigen::VectorXd* v : {&r, &rTrial, &hStep, &g, &gFree, &delta, &step})
            prefetchBytes(v->data(), static_cast<std::size_t>(v->size()) * sizeof(double));
    }
};

struct BlockPlan {
    BlockPlan(const Approximation& approximation, const Equivalences& equivalences, const PartitionBlock& block)
        : structure(approximation, block.parameters, block.outputs)
    {
        // Only a control's own limits bind; a free one's min..max is just the range it was learned on.
        constexpr double free = std::numeric_limits<double>::infinity();
        for (const int p : block.parameters) {
            const ModelledParameter& m = approximation.parameters[static_cast<std::size_t>(p)];
            lower.push_back(m.parameter.limited ? m.parameter.min : -free);
            upper.push_back(m.parameter.limited ? m.parameter.max : free);
            angular.push_back(m.parameter.angular);
            period.push_back(equivalences.period[static_cast<std::size_t>(p)]);
            defaults.push_back(m.parameter.defaultValue);
            for (const Operator& op : m.operators) rotationsOnly = rotationsOnly && op.kind == OperatorKind::rotation;
        }
        // The approximation's Euler triples whose three channels are all solved here, as columns.
        const auto column = [&](int p) {
            const auto it = std::lower_bound(block.parameters.begin(), block.parameters.end(), p);
            return it != block.parameters.end() && *it == p ? static_cast<int>(it - block.parameters.begin()) : -1;
        };
        for (const auto& [a, b, c] : equivalences.triples)
            if (column(a) >= 0 && column(b) >= 0 && column(c) >= 0)
                triples.push_back({column(a), column(b), column(c)});
    }
    ResidualStructure structure;
    std::vector<double> lower, upper;
    std::vector<bool> angular;
    std::vector<double> period;  // > 0: the values x and x + period give the same pose (Equivalences::period)
    std::vector<double> defaults;
    std::vector<std::array<int, 3>> triples;  // columns that are Euler angles of one rotation (Equivalences::triples)
    bool rotationsOnly = true;                // every operator of every parameter is a rotation about a pivot
    // Set for a partition's coupled solve: the blocks' step by elimination instead of one dense system.
    std::unique_ptr<BlockElimination> elimination;
    mutable Pool<BlockWorkspace> pool;
};

// One step of Solver::initialGuess: the parameters that the output's target fixes, solved on it alone.
struct GuessStep {
    GuessStep(const Approximation& approximation, const Equivalences& equivalences, const PartitionBlock& b)
        : block(b), plan(approximation, equivalences, b)
    {
    }
    PartitionBlock block;
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
    explicit BlockGraph(const Partition& partition) : start_(graph_)
    {
        for (std::size_t b = 0; b < partition.blocks.size(); ++b)
            nodes_.push_back(std::make_unique<Node>(
                graph_, [this, b](const tbb::flow::continue_msg&) { (*body_)(static_cast<int>(b)); }));
        for (const int root : partition.roots) tbb::flow::make_edge(start_, *nodes_[static_cast<std::size_t>(root)]);
        for (std::size_t b = 0; b < partition.blocks.size(); ++b)
            for (const int child : partition.blocks[b].children)
                tbb::flow::make_edge(*nodes_[b], *nodes_[static_cast<std::size_t>(child)]);
    }

    // Runs body(block) for every block, parents before children; returns when all have run.
    void run(const std::function<void(int)>& body)
    {
        body_ = &body;
        start_.try_put(tbb::flow::continue_msg());
        try {
            graph_.wait_for_all();
        }
        catch (...) {
            graph_.reset();  // a block threw: the graph is cancelled; ready it for the next solve
            throw;
        }
    }

private:
    using Node = tbb::flow::continue_node<tbb::flow::continue_msg>;
    tbb::flow::graph graph_;
    tbb::flow::broadcast_node<tbb::flow::continue_msg> start_;
    std::vector<std::unique_ptr<Node>> nodes_;
    const std::function<void(int)>* body_ = nullptr;
};

// The partition for one set of counted rows, with what its blocks need.
// Hints the cache to fetch what solving `tree` in `w` touches: the workspace's arrays, the tree's limits and
// its outputs' prepared targets.
void prefetchTree(const BlockPlan& tree, const BlockWorkspace& w, std::span<const PreparedTarget> prepared)
{
    w.prefetch();
    prefetch(tree.lower);
    prefetch(tree.upper);
    prefetch(tree.period);
    prefetch(tree.defaults);
    for (const int o : tree.structure.outputs())
        prefetchBytes(&prepared[static_cast<std::size_t>(o)], sizeof(PreparedTarget));
}

struct Plan {
    // `twists`: the analytic Jacobian (the coupled systems' normal equations from twists where in twist form).
    Plan(const Approximation& approximation, const Equivalences& equivalences, Partition p, std::vector<int> counted,
         bool coupledBlocks, bool twists)
        : partition(std::move(p)), whole(approximation, {}, std::move(counted))
    {
        for (const PartitionBlock& block : partition.blocks)
            blocks.push_back(std::make_unique<BlockPlan>(approximation, equivalences, block));
        if (!coupledBlocks) return;
        // One coupled system per independent tree: trees share nothing (a crowd's members), and one
        // system over all of them would only multiply the Jacobian's zeros.
        std::vector<int> treeOf(partition.blocks.size(), -1);
        for (std::size_t t = 0; t < partition.roots.size(); ++t)
            treeOf[static_cast<std::size_t>(partition.roots[t])] = static_cast<int>(t);
        for (std::size_t b = 0; b < partition.blocks.size(); ++b)  // parents come first
            if (treeOf[b] < 0) treeOf[b] = treeOf[static_cast<std::size_t>(partition.blocks[b].parent)];
        for (std::size_t t = 0; t < partition.roots.size(); ++t) {
            Partition tree;
            std::vector<int> index(partition.blocks.size(), -1);
            PartitionBlock all;
            for (std::size_t b = 0; b < partition.blocks.size(); ++b) {
                if (treeOf[b] != static_cast<int>(t)) continue;
                PartitionBlock block = partition.blocks[b];
                index[b] = static_cast<int>(tree.blocks.size());
                block.parent = block.parent < 0 ? -1 : index[static_cast<std::size_t>(block.parent)];
                block.children.clear();
                if (block.parent >= 0) tree.blocks[static_cast<std::size_t>(block.parent)].children.push_back(index[b]);
                all.parameters.insert(all.parameters.end(), block.parameters.begin(), block.parameters.end());
                all.outputs.insert(all.outputs.end(), block.outputs.begin(), block.outputs.end());
                tree.blocks.push_back(std::move(block));
            }
            if (tree.blocks.size() < 2) {
                trees.push_back(nullptr);  // one block: its own plan
                continue;
            }
            tree.roots = {0};
            std::sort(all.parameters.begin(), all.parameters.end());
            std::sort(all.outputs.begin(), all.outputs.end());
            auto plan = std::make_unique<BlockPlan>(approximation, equivalences, all);
            plan->elimination = std::make_unique<BlockElimination>(tree, plan->structure, twists);
            trees.push_back(std::move(plan));
        }
        if (trees.size() == 1) {
            const BlockPlan* tree =
                trees[0] ? trees[0].get() : blocks[static_cast<std::size_t>(partition.roots[0])].get();
            if (tree->structure.outputs() == whole.outputs()) system = tree;
        } else if (trees.size() > 1) {
            std::size_t outputs = 0;
            treesCover = true;
            for (std::size_t t = 0; t < trees.size(); ++t) {
                const ResidualStructure& s = tree(t).structure;
                outputs += s.outputs().size();
                treesCover = treesCover && s.twistForm();
            }
            treesCover = treesCover && outputs == whole.outputs().size();
        }
        // The whole's workspace made now: solves that take both costs from the system (or the trees) never make
        // it, and a later one that needs it (values off the limits) must allocate nothing.
        if (system || treesCover) wholePool.release(std::make_unique<WholeWorkspace>(whole));
    }
    // Tree t's plan: its system, or its one block's.
    const BlockPlan& tree(std::size_t t) const
    {
        return trees[t] ? *trees[t] : *blocks[static_cast<std::size_t>(partition.roots[t])];
    }
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
    // The steps of initialGuess, made when first needed: parents first, each counted output with the
    // solved parameters that reach it and no output before it.
    const std::vector<std::unique_ptr<GuessStep>>& guessSteps(const Approximation& approximation,
                                                              const Equivalences& equivalences) const
    {
        std::call_once(guessOnce, [&] {
            std::vector<char> solved(approximation.parameters.size(), 0), assigned(solved.size(), 0);
            for (const PartitionBlock& block : partition.blocks)
                for (const int p : block.parameters) solved[static_cast<std::size_t>(p)] = 1;
            std::vector<char> counted(approximation.outputs.size(), 0);
            for (const int k : whole.outputs()) counted[static_cast<std::size_t>(k)] = 1;
            const std::vector<std::vector<int>> reach = approximation.reach();
            for (const int k : approximation.outputOrder()) {
                if (!counted[static_cast<std::size_t>(k)]) continue;
                PartitionBlock step;
                step.outputs = {k};
                for (std::size_t p = 0; p < reach.size(); ++p)
                    if (solved[p] && !assigned[p] && std::binary_search(reach[p].begin(), reach[p].end(), k)) {
                        step.parameters.push_back(static_cast<int>(p));
                        assigned[p] = 1;
                    }
                if (!step.parameters.empty())
                    guess.push_back(std::make_unique<GuessStep>(approximation, equivalences, step));
            }
        });
        return guess;
    }
    Partition partition;
    std::vector<std::unique_ptr<BlockPlan>> blocks;
    mutable std::once_flag guessOnce;
    mutable std::vector<std::unique_ptr<GuessStep>> guess;
    ResidualStructure whole;  // every counted output, no unknowns: costs and errors
    mutable Pool<WholeWorkspace> wholePool;
    mutable Pool<BlockGraph> graphs;
};

struct BlockResult {
    int gaussNewton = 0;
    int levenbergMarquardt = 0;
    bool converged = false;
    double cost = 0.0;            // 1/2 |r|^2 over the block's rows at the values returned
    double initialCost = 0.0;     // the same at the values given, clamped to the limits
    bool evaluatedAtEnd = false;  // the workspace's last evaluation (worlds, w.r) is at the values returned
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
    std::vector<BlockResult> results;
    std::vector<TreeErrors> treeErrors;  // per tree, when the trees give the whole's errors
    std::vector<char> missed;            // per output: further than targetTolerance (Solver::solve's errors)
    std::vector<double> trial, best;     // initialGuess: the start being solved, the best answer so far
    std::vector<Varied> varied;
};

constexpr std::size_t maxCachedPlans = 256;
// Levenberg-Marquardt's first damping, relative to the largest diagonal entry of J^T J (Nielsen's tau).
constexpr double initialDamping = 1e-4;
// Directions whose curvature is below this fraction of the largest are left alone: the minimum-norm step.
constexpr double rankTolerance = 1e-12;

double clampTo(double v, double lo, double hi) { return std::min(std::max(v, lo), hi); }

}  // namespace

std::string_view terminationName(TerminationType termination)
{
    switch (termination) {
        case TerminationType::converged:
            return "converged";
        case TerminationType::stuck:
            return "stuck";
        case TerminationType::noConvergence:
            return "noConvergence";
        case TerminationType::invalidTargets:
            return "invalidTargets";
        case TerminationType::noTargets:
            return "noTargets";
    }
    return "?";
}

void SolverOptions::validate() const
{
    auto fail = [](std::string_view field, auto value, std::string_view rule) {
        throw Error(fmt::format("SolverOptions::{} = {}: {}", field, value, rule));
    };
    auto nonNegative = [&](std::string_view field, double value) {
        if (!(value >= 0) || !std::isfinite(value)) fail(field, value, "must be a finite number, 0 or more");
    };
    auto positive = [&](std::string_view field, double value) {
        if (!(value > 0) || !std::isfinite(value)) fail(field, value, "must be a positive number");
    };
    if (gaussNewtonIterations < 0) fail("gaussNewtonIterations", gaussNewtonIterations, "must not be negative");
    if (maxIterations < 1) fail("maxIterations", maxIterations, "must be at least 1");
    positive("rotationScaleCm", rotationScaleCm);
    nonNegative("functionTolerance", functionTolerance);
    nonNegative("parameterTolerance", parameterTolerance);
    nonNegative("gradientTolerance", gradientTolerance);
    nonNegative("targetTolerance", targetTolerance);
    if (jacobian != JacobianMethod::analytic && jacobian != JacobianMethod::finiteDifference)
        fail("jacobian", static_cast<int>(jacobian), "must be analytic or finiteDifference");
    positive("finiteDifferenceStep", finiteDifferenceStep);
    positive("maxAngularStep", maxAngularStep);
    if (threads < 0) fail("threads", threads, "must not be negative (0: all cores)");
}

std::string SolveSummary::briefReport() const
{
    std::string report = fmt::format("{}: {} iterations ({} Gauss-Newton, {} Levenberg-Marquardt), {} block{}",
                                     terminationName(termination), iterations, gaussNewtonIterations,
                                     levenbergMarquardtIterations, blocks, blocks == 1 ? "" : "s");
    if (termination == TerminationType::invalidTargets) return report;
    report += fmt::format(", cost {:.6g} -> {:.6g}, worst {:.3g} cm, {:.3g} deg", initialCost, finalCost,
                          maxPositionErrorCm, maxRotationErrorDeg);
    if (!worstOutput.empty()) report += fmt::format(" (worst output {})", worstOutput);
    return report;
}

struct Solver::Impl {
    Impl(const Approximation& a, SolverOptions o) : approximation(a), options(o) {}

    const Approximation& approximation;
    SolverOptions options;
    std::optional<Equivalences> equivalences;  // made once the approximation is checked (Solver's constructor)
    std::optional<tbb::task_arena> arena;
    Pool<SolveScratch> scratchPool;
    std::mutex plansMutex;
    std::map<std::string, std::shared_ptr<const Plan>, std::less<>> plans;

    std::shared_ptr<const Plan> plan(const std::vector<unsigned char>& rows, std::string& key)
    {
        key.resize(rows.size());  // not assign(first, last): libstdc++ would build a temporary string
        std::copy(rows.begin(), rows.end(), key.begin());
        {
            std::lock_guard lock(plansMutex);
            const auto found = plans.find(key);
            if (found != plans.end()) return found->second;
        }
        std::vector<int> counted;
        for (std::size_t k = 0; k < rows.size(); ++k)
            if (rows[k] != noRows) counted.push_back(static_cast<int>(k));
        auto made = std::make_shared<const Plan>(
            approximation, *equivalences, partitionProblem(approximation, rows, options.partition), std::move(counted),
            options.coupledBlocks, options.jacobian == JacobianMethod::analytic);
        std::lock_guard lock(plansMutex);
        if (plans.size() >= maxCachedPlans) return made;
        return plans.emplace(key, std::move(made)).first->second;  // another thread's, if it was first
    }

    // `reference` (one value per parameter; empty: `values` as given) is what periodic controls and Euler
    // triples are kept nearest to.
    BlockResult solveBlock(const BlockPlan& block, std::span<const PreparedTarget> targets, std::span<double> values,
                           bool parallel, std::span<const double> reference = {}) const;
    // The same in a workspace of block.pool that the caller borrowed, and can read after.
    BlockResult solveBlock(const BlockPlan& block, BlockWorkspace& w, std::span<const PreparedTarget> targets,
                           std::span<double> values, bool parallel, std::span<const double> reference = {}) const;
    // Prepares the targets and finds their plan; false (with the termination) when there is nothing to solve.
    bool prepare(std::span<const JointTarget> targets, std::span<const double> values, SolveScratch& scratch,
                 std::shared_ptr<const Plan>& plan, TerminationType& termination);
    bool solveStep(BlockWorkspace& w, double mu) const;
    // The loop's parts. holdAtLimits: the projected gradient's norm; below gradientTolerance nothing else is
    // done, else the columns at a limit whose descent points out are held (w.fixed, w.gFree, J^T J) and
    // `largestDiagonal` is the free columns' largest entry of J^T J's diagonal.
    double holdAtLimits(const BlockPlan& block, BlockWorkspace& w, double& largestDiagonal) const;
    // The damped step from w.x, within the angular trust region and the limits, into w.trial and w.step;
    // false when the system has no solution. `smallStep`: under parameterTolerance.
    bool trialStep(const BlockPlan& block, BlockWorkspace& w, double damping, bool& smallStep, bool& wholeStep) const;
    // Periodic controls and Euler triples of w.x moved to the equivalent values nearest `near` (one value
    // per parameter) where the block's `cost` says they are the same pose. `evaluatedAtX`: whether the
    // workspace's last evaluation is at w.x; returns whether it still is.
    bool keepNear(const BlockPlan& block, BlockWorkspace& w, std::span<const double> near, double cost,
                  bool evaluatedAtX) const;
    // For a block of rotations only: the position part of its cost at `values` when no parameter of the
    // block moves any of its outputs' positions (all pivots at the outputs), else -1.
    double unmovedPositionCost(const BlockPlan& block, std::span<const PreparedTarget> targets,
                               std::span<const double> values) const;
};

Solver::Solver(const Approximation& approximation, SolverOptions options)
    : impl_(std::make_unique<Impl>(approximation, options))
{
    options.validate();
    for (const auto& m : approximation.parameters) {
        const RigParameter& p = m.parameter;
        if (std::isnan(p.min) || std::isnan(p.max) || p.min > p.max)
            throw internalError(fmt::format("Solver: parameter {} has limits [{}, {}]", p.name, p.min, p.max));
        if (m.outputs.size() != m.operatorOfOutput.size())
            throw internalError(fmt::format("Solver: parameter {} has {} outputs but {} operator indices", p.name,
                                            m.outputs.size(), m.operatorOfOutput.size()));
    }
    approximation.outputOrder();  // throws for parents out of range or in a cycle
    impl_->equivalences.emplace(approximation);
    // Above the core count TBB refuses the extra workers (with a warning); the values do not depend on it.
    if (options.threads > 1) impl_->arena.emplace(std::min(options.threads, tbb::info::default_concurrency()));
}

Solver::~Solver() = default;
Solver::Solver(Solver&&) noexcept = default;
Solver& Solver::operator=(Solver&&) noexcept = default;

const SolverOptions& Solver::options() const { return impl_->options; }
const Approximation& Solver::approximation() const { return impl_->approximation; }
const Equivalences& Solver::equivalences() const { return *impl_->equivalences; }

namespace {

// A non-compositional output's target is not counted: the approximation does not predict it.
unsigned char countedRows(const ApproximationOutput& output, const JointTarget& t)
{
    if (!t.active || !output.modelled) return noRows;
    unsigned char rows = noRows;
    if (t.positionWeight > 0) rows |= positionRows;
    if (t.rotationWeight > 0) rows |= rotationRows;
    return rows;
}

}  // namespace

Partition Solver::partition(std::span<const JointTarget> targets) const
{
    if (targets.size() != impl_->approximation.outputs.size())
        throw internalError(fmt::format("Solver::partition: {} targets for {} outputs", targets.size(),
                                        impl_->approximation.outputs.size()));
    std::vector<unsigned char> rows(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k) rows[k] = countedRows(impl_->approximation.outputs[k], targets[k]);
    std::string key;
    return impl_->plan(rows, key)->partition;
}

// Gauss-Newton (mu = 0) or Levenberg-Marquardt step from w.H (lower triangle, J^T J with held
// parameters' rows and columns replaced by the identity) and w.gFree. Cholesky when the system is well
// conditioned; otherwise an eigendecomposition that leaves the (near-)null directions alone, which is
// the minimum-norm step: redundant parameters split a change evenly, a parameter with no effect stays.
bool Solver::Impl::solveStep(BlockWorkspace& w, double mu) const
{
    const Eigen::Index n = w.H.rows();
    double maxDiagonal = 0.0;
    for (Eigen::Index i = 0; i < n; ++i)
        if (!w.fixed[static_cast<std::size_t>(i)]) maxDiagonal = std::max(maxDiagonal, w.H(i, i));
    if (!(maxDiagonal > 0)) {
        w.delta.setZero();
        return true;
    }
    w.damped.triangularView<Eigen::Lower>() = w.H;
    w.damped.diagonal().array() += mu;
    w.llt.compute(w.damped);
    bool wellConditioned = w.llt.info() == Eigen::Success;
    if (wellConditioned) {
        const auto& l = w.llt.matrixLLT();
        for (Eigen::Index i = 0; i < n; ++i)
            if (!(l(i, i) * l(i, i) > rankTolerance * maxDiagonal)) wellConditioned = false;
    }
    if (wellConditioned) {
        w.delta = -w.gFree;
        w.llt.solveInPlace(w.delta);
    } else {
        w.eigen.compute(w.damped);
        if (w.eigen.info() != Eigen::Success) return false;
        const auto& lambda = w.eigen.eigenvalues();
        const double largest = lambda.cwiseAbs().maxCoeff();
        w.projected.noalias() = w.eigen.eigenvectors().transpose() * w.gFree;
        for (Eigen::Index i = 0; i < n; ++i)
            w.projected[i] = lambda[i] > rankTolerance * largest ? w.projected[i] / lambda[i] : 0.0;
        w.delta.noalias() = -(w.eigen.eigenvectors() * w.projected);
    }
    return w.delta.allFinite();
}

namespace {

// The step strategy of a block's loop, as Ceres splits a minimizer from its strategies: Gauss-Newton while
// it descends (and for at most gaussNewtonIterations), then Levenberg-Marquardt with Nielsen's damping.
class StepControl {
public:
    explicit StepControl(const SolverOptions& options)
        : options_(options), gaussNewton_(options.gaussNewtonIterations > 0)
    {
    }
    bool gaussNewton() const { return gaussNewton_; }
    // The damping of the next step; `largestDiagonal` (of the free columns' J^T J) scales the first one.
    double damping(double largestDiagonal)
    {
        if (gaussNewton_) return 0.0;
        if (mu_ == 0.0) mu_ = largestDiagonal > 0 ? initialDamping * largestDiagonal : initialDamping;
        return mu_;
    }
    // Whether the trial point is taken; adapts the damping. `predicted` (the model's decrease) is asked for
    // only in Levenberg-Marquardt.
    bool accept(double cost, double trialCost, bool smallStep, const std::function<double()>& predicted)
    {
        const bool finite = std::isfinite(trialCost);
        if (gaussNewton_) {
            const bool taken = finite && (trialCost < cost || (smallStep && trialCost <= cost));
            if (!taken && !smallStep) gaussNewton_ = false;  // Gauss-Newton failed to descend: damp from now on
            return taken;
        }
        const double model = predicted();
        const double actual = cost - trialCost;
        if (finite && actual > 0 && model > 0) {
            const double rho = actual / model;
            mu_ *= std::max(1.0 / 3.0, 1.0 - std::pow(2.0 * rho - 1.0, 3));
            nu_ = 2.0;
            return true;
        }
        if (!smallStep) {
            mu_ *= nu_;
            nu_ *= 2.0;
        }
        return false;
    }
    // Damping that overflowed: no step can be found any more.
    bool exhausted() const { return !std::isfinite(mu_); }
    // After an accepted step: Gauss-Newton's iterations are counted against its budget.
    void accepted(int gaussNewtonSteps)
    {
        if (gaussNewton_ && gaussNewtonSteps >= options_.gaussNewtonIterations) gaussNewton_ = false;
    }

private:
    const SolverOptions& options_;
    bool gaussNewton_;
    double mu_ = 0.0, nu_ = 2.0;
};

}  // namespace

double Solver::Impl::holdAtLimits(const BlockPlan& block, BlockWorkspace& w, double& largestDiagonal) const
{
    const std::size_t n = block.structure.columns().size();
    double projectedGradient = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        const double gc = w.g[static_cast<Eigen::Index>(c)];
        projectedGradient =
            std::max(projectedGradient, std::abs(w.x[c] - clampTo(w.x[c] - gc, block.lower[c], block.upper[c])));
        // At a limit with the descent direction pointing out: held for this step.
        w.fixed[c] = (w.x[c] <= block.lower[c] && gc > 0) || (w.x[c] >= block.upper[c] && gc < 0);
    }
    if (projectedGradient <= options.gradientTolerance) return projectedGradient;
    w.gFree = w.g;
    for (std::size_t c = 0; c < n; ++c)
        if (w.fixed[c]) w.gFree[static_cast<Eigen::Index>(c)] = 0.0;
    // Held columns: identity rows and columns (the same set after a rejected step, at the same x and g).
    largestDiagonal = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        const Eigen::Index i = static_cast<Eigen::Index>(c);
        if (!w.fixed[c]) {
            largestDiagonal = std::max(largestDiagonal, w.diagonal(i));
            continue;
        }
        w.hold(i);
    }
    return projectedGradient;
}

bool Solver::Impl::trialStep(const BlockPlan& block, BlockWorkspace& w, double damping, bool& smallStep,
                             bool& wholeStep) const
{
    const std::size_t n = block.structure.columns().size();
    if (!(w.elimination ? w.elimination->solve(w.gFree, damping, w.delta) : solveStep(w, damping))) return false;
    // The rotation trust region (SolverOptions::maxAngularStep): shorten the whole step, keeping its direction.
    double largestTurn = 0.0;
    for (std::size_t c = 0; c < n; ++c)
        if (block.angular[c]) largestTurn = std::max(largestTurn, std::abs(w.delta[static_cast<Eigen::Index>(c)]));
    wholeStep = largestTurn <= options.maxAngularStep;
    if (!wholeStep) w.delta *= options.maxAngularStep / largestTurn;
    // Projection onto the limits; the step actually taken is what the model and tolerances see.
    double stepNorm2 = 0.0, xNorm2 = 0.0;
    for (std::size_t c = 0; c < n; ++c) {
        w.trial[c] = clampTo(w.x[c] + w.delta[static_cast<Eigen::Index>(c)], block.lower[c], block.upper[c]);
        w.step[static_cast<Eigen::Index>(c)] = w.trial[c] - w.x[c];
        wholeStep = wholeStep && w.trial[c] == w.x[c] + w.delta[static_cast<Eigen::Index>(c)];
        stepNorm2 += w.step[static_cast<Eigen::Index>(c)] * w.step[static_cast<Eigen::Index>(c)];
        xNorm2 += w.x[c] * w.x[c];
    }
    smallStep = std::sqrt(stepNorm2) <= options.parameterTolerance * (std::sqrt(xNorm2) + options.parameterTolerance);
    return true;
}

bool Solver::Impl::keepNear(const BlockPlan& block, BlockWorkspace& w, std::span<const double> near, double cost,
                            bool evaluatedAtX) const
{
    const auto& columns = block.structure.columns();
    const std::size_t n = columns.size();
    // Of the equivalent values of a periodic control, the one nearest the warm start, so that a solve never
    // adds whole turns (curves stay continuous from frame to frame).
    const auto at = [&](std::size_t c) { return near[static_cast<std::size_t>(columns[c])]; };
    const auto wrap = [&](std::size_t c, double x) {
        const double start = at(c);
        if (!(block.period[c] > 0.0) || !std::isfinite(start)) return x;
        // Within half a period of the start (where the remainder is x - start itself) a value is kept as it
        // is: only whole periods are taken off.
        const double d = x - start;
        return std::abs(d) <= 0.5 * block.period[c] ? x : start + std::remainder(d, block.period[c]);
    };
    for (std::size_t c = 0; c < n; ++c) {
        const double wrapped = wrap(c, w.x[c]);
        evaluatedAtX = evaluatedAtX && wrapped == w.x[c];
        w.x[c] = wrapped;
    }
    // And of the two Euler solutions of one pose, the nearer (no flip near gimbal lock, nor through a
    // half turn of all three channels): taken when the block's cost says it is the same pose.
    for (const auto& triple : block.triples) {
        const auto [a, b, c] = triple;
        const auto half = [&](int i) { return 0.5 * block.period[static_cast<std::size_t>(i)]; };
        std::copy(w.x.begin(), w.x.end(), w.trial.begin());
        const std::size_t ia = static_cast<std::size_t>(a), ib = static_cast<std::size_t>(b),
                          ic = static_cast<std::size_t>(c);
        w.trial[ia] = wrap(ia, w.x[ia] + half(a));
        w.trial[ib] = wrap(ib, 2.0 * block.defaults[ib] + half(b) - w.x[ib]);
        w.trial[ic] = wrap(ic, w.x[ic] + half(c));
        double now = 0.0, other = 0.0;
        for (const std::size_t i : {ia, ib, ic}) {
            now += (w.x[i] - at(i)) * (w.x[i] - at(i));
            other += (w.trial[i] - at(i)) * (w.trial[i] - at(i));
        }
        if (!(other < now)) continue;
        w.residual.residuals(w.trial, w.rTrial);
        evaluatedAtX = std::abs(0.5 * w.rTrial.squaredNorm() - cost) <= 1e-9 * cost + 1e-12;
        if (evaluatedAtX) {
            std::swap(w.x, w.trial);
            w.r.swap(w.rTrial);
        }
    }
    return evaluatedAtX;
}

BlockResult Solver::Impl::solveBlock(const BlockPlan& block, std::span<const PreparedTarget> targets,
                                     std::span<double> values, bool parallel, std::span<const double> reference) const
{
    Borrowed<BlockWorkspace> borrowed(
        block.pool, [&] { return std::make_unique<BlockWorkspace>(block.structure, block.elimination.get()); });
    return solveBlock(block, *borrowed, targets, values, parallel, reference);
}

BlockResult Solver::Impl::solveBlock(const BlockPlan& block, BlockWorkspace& w, std::span<const PreparedTarget> targets,
                                     std::span<double> values, bool parallel, std::span<const double> reference) const
{
    const ResidualStructure& structure = block.structure;
    const auto& columns = structure.columns();
    const std::size_t n = columns.size();
    const SolverOptions& o = options;

    // Ancestors are final and siblings never reach these outputs: the held values are settled.
    w.residual.holdParameters(values);
    w.residual.setTargets(targets);
    for (std::size_t c = 0; c < n; ++c)
        w.x[c] = clampTo(values[static_cast<std::size_t>(columns[c])], block.lower[c], block.upper[c]);

    BlockResult result;
    // The normal equations at w.x (a rejected step reuses them). At an accepted trial point the residuals
    // and products are those of its evaluation (w.r).
    const bool reuse = o.jacobian == JacobianMethod::analytic && structure.twistForm();
    auto linearize = [&](bool atTrial) {
        if (atTrial && reuse) w.residual.normalEquationsAtLast(w.r, w.g, w.entries());
        else w.residual.normalEquations(w.x, o.jacobian, o.finiteDifferenceStep, parallel, w.r, w.g, w.entries(), w.J);
        // A non-finite J^T J with finite residuals and gradient shows in the step, which is checked.
        return w.r.allFinite() && w.g.allFinite();
    };
    bool finite = linearize(false);
    double cost = 0.5 * w.r.squaredNorm();
    // A cost that overflows (targets 1e160 cm away: finite residuals, an infinite square) compares no step with
    // another: left to run, the damping grows until the steps are negligible and the stop reads as a stationary
    // point (stuck, a best fit). It is a solve that cannot proceed (noConvergence), as non-finite residuals are.
    finite = finite && std::isfinite(cost);
    result.initialCost = cost;
    bool evaluatedAtX = true;
    StepControl control(o);
    while (finite && result.gaussNewton + result.levenbergMarquardt < o.maxIterations) {
        double largestDiagonal = 0.0;
        if (holdAtLimits(block, w, largestDiagonal) <= o.gradientTolerance) {
            result.converged = true;
            break;
        }
        const bool gaussNewton = control.gaussNewton();
        bool smallStep = false, wholeStep = false;
        if (!trialStep(block, w, control.damping(largestDiagonal), smallStep, wholeStep)) break;
        // The model's decrease, -(g.s + s^T J^T J s / 2); held columns do not move (s = 0 there).
        const auto predicted = [&] {
            if (w.elimination) w.elimination->multiply(w.step, w.hStep);
            else w.hStep.noalias() = w.H.selfadjointView<Eigen::Lower>() * w.step;
            return -(w.g.dot(w.step) + 0.5 * w.step.dot(w.hStep));
        };
        (gaussNewton ? result.gaussNewton : result.levenbergMarquardt) += 1;
        // The undamped step whole, the model's minimum: J^T J s = -g makes its decrease -g.s / 2 (half the squared
        // Newton decrement). When that is within the function tolerance, so is any step's, and evaluating it
        // is not worth a residual pass.
        if (gaussNewton && wholeStep && !smallStep) {
            const double model = -0.5 * w.g.dot(w.step);
            if (model >= 0.0 && model <= o.functionTolerance * cost) {
                result.converged = true;
                break;
            }
        }
        w.residual.residuals(w.trial, w.rTrial);
        evaluatedAtX = false;
        const double trialCost = 0.5 * w.rTrial.squaredNorm();
        if (control.accept(cost, trialCost, smallStep, predicted)) {
            const double decrease = cost - trialCost;
            std::swap(w.x, w.trial);
            w.r.swap(w.rTrial);
            evaluatedAtX = true;
            cost = trialCost;
            if (smallStep || decrease <= o.functionTolerance * (cost + decrease)) {
                result.converged = true;
                break;
            }
            finite = linearize(true);
            control.accepted(result.gaussNewton);
        } else if (smallStep) {
            result.converged = true;  // a negligible step that does not help: nothing left to gain
            break;
        } else if (control.exhausted()) {
            break;
        }
    }
    result.evaluatedAtEnd =
        keepNear(block, w, reference.empty() ? std::span<const double>(values) : reference, cost, evaluatedAtX);
    for (std::size_t c = 0; c < n; ++c) values[static_cast<std::size_t>(columns[c])] = w.x[c];
    result.cost = cost;
    return result;
}

bool Solver::Impl::prepare(std::span<const JointTarget> targets, std::span<const double> values, SolveScratch& scratch,
                           std::shared_ptr<const Plan>& plan, TerminationType& termination)
{
    if (targets.size() != approximation.outputs.size())
        throw internalError(
            fmt::format("Solver::solve: {} targets for {} outputs", targets.size(), approximation.outputs.size()));
    if (values.size() != approximation.parameters.size())
        throw internalError(
            fmt::format("Solver::solve: {} values for {} parameters", values.size(), approximation.parameters.size()));
    scratch.prepared.resize(targets.size());
    scratch.rows.resize(targets.size());
    scratch.missed.resize(targets.size(), 0);
    for (std::size_t k = 0; k < targets.size(); ++k) {
        scratch.rows[k] = countedRows(approximation.outputs[k], targets[k]);
        if (targets[k].active && !prepareTarget(targets[k], options.rotationScaleCm, scratch.prepared[k])) {
            termination = TerminationType::invalidTargets;
            return false;
        }
    }
    plan = this->plan(scratch.rows, scratch.key);
    for (const PartitionBlock& block : plan->partition.blocks)
        for (const int p : block.parameters)
            if (!std::isfinite(values[static_cast<std::size_t>(p)]))
                throw Error(fmt::format("Solver::solve: the value of {} is {}",
                                        approximation.parameters[static_cast<std::size_t>(p)].parameter.name,
                                        values[static_cast<std::size_t>(p)]));
    termination = TerminationType::noTargets;
    return !plan->whole.outputs().empty() && !plan->partition.blocks.empty();
}

double Solver::Impl::unmovedPositionCost(const BlockPlan& block, std::span<const PreparedTarget> targets,
                                         std::span<const double> values) const
{
    const ResidualStructure& structure = block.structure;
    Borrowed<BlockWorkspace> borrowed(
        block.pool, [&] { return std::make_unique<BlockWorkspace>(structure, block.elimination.get()); });
    BlockWorkspace& w = *borrowed;
    w.residual.holdParameters(values);
    w.residual.setTargets(targets);
    for (std::size_t c = 0; c < w.x.size(); ++c) w.x[c] = values[static_cast<std::size_t>(structure.columns()[c])];
    w.residual.jacobian(w.x, JacobianMethod::analytic, options.finiteDifferenceStep, false, w.r, w.J);
    // A rotation about pivot c moves a point p by omega x (p - c): zero for every rotation of the product
    // (at any pose) exactly when every pivot is at p. Rounding aside, which this scale bounds.
    double scale = 1.0;
    for (Eigen::Index o = 0; o < w.r.size(); o += rowsPerTarget)
        scale = std::max(scale, w.J.middleRows<3>(o + 3).cwiseAbs().maxCoeff());
    double position = 0.0;
    for (Eigen::Index o = 0; o < w.r.size(); o += rowsPerTarget) {
        if (w.J.middleRows<3>(o).cwiseAbs().maxCoeff() > 1e-9 * scale) return -1.0;
        position += 0.5 * w.r.segment<3>(o).squaredNorm();
    }
    return position;
}

TerminationType Solver::initialGuess(std::span<const JointTarget> targets, std::span<double> values) const
{
    Impl& impl = *impl_;
    Borrowed<SolveScratch> scratch(impl.scratchPool, [] { return std::make_unique<SolveScratch>(); });
    std::shared_ptr<const Plan> plan;
    TerminationType termination;
    if (!impl.prepare(targets, values, *scratch, plan, termination)) return termination;

    // Each angular unknown starts at its value and a third of a turn either way: of three starts a third
    // of a turn apart, one lies within a sixth of a turn of any answer, where the cost (1 - cos) is convex
    // enough for Gauss-Newton. A limited one starts at the middles of the thirds of its range instead.
    constexpr std::size_t maxVaried = 4;  // 3^4 starts at most per output
    std::vector<double>& trial = scratch->trial;
    std::vector<double>& best = scratch->best;
    std::vector<Varied>& varied = scratch->varied;
    // Outside the step's columns, trial is values throughout: a start resets only the step's columns (a
    // crowd's guess stays linear in its size).
    trial.assign(values.begin(), values.end());
    best.resize(values.size());
    // An output is reached when its cost is this far within targetTolerance: no start can do better.
    const double reachedCost = 0.5 * std::pow(1e-3 * impl.options.targetTolerance, 2);
    for (const auto& step : plan->guessSteps(impl.approximation, *impl.equivalences)) {
        const BlockPlan& block = step->plan;
        const std::vector<int>& columns = step->block.parameters;
        // Rotations that cannot move the output's position (every pivot at the joint, as a joint's own
        // rotate channels): its position cost is the same from every start, and a start that reaches the
        // target's rotation is as good as any.
        const double floorCost =
            block.rotationsOnly ? impl.unmovedPositionCost(block, scratch->prepared, values) : -1.0;
        varied.clear();
        for (std::size_t c = 0; c < columns.size() && varied.size() < maxVaried; ++c) {
            const std::size_t i = static_cast<std::size_t>(columns[c]);
            const RigParameter& p = impl.approximation.parameters[i].parameter;
            if (!p.angular) continue;
            const double v = values[i];
            if (p.limited) {
                const double third = (p.max - p.min) / 3.0;
                varied.push_back({i, {clampTo(v, p.min, p.max), p.min + 0.5 * third, p.max - 0.5 * third}});
            } else {
                const double turn = block.period[c] > 0 ? block.period[c] : 2.0 * std::numbers::pi;
                varied.push_back({i, {v, v + turn / 3.0, v - turn / 3.0}});
            }
        }
        int starts = 1;
        for (std::size_t i = 0; i < varied.size(); ++i) starts *= 3;
        // Of the starts' answers, the cheapest; of those as cheap to rounding (another pose the joint's
        // controls reach equally well), the nearest the values given.
        double bestCost = std::numeric_limits<double>::infinity(), bestDistance = 0.0;
        for (int start = 0; start < starts; ++start) {
            for (const int p : columns) trial[static_cast<std::size_t>(p)] = values[static_cast<std::size_t>(p)];
            int code = start;
            for (const Varied& v : varied) {
                trial[v.parameter] = v.starts[static_cast<std::size_t>(code % 3)];
                code /= 3;
            }
            const BlockResult r = impl.solveBlock(block, scratch->prepared, trial, false, values);
            double distance = 0.0;
            for (const int p : columns) {
                const std::size_t i = static_cast<std::size_t>(p);
                distance += (trial[i] - values[i]) * (trial[i] - values[i]);
            }
            const double slack = 1e-9 * std::min(r.cost, bestCost) + 1e-12;
            const bool cheaper = r.cost < bestCost - slack;
            const bool asCheapAndNearer = r.cost <= bestCost + slack && distance < bestDistance;
            if (cheaper || asCheapAndNearer) {
                bestCost = std::min(r.cost, bestCost);
                bestDistance = distance;
                for (const int p : columns) best[static_cast<std::size_t>(p)] = trial[static_cast<std::size_t>(p)];
            }
            // The earliest start that reaches it: the nearest the values given. The floor is reached within
            // what the solve converges to: its stop tests leave up to functionTolerance of the cost.
            if (bestCost <= reachedCost ||
                (floorCost >= 0.0 && bestCost <= floorCost * (1.0 + impl.options.functionTolerance) + reachedCost))
                break;
        }
        // No start gave a finite cost: these parameters are left alone. Else the best, which solveBlock kept
        // nearest the values given (whole turns, Euler triples).
        const bool found = std::isfinite(bestCost);
        for (const int p : columns) {
            const std::size_t i = static_cast<std::size_t>(p);
            if (found) values[i] = best[i];
            trial[i] = values[i];
        }
    }
    return TerminationType::converged;
}

SolveSummary Solver::solve(std::span<const JointTarget> targets, std::span<double> values) const
{
    SolveSummary summary;
    solve(targets, values, summary);
    return summary;
}

void Solver::solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary) const
{
    Impl& impl = *impl_;
    const Approximation& approximation = impl.approximation;
    Borrowed<SolveScratch> scratch(impl.scratchPool, [] { return std::make_unique<SolveScratch>(); });
    // Every field anew; the name's and the list's storage kept.
    std::string worstOutput = std::move(summary.worstOutput);
    std::vector<int> missedOutputs = std::move(summary.missedOutputs);
    summary = SolveSummary{};
    worstOutput.clear();
    missedOutputs.clear();
    summary.worstOutput = std::move(worstOutput);
    summary.missedOutputs = std::move(missedOutputs);
    std::shared_ptr<const Plan> plan;
    impl.prepare(targets, values, *scratch, plan, summary.termination);
    if (summary.termination == TerminationType::invalidTargets) return;
    const Partition& partition = plan->partition;

    // The final cost and errors of an evaluation's rows (`outputs`, increasing) into `part`, the misses marked
    // in scratch->missed; then the parts' sum into the summary, as one evaluation of every counted output gives
    // it (misses in increasing order, the worst the first of the largest).
    const auto errorsOf = [&](const std::vector<int>& outputs, const ResidualWorkspace& residual,
                              const Eigen::VectorXd& r, TreeErrors& part) {
        part.cost = 0.5 * r.squaredNorm();
        for (std::size_t o = 0; o < outputs.size(); ++o) {
            const std::size_t k = static_cast<std::size_t>(outputs[o]);
            const TargetError e = residual.error(static_cast<int>(o));
            const double position = targets[k].positionWeight > 0 ? e.positionCm : 0.0;
            const double rotation = targets[k].rotationWeight > 0 ? e.rotationRad : 0.0;
            part.maxPositionCm = std::max(part.maxPositionCm, position);
            part.maxRotationDeg = std::max(part.maxRotationDeg, rotation * 180.0 / std::numbers::pi);
            const double combined = std::max(position, impl.options.rotationScaleCm * rotation);
            scratch->missed[k] = !(combined <= impl.options.targetTolerance);
            if (combined > part.worst) {
                part.worst = combined;
                part.worstOutput = static_cast<int>(k);
            }
        }
        part.valid = true;
    };
    const auto reportErrors = [&](std::span<const TreeErrors> parts) {
        summary.finalCost = 0.0;
        double worst = -1.0;
        int worstOutput = -1;
        for (const TreeErrors& part : parts) {
            summary.finalCost += part.cost;
            summary.maxPositionErrorCm = std::max(summary.maxPositionErrorCm, part.maxPositionCm);
            summary.maxRotationErrorDeg = std::max(summary.maxRotationErrorDeg, part.maxRotationDeg);
            if (part.worst > worst || (part.worst == worst && part.worstOutput < worstOutput)) {
                worst = part.worst;
                worstOutput = part.worstOutput;
            }
        }
        for (const int k : plan->whole.outputs()) {
            char& missed = scratch->missed[static_cast<std::size_t>(k)];
            if (missed) summary.missedOutputs.push_back(k);
            missed = 0;
        }
        if (worstOutput >= 0) summary.worstOutput = approximation.outputs[static_cast<std::size_t>(worstOutput)].name;
    };
    // From one evaluation of every counted output (rows in plan->whole's order).
    const auto finalErrors = [&](const ResidualWorkspace& residual, const Eigen::VectorXd& r) {
        TreeErrors whole;
        errorsOf(plan->whole.outputs(), residual, r, whole);
        reportErrors({&whole, 1});
    };
    // Costs and errors over every counted output, the outputs no parameter reaches included.
    auto measure = [&](bool final) {
        const ResidualStructure& whole = plan->whole;
        Borrowed<WholeWorkspace> w(plan->wholePool, [&] { return std::make_unique<WholeWorkspace>(whole); });
        w->residual.holdParameters(values);
        w->residual.setTargets(scratch->prepared);
        w->residual.residuals({}, w->r);
        if (final) finalErrors(w->residual, w->r);
        else summary.initialCost = 0.5 * w->r.squaredNorm();
    };
    if (plan->whole.outputs().empty()) return;  // noTargets
    // The one system's evaluations are the whole's, bit for bit, when its residuals come straight from the
    // tree of products (analytic, twist form): its first one gives the initial cost at values within the
    // limits, and its last one the final errors when it is at the values returned.
    const BlockPlan* system = plan->system;
    if (system && (impl.options.jacobian != JacobianMethod::analytic || !system->structure.twistForm()))
        system = nullptr;
    // The same with several trees (a crowd) that have every counted output between them: their costs summed.
    const bool byTrees = plan->treesCover && impl.options.jacobian == JacobianMethod::analytic;
    bool initialFromSolve = system != nullptr || byTrees;
    const auto withinLimits = [&](const BlockPlan& block) {
        for (std::size_t c = 0; c < block.lower.size(); ++c) {
            const double v = values[static_cast<std::size_t>(block.structure.columns()[c])];
            if (!(v >= block.lower[c] && v <= block.upper[c])) return false;
        }
        return true;
    };
    if (system) initialFromSolve = withinLimits(*system);
    for (std::size_t t = 0; byTrees && initialFromSolve && t < plan->trees.size(); ++t)
        initialFromSolve = withinLimits(plan->tree(t));
    if (!initialFromSolve) measure(false);
    summary.blocks = static_cast<int>(partition.blocks.size());
    if (partition.blocks.empty()) {
        measure(true);
        return;  // noTargets: nothing reaches the targets
    }

    auto& results = scratch->results;
    std::optional<Borrowed<BlockWorkspace>> systemWorkspace;  // the one system's, read for the final errors
    const bool parallel = impl.options.threads != 1;
    const bool coupled = !plan->trees.empty();
    results.assign(coupled ? plan->trees.size() : partition.blocks.size(), BlockResult{});
    const auto solveOne = [&](int b) {
        results[static_cast<std::size_t>(b)] =
            impl.solveBlock(*plan->blocks[static_cast<std::size_t>(b)], scratch->prepared, values, parallel);
    };
    if (coupled) {
        // Independent trees touch disjoint parameters and outputs: in parallel they give the serial values.
        if (byTrees) scratch->treeErrors.assign(plan->trees.size(), TreeErrors{});
        const auto borrow = [&](std::optional<Borrowed<BlockWorkspace>>& slot, std::size_t t) -> BlockWorkspace& {
            const BlockPlan& tree = plan->tree(t);
            return *slot.emplace(
                tree.pool, [&] { return std::make_unique<BlockWorkspace>(tree.structure, tree.elimination.get()); });
        };
        const auto solveIn = [&](std::size_t t, BlockWorkspace& w) {
            const BlockPlan& tree = plan->tree(t);
            results[t] = impl.solveBlock(tree, w, scratch->prepared, values, parallel);
            if (byTrees && results[t].evaluatedAtEnd)
                errorsOf(tree.structure.outputs(), w.residual, w.r, scratch->treeErrors[t]);
        };
        const std::size_t trees = plan->trees.size();
        if (system) {
            systemWorkspace.emplace(system->pool, [&] {
                return std::make_unique<BlockWorkspace>(system->structure, system->elimination.get());
            });
            results[0] = impl.solveBlock(*system, **systemWorkspace, scratch->prepared, values, parallel);
        } else if (!parallel || trees == 1) {
            // One tree after another, the next one's workspace and data fetched into the cache while this one
            // is solved: a crowd's trees do not fit in the cache together, and each is otherwise missed anew
            // at every frame (docs/performance.md, crowds).
            std::optional<Borrowed<BlockWorkspace>> workspaces[2];
            borrow(workspaces[0], 0);
            for (std::size_t t = 0; t < trees; ++t) {
                if (t + 1 < trees)
                    prefetchTree(plan->tree(t + 1), borrow(workspaces[(t + 1) % 2], t + 1), scratch->prepared);
                solveIn(t, **workspaces[t % 2]);
                workspaces[t % 2].reset();
            }
        } else {
            auto runAll = [&] {
                tbb::parallel_for(std::size_t{0}, trees, [&](std::size_t t) {
                    std::optional<Borrowed<BlockWorkspace>> w;
                    solveIn(t, borrow(w, t));
                });
            };
            if (impl.arena) impl.arena->execute(runAll);
            else runAll();
        }
    } else if (!parallel || partition.blocks.size() == 1) {
        // Serially, in dependency order: the blocks are listed parents first.
        for (std::size_t b = 0; b < partition.blocks.size(); ++b) solveOne(static_cast<int>(b));
    } else {
        // Siblings touch disjoint parameters and outputs: in parallel they give the values of the serial order.
        auto runAll = [&] {
            Borrowed<BlockGraph> graph(plan->graphs, [&] { return std::make_unique<BlockGraph>(partition); });
            graph->run(std::function<void(int)>(solveOne));
        };
        if (impl.arena) impl.arena->execute(runAll);  // the graph is made in, and runs on, the solver's arena
        else runAll();
    }

    bool converged = true;
    for (const BlockResult& r : results) {
        summary.gaussNewtonIterations += r.gaussNewton;
        summary.levenbergMarquardtIterations += r.levenbergMarquardt;
        converged = converged && r.converged;
    }
    summary.iterations = summary.gaussNewtonIterations + summary.levenbergMarquardtIterations;
    if (initialFromSolve && system) summary.initialCost = results[0].initialCost;
    else if (initialFromSolve) {
        summary.initialCost = 0.0;
        for (const BlockResult& r : results) summary.initialCost += r.initialCost;
    }
    if (systemWorkspace && results[0].evaluatedAtEnd) finalErrors((*systemWorkspace)->residual, (*systemWorkspace)->r);
    else if (byTrees && std::all_of(scratch->treeErrors.begin(), scratch->treeErrors.end(),
                                    [](const TreeErrors& e) { return e.valid; }))
        reportErrors(scratch->treeErrors);
    else measure(true);  // marks every counted output's miss anew
    if (!converged) summary.termination = TerminationType::noConvergence;
    else summary.termination = summary.missedOutputs.empty() ? TerminationType::converged : TerminationType::stuck;
}

}  // namespace rig

#include "inversion/solve/solve_plan.h"

#include <algorithm>

#include "core/prefetch.h"

namespace rig {

BlockWorkspace::BlockWorkspace(const ResidualStructure& structure, const BlockElimination* coupled)
    : residual(structure),
      state(structure.rows(), structure.columnCount()),
      J(structure.rows(), structure.columnCount()),
      // Dense J^T J and its factorizations only where the step is not by elimination.
      dense(coupled ? 0 : structure.columnCount())
{
    if (coupled) {
        elimination = std::make_unique<BlockEliminationWorkspace>(*coupled, &residual);
        residual.useLayout(coupled->layout());
    }
}

void BlockWorkspace::configure(const SolverOptions& options, bool parallel)
{
    options_ = &options;
    parallel_ = parallel;
    reuse_ = options.jacobian == JacobianMethod::analytic && residual.structure().twistNormals();
}

// At an accepted trial point the residuals and products are those of its evaluation (r).
bool BlockWorkspace::linearize(std::span<const double> x, bool atTrial, Eigen::VectorXd& r, Eigen::VectorXd& g)
{
    if (atTrial && reuse_) residual.normalEquationsAtLast(r, g, entries());
    else residual.normalEquations(x, options_->jacobian, options_->finiteDifferenceStep, parallel_, r, g, entries(), J);
    // A non-finite J^T J with finite residuals and gradient shows in the step, which is checked.
    return r.allFinite() && g.allFinite();
}

double BlockWorkspace::diagonal(Eigen::Index i) const
{
    return elimination ? elimination->diagonal(static_cast<int>(i)) : dense.diagonal(i);
}

void BlockWorkspace::hold(Eigen::Index i)
{
    if (elimination) return elimination->hold(static_cast<int>(i));
    dense.hold(i);
}

bool BlockWorkspace::solveStep(const Eigen::VectorXd& gradient, double damping, std::span<const char> fixed,
                               Eigen::VectorXd& delta)
{
    return elimination ? elimination->solve(gradient, damping, delta) : dense.solve(gradient, damping, fixed, delta);
}

void BlockWorkspace::multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out)
{
    if (elimination) elimination->multiply(v, out);
    else dense.multiply(v, out);
}

void BlockWorkspace::prefetch() const
{
    residual.prefetch();
    if (elimination) elimination->prefetch();
    state.prefetch();
}

BlockPlan::BlockPlan(const Approximation& approximation, const Equivalences& equivalences, const PartitionBlock& block,
                     std::span<const ResidualTerm* const> terms)
    : structure(approximation, block.parameters, block.outputs, terms),
      unknowns(approximation, &equivalences, block.parameters)
{
    for (const int p : block.parameters)
        for (const Operator& op : approximation.parameters[static_cast<std::size_t>(p)].operators)
            rotationsOnly = rotationsOnly && op.traits().angular;
}

BlockGraph::BlockGraph(const Partition& partition) : start_(graph_)
{
    for (std::size_t b = 0; b < partition.blocks.size(); ++b)
        nodes_.push_back(std::make_unique<Node>(
            graph_, [this, b](const tbb::flow::continue_msg&) { (*body_)(static_cast<int>(b)); }));
    for (const int root : partition.roots) tbb::flow::make_edge(start_, *nodes_[static_cast<std::size_t>(root)]);
    for (std::size_t b = 0; b < partition.blocks.size(); ++b)
        for (const int child : partition.blocks[b].children)
            tbb::flow::make_edge(*nodes_[b], *nodes_[static_cast<std::size_t>(child)]);
}

void BlockGraph::run(const std::function<void(int)>& body)
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

void prefetchTree(const BlockPlan& tree, const BlockWorkspace& w, std::span<const PreparedTarget> prepared)
{
    w.prefetch();
    prefetch(tree.unknowns.lower);
    prefetch(tree.unknowns.upper);
    prefetch(tree.unknowns.period);
    prefetch(tree.unknowns.defaults);
    for (const int o : tree.structure.outputs())
        prefetchBytes(&prepared[static_cast<std::size_t>(o)], sizeof(PreparedTarget));
}

Plan::Plan(const Approximation& approximation, const Equivalences& equivalences, Partition p, std::vector<int> counted,
           std::vector<const ResidualTerm*> terms, bool coupledBlocks, bool twists)
    : partition(std::move(p)), terms(std::move(terms)), whole(approximation, {}, std::move(counted), this->terms)
{
    for (const PartitionBlock& block : partition.blocks) {
        blocks.push_back(std::make_unique<BlockPlan>(approximation, equivalences, block, this->terms));
        if (twists && static_cast<int>(block.parameters.size()) > BlockElimination::recursiveAbove)
            eliminateNodeByNode(*blocks.back());
    }
    if (!coupledBlocks) return;
    planTrees(approximation, equivalences, twists);
    if (trees.size() == 1) {
        const BlockPlan* tree = trees[0] ? trees[0].get() : blocks[static_cast<std::size_t>(partition.roots[0])].get();
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

// A long block alone (a chain) is eliminated node by node where its structure allows it, rather than factored
// densely (inversion/solve/block_elimination.h).
void Plan::eliminateNodeByNode(BlockPlan& plan)
{
    Partition single;
    single.blocks.push_back({plan.structure.columns(), plan.structure.outputs(), -1, {}});
    single.roots.push_back(0);
    auto elimination = std::make_unique<BlockElimination>(single, plan.structure, true);
    if (elimination->nodeByNode()) plan.elimination = std::move(elimination);
}

// One coupled system per independent tree: trees share nothing (a crowd's members), and one system over all of
// them would only multiply the Jacobian's zeros.
void Plan::planTrees(const Approximation& approximation, const Equivalences& equivalences, bool twists)
{
    std::vector<int> treeOf(partition.blocks.size(), -1);
    for (std::size_t t = 0; t < partition.roots.size(); ++t)
        treeOf[static_cast<std::size_t>(partition.roots[t])] = static_cast<int>(t);
    for (std::size_t b = 0; b < partition.blocks.size(); ++b)  // parents come first
        if (treeOf[b] < 0) treeOf[b] = treeOf[static_cast<std::size_t>(partition.blocks[b].parent)];
    for (std::size_t t = 0; t < partition.roots.size(); ++t) {
        Partition tree;
        PartitionBlock all;
        treeBlocks(treeOf, static_cast<int>(t), tree, all);
        if (tree.blocks.size() < 2) {
            trees.push_back(nullptr);  // one block: its own plan
            continue;
        }
        auto plan = std::make_unique<BlockPlan>(approximation, equivalences, all, terms);
        plan->elimination = std::make_unique<BlockElimination>(tree, plan->structure, twists);
        trees.push_back(std::move(plan));
    }
}

void Plan::treeBlocks(const std::vector<int>& treeOf, int t, Partition& tree, PartitionBlock& all) const
{
    std::vector<int> index(partition.blocks.size(), -1);
    for (std::size_t b = 0; b < partition.blocks.size(); ++b) {
        if (treeOf[b] != t) continue;
        PartitionBlock block = partition.blocks[b];
        index[b] = static_cast<int>(tree.blocks.size());
        block.parent = block.parent < 0 ? -1 : index[static_cast<std::size_t>(block.parent)];
        block.children.clear();
        if (block.parent >= 0) tree.blocks[static_cast<std::size_t>(block.parent)].children.push_back(index[b]);
        all.parameters.insert(all.parameters.end(), block.parameters.begin(), block.parameters.end());
        all.outputs.insert(all.outputs.end(), block.outputs.begin(), block.outputs.end());
        tree.blocks.push_back(std::move(block));
    }
    tree.roots = {0};
    std::sort(all.parameters.begin(), all.parameters.end());
    std::sort(all.outputs.begin(), all.outputs.end());
}

const std::vector<std::unique_ptr<GuessStep>>& Plan::guessSteps(const Approximation& approximation,
                                                                const Equivalences& equivalences) const
{
    std::call_once(guessOnce, [&] {
        std::vector<char> solved(approximation.parameters.size(), 0), assigned(solved.size(), 0);
        for (const PartitionBlock& block : partition.blocks)
            for (const int p : block.parameters) solved[static_cast<std::size_t>(p)] = 1;
        std::vector<char> counted(approximation.outputs.size(), 0);
        for (const int k : whole.outputs()) counted[static_cast<std::size_t>(k)] = 1;
        const std::vector<std::vector<int>> reach = approximation.reach();
        const auto reaches = [&](int p, int k) {
            return std::binary_search(reach[static_cast<std::size_t>(p)].begin(),
                                      reach[static_cast<std::size_t>(p)].end(), k);
        };
        std::vector<PartitionBlock> steps;
        std::vector<char> underdetermined;
        for (const int k : approximation.outputOrder()) {
            if (!counted[static_cast<std::size_t>(k)]) continue;
            PartitionBlock step;
            step.outputs = {k};
            for (std::size_t p = 0; p < reach.size(); ++p)
                if (solved[p] && !assigned[p] && reaches(static_cast<int>(p), k)) {
                    step.parameters.push_back(static_cast<int>(p));
                    assigned[p] = 1;
                }
            if (!step.parameters.empty()) {
                const int rows = ResidualStructure(approximation, step.parameters, step.outputs, terms).rows();
                underdetermined.push_back(rows < static_cast<int>(step.parameters.size()));
                steps.push_back(std::move(step));
                continue;
            }
            // An output whose parameters were all fixed before it: when the latest step that moves it left some
            // of them free on its own output (a reverse foot's roll beside its translate and rotate, on the ankle
            // alone), that step solves this output too, else the free ones stay where they started.
            for (std::size_t s = steps.size(); s-- > 0;) {
                const std::vector<int>& ps = steps[s].parameters;
                if (std::none_of(ps.begin(), ps.end(), [&](int p) { return reaches(p, k); })) continue;
                if (underdetermined[s])
                    steps[s].outputs.insert(std::upper_bound(steps[s].outputs.begin(), steps[s].outputs.end(), k), k);
                break;
            }
        }
        for (const PartitionBlock& step : steps)
            guess.push_back(std::make_unique<GuessStep>(approximation, equivalences, step, terms));
    });
    return guess;
}

}  // namespace rig

#include "inversion/solve/solve_plan.h"

#include <algorithm>
#include <array>
#include <span>

#include <Eigen/QR>

#include "core/prefetch.h"

namespace rig {

BlockWorkspace::BlockWorkspace(const ResidualStructure& structure, const BlockElimination* coupled)
    : residual(structure),
      state(structure.rows(), structure.columnCount()),
      J(structure.rows(), structure.columnCount()),
      // Dense J^T J and its factorizations only where the step is not by elimination.
      dense(coupled ? 0 : structure.columnCount(), structure.rows())
{
    residual.formsInPlace(J);
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
    dense.restart();
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
    return elimination ? elimination->solve(gradient, damping, delta, fixed)
                       : dense.solve(gradient, damping, fixed, delta);
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

namespace {

// The steps of Plan::guessSteps as they are drafted, output by output (parents first).
class GuessDraft {
public:
    GuessDraft(const Approximation& approximation, std::span<const ResidualTerm* const> terms, std::vector<char> solved)
        : approximation_(approximation),
          terms_(terms),
          solved_(std::move(solved)),
          stepOf_(solved_.size(), -1),
          reach_(approximation.reach()),
          visited_(approximation.outputs.size(), 0)
    {
    }
    void add(int k);
    std::vector<PartitionBlock> steps;
    std::vector<std::vector<int>> own;  // per step: the parameters first fixed there

private:
    bool reaches(int p, int k) const
    {
        const std::vector<int>& r = reach_[static_cast<std::size_t>(p)];
        return std::binary_search(r.begin(), r.end(), k);
    }
    // Whether parameter p moves an input of output k's constraint other than its anchor (a chain's goal or pole, a
    // twist's driver, a blend's branches, an orient output): information on p that k's target holds and no output
    // it is relative to does.
    bool movesInput(int p, int k) const;
    // Whether output k's rows fix some combination of parameters that the steps `joined` leave free on their outputs:
    // those steps and k, with its own parameters `fresh`, leave fewer combinations free at rest together than apart.
    bool informs(int k, std::span<const int> joined, const std::vector<int>& fresh);
    Eigen::MatrixXd restJacobian(const PartitionBlock& step);  // the step's residuals' Jacobian at rest
    void push(PartitionBlock step, std::vector<int> first);
    void resolve(std::size_t from, const std::vector<int>& moving, std::vector<int> fresh);

    const Approximation& approximation_;
    std::span<const ResidualTerm* const> terms_;
    std::vector<char> solved_;
    std::vector<int> stepOf_;  // per parameter: the latest step solving it, -1 before any
    std::vector<std::vector<int>> reach_;
    // Per step: some of its parameters left free on its outputs (fewer rows than parameters, or a parameter moving
    // none of them at rest: a foot control's roll beside its translate and rotate, on the ankle alone).
    std::vector<char> underdetermined_;
    std::vector<Eigen::Index> free_;    // per step: the combinations of its parameters that move none of its outputs
    std::vector<char> visited_;         // per output: drafted already
    std::vector<PreparedTarget> rest_;  // every output's rest world as a target, made when first needed
    std::vector<double> defaults_;
};

bool GuessDraft::movesInput(int p, int k) const
{
    const int c = approximation_.outputs[static_cast<std::size_t>(k)].constraint;
    if (c < 0) return false;
    const ConstraintBase& base = approximation_.constraints[static_cast<std::size_t>(c)];
    const std::array<int, 5> inputs = base.frameInputs();
    return std::any_of(inputs.begin(), inputs.end(),
                       [&](int input) { return input >= 0 && input != base.anchor && reaches(p, input); });
}

Eigen::MatrixXd GuessDraft::restJacobian(const PartitionBlock& step)
{
    const ResidualStructure structure(approximation_, step.parameters, step.outputs, terms_);
    if (rest_.empty()) {
        rest_.resize(approximation_.outputs.size());
        for (std::size_t k = 0; k < rest_.size(); ++k)
            prepareTarget({true, approximation_.outputs[k].rest}, 1.0, rest_[k]);
        defaults_ = approximation_.defaults();
    }
    ResidualWorkspace w(structure);
    w.holdParameters(defaults_);
    w.setTargets(rest_);
    std::vector<double> x;
    for (const int p : step.parameters) x.push_back(defaults_[static_cast<std::size_t>(p)]);
    Eigen::VectorXd r(structure.rows());
    Eigen::MatrixXd j(structure.rows(), structure.columnCount());
    w.jacobian(x, JacobianMethod::analytic, 0.0, false, r, j);
    return j;
}

// Fewer rows than columns, or a column that moves nothing (zero to the last bits, rounding aside).
bool hasFreeColumn(const Eigen::MatrixXd& j)
{
    if (j.rows() < j.cols()) return true;
    if (!j.allFinite()) return false;
    const double zero = 1e-12 * std::max(1.0, j.cwiseAbs().maxCoeff());
    for (Eigen::Index c = 0; c < j.cols(); ++c)
        if (j.col(c).cwiseAbs().maxCoeff() <= zero) return true;
    return false;
}

// The combinations of the columns that move nothing: a pivot zero to the last bits, rounding aside.
Eigen::Index nullity(const Eigen::MatrixXd& j)
{
    if (!j.allFinite()) return 0;
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(j);
    qr.setThreshold(1e-9);
    return j.cols() - qr.rank();
}

bool GuessDraft::informs(int k, std::span<const int> joined, const std::vector<int>& fresh)
{
    // A chain's later joints fix nothing its first one's step does not place already (the guess places the chain from
    // its end's and middle's targets): an IK arm's forearm tells the arm's step no more.
    const auto goalOf = [&](int o) {
        const int c = approximation_.outputs[static_cast<std::size_t>(o)].constraint;
        return c < 0 ? -1 : approximation_.constraints[static_cast<std::size_t>(c)].goal;
    };
    const int goal = goalOf(k);
    PartitionBlock with;
    with.outputs = {k};
    with.parameters = fresh;
    Eigen::Index apart = fresh.empty() ? 0 : nullity(restJacobian(with));
    for (const int s : joined) {
        const PartitionBlock& step = steps[static_cast<std::size_t>(s)];
        if (goal >= 0 &&
            std::any_of(step.outputs.begin(), step.outputs.end(), [&](int o) { return goalOf(o) == goal; }))
            return false;
        with.outputs.insert(with.outputs.end(), step.outputs.begin(), step.outputs.end());
        with.parameters.insert(with.parameters.end(), step.parameters.begin(), step.parameters.end());
        apart += free_[static_cast<std::size_t>(s)];
    }
    for (std::vector<int>* v : {&with.outputs, &with.parameters}) {
        std::sort(v->begin(), v->end());
        v->erase(std::unique(v->begin(), v->end()), v->end());
    }
    // A rig's own redundancy (a spider's world control against its body control, each leg's control under the first)
    // stays free however the steps join: only fewer free combinations together than apart tell the steps something.
    return nullity(restJacobian(with)) < apart;
}

void GuessDraft::push(PartitionBlock step, std::vector<int> first)
{
    const Eigen::MatrixXd j = restJacobian(step);
    underdetermined_.push_back(hasFreeColumn(j) ? 1 : 0);
    free_.push_back(nullity(j));
    for (const int p : step.parameters) stepOf_[static_cast<std::size_t>(p)] = static_cast<int>(steps.size());
    steps.push_back(std::move(step));
    own.push_back(std::move(first));
}

void GuessDraft::add(int k)
{
    PartitionBlock step;
    step.outputs = {k};
    // The steps that move k, and those among them whose parameters move an input of its constraint (movesInput).
    std::vector<int> moving, inputs;
    for (std::size_t p = 0; p < reach_.size(); ++p) {
        if (!solved_[p] || !reaches(static_cast<int>(p), k)) continue;
        if (stepOf_[p] < 0) step.parameters.push_back(static_cast<int>(p));
        else moving.push_back(stepOf_[p]);
        if (stepOf_[p] >= 0 && movesInput(static_cast<int>(p), k)) inputs.push_back(stepOf_[p]);
    }
    visited_[static_cast<std::size_t>(k)] = 1;
    // When a step that moves k left some combination of its parameters free, one of them moves an input of k's
    // constraint and k's target fixes some of that combination (a ball aimed by an ikSCsolver at a goal under the foot
    // control, which the leg's step placed but did not turn), the steps from that one on that move k are solved again
    // together with k's own parameters, if any (the latest alone, without them, solves k too). Else k's own parameters
    // are a step of their own; else, when the latest step left some parameter free on its own outputs (a reverse
    // foot's roll beside its translate and rotate, on the ankle alone), that step solves k too; else the free ones stay
    // where they started.
    std::sort(moving.begin(), moving.end());
    moving.erase(std::unique(moving.begin(), moving.end()), moving.end());
    std::sort(inputs.begin(), inputs.end());
    const auto fromStep = [&](int s) {
        return static_cast<std::size_t>(std::lower_bound(moving.begin(), moving.end(), s) - moving.begin());
    };
    // The fewest steps that k informs: from the latest input's step back (a forearm twist driven by the hand joins
    // the arm's step, which left the reach free, not every step from the root's on).
    const auto informing = std::find_if(inputs.rbegin(), inputs.rend(), [&](int s) {
        return informs(k, std::span<const int>(moving).subspan(fromStep(s)), step.parameters);
    });
    const bool own = !step.parameters.empty();
    if (informing != inputs.rend() && (own || *informing != moving.back())) {
        resolve(fromStep(*informing), moving, std::move(step.parameters));
        return;
    }
    if (own) {
        std::vector<int> first = step.parameters;
        push(std::move(step), std::move(first));
        return;
    }
    if (moving.empty()) return;
    std::vector<int>& outputs = steps[static_cast<std::size_t>(moving.back())].outputs;
    if (informing != inputs.rend() || underdetermined_[static_cast<std::size_t>(moving.back())])
        outputs.insert(std::upper_bound(outputs.begin(), outputs.end(), k), k);
}

// A step after the steps moving[from..] (those that move an output none of its own parameters reach), with `fresh`,
// parameters no step fixed before: all solved together, on every output drafted so far that they move, the output
// among them. Their free parameters are this step's now.
void GuessDraft::resolve(std::size_t from, const std::vector<int>& moving, std::vector<int> fresh)
{
    PartitionBlock step;
    step.parameters = fresh;
    for (std::size_t m = from; m < moving.size(); ++m) {
        const std::size_t s = static_cast<std::size_t>(moving[m]);
        step.parameters.insert(step.parameters.end(), steps[s].parameters.begin(), steps[s].parameters.end());
        underdetermined_[s] = 0;
    }
    std::sort(step.parameters.begin(), step.parameters.end());
    step.parameters.erase(std::unique(step.parameters.begin(), step.parameters.end()), step.parameters.end());
    for (const int p : step.parameters)
        for (const int o : reach_[static_cast<std::size_t>(p)])
            if (visited_[static_cast<std::size_t>(o)]) step.outputs.push_back(o);
    std::sort(step.outputs.begin(), step.outputs.end());
    step.outputs.erase(std::unique(step.outputs.begin(), step.outputs.end()), step.outputs.end());
    push(std::move(step), std::move(fresh));
}

}  // namespace

const std::vector<std::unique_ptr<GuessStep>>& Plan::guessSteps(const Approximation& approximation,
                                                                const Equivalences& equivalences) const
{
    std::call_once(guessOnce, [&] {
        std::vector<char> solved(approximation.parameters.size(), 0);
        for (const PartitionBlock& block : partition.blocks)
            for (const int p : block.parameters) solved[static_cast<std::size_t>(p)] = 1;
        std::vector<char> counted(approximation.outputs.size(), 0);
        for (const int k : whole.outputs()) counted[static_cast<std::size_t>(k)] = 1;
        GuessDraft draft(approximation, terms, std::move(solved));
        for (const int k : approximation.outputOrder())
            if (counted[static_cast<std::size_t>(k)]) draft.add(k);
        for (std::size_t s = 0; s < draft.steps.size(); ++s)
            guess.push_back(std::make_unique<GuessStep>(approximation, equivalences, draft.steps[s],
                                                        std::move(draft.own[s]), terms));
    });
    return guess;
}

}  // namespace rig

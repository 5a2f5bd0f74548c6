#include "inversion/solve/solver.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <optional>
#include <string>

#include <fmt/format.h>
#include <oneapi/tbb/info.h>
#include <oneapi/tbb/parallel_for.h>

#include "core/error.h"
#include "inversion/solve/solver_impl.h"

namespace rig {
namespace {

constexpr std::size_t maxCachedPlans = 256;
// A switch's weight this close to its branch after a solve that started there is on it: the solve moved it by rounding.
constexpr double branchRounding = 1e-9;
// solveOrGiveUp's window: ten iterations that lowered a cost above the tolerance by less than a tenth. On the random
// characters' IK clips, the warm solves that ended stuck had ground 50 to 100 iterations against a kink or along a
// valley before the chain started afresh (docs/solver.md, Clip inversion).
constexpr int giveUpWindow = 10;

// A non-compositional output's target is not counted: the approximation does not predict it. The rows a
// target's term counts, and its kind (termRowsKey): plans differ by both.
unsigned char countedRows(const ApproximationOutput& output, const JointTarget& t)
{
    if (!t.active || !output.modelled) return noRows;
    return termRowsKey(t);
}

}  // namespace

std::shared_ptr<const Plan> Solver::Impl::plan(const std::vector<unsigned char>& rows, std::string& key)
{
    key.resize(rows.size());  // not assign(first, last): libstdc++ would build a temporary string
    std::copy(rows.begin(), rows.end(), key.begin());
    {
        std::lock_guard lock(plansMutex);
        const auto found = plans.find(key);
        if (found != plans.end()) return found->second;
    }
    std::vector<int> counted;
    std::vector<const ResidualTerm*> terms;  // termRowsKey's kinds, when some target is not a joint target
    for (std::size_t k = 0; k < rows.size(); ++k) {
        if (rows[k] != noRows) counted.push_back(static_cast<int>(k));
        if (rows[k] >> 2 && terms.empty()) terms.assign(rows.size(), nullptr);
        if (!terms.empty()) terms[k] = rows[k] == noRows ? nullptr : &termOfKey(rows[k]);
    }
    const PartitionSplit split = !options.partition      ? PartitionSplit::none
                                 : options.coupledBlocks ? PartitionSplit::branching
                                                         : PartitionSplit::determined;
    auto made = std::make_shared<const Plan>(approximation, *equivalences, partitionProblem(approximation, rows, split),
                                             std::move(counted), std::move(terms), options.coupledBlocks,
                                             options.jacobian == JacobianMethod::analytic);
    std::lock_guard lock(plansMutex);
    if (plans.size() >= maxCachedPlans) return made;
    return plans.emplace(key, std::move(made)).first->second;  // another thread's, if it was first
}

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

std::shared_ptr<const Plan> Solver::Impl::planFor(std::span<const JointTarget> targets, const char* caller)
{
    if (targets.size() != approximation.outputs.size())
        throw internalError(
            fmt::format("Solver::{}: {} targets for {} outputs", caller, targets.size(), approximation.outputs.size()));
    std::vector<unsigned char> rows(targets.size());
    for (std::size_t k = 0; k < targets.size(); ++k) rows[k] = countedRows(approximation.outputs[k], targets[k]);
    std::string key;
    return plan(rows, key);
}

Partition Solver::partition(std::span<const JointTarget> targets) const
{
    return impl_->planFor(targets, "partition")->partition;
}

void Solver::prepare(std::span<const JointTarget> targets) const
{
    impl_->planFor(targets, "prepare")->guessSteps(impl_->approximation, *impl_->equivalences);
}

MinimizerResult Solver::Impl::solveBlock(const BlockPlan& block, std::span<const PreparedTarget> targets,
                                         std::span<double> values, bool parallel, std::span<const double> reference,
                                         GiveUp giveUp) const
{
    Borrowed<BlockWorkspace> borrowed(block.pool, [&] { return block.makeWorkspace(); });
    return solveBlock(block, *borrowed, targets, values, parallel, reference, giveUp);
}

MinimizerResult Solver::Impl::solveBlock(const BlockPlan& block, BlockWorkspace& w,
                                         std::span<const PreparedTarget> targets, std::span<double> values,
                                         bool parallel, std::span<const double> reference, GiveUp giveUp) const
{
    const auto& columns = block.structure.columns();
    const Unknowns& u = block.unknowns;
    // Ancestors are final and siblings never reach these outputs: the held values are settled.
    w.residual.holdParameters(values);
    w.residual.setTargets(targets);
    for (std::size_t c = 0; c < columns.size(); ++c)
        w.state.x[c] = clampTo(values[static_cast<std::size_t>(columns[c])], u.lower[c], u.upper[c]);
    w.configure(options, parallel);
    const MinimizerResult result =
        minimize(w, u, options, w.state, reference.empty() ? std::span<const double>(values) : reference,
                 StepPolicy::approximation(), giveUp);
    for (std::size_t c = 0; c < columns.size(); ++c) values[static_cast<std::size_t>(columns[c])] = w.state.x[c];
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

namespace {

// One call of Solver::solve once its plan is found: the blocks (or trees) solved, then the summary's costs and
// errors, from the solve's own evaluations where they cover every counted output.
class SolveRun {
public:
    SolveRun(Solver::Impl& impl, std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary,
             SolveScratch& scratch, const Plan& plan, GiveUp giveUp = {})
        : impl_(impl),
          targets_(targets),
          values_(values),
          summary_(summary),
          scratch_(scratch),
          plan_(plan),
          giveUp_(giveUp)
    {
    }
    void run();

private:
    // The final cost and errors of an evaluation's rows (`outputs`, increasing) into `part`, the misses marked
    // in scratch.missed.
    void errorsOf(const std::vector<int>& outputs, const ResidualWorkspace& residual, const Eigen::VectorXd& r,
                  TreeErrors& part);
    // The parts' sum into the summary, as one evaluation of every counted output gives it (misses in
    // increasing order, the worst the first of the largest).
    void reportErrors(std::span<const TreeErrors> parts);
    // From one evaluation of every counted output (rows in plan.whole's order).
    void finalErrors(const ResidualWorkspace& residual, const Eigen::VectorXd& r);
    // Costs and errors over every counted output, the outputs no parameter reaches included.
    void measure(bool final);
    bool withinLimits(const BlockPlan& block) const;
    // Whether the solve's first evaluations give the initial cost (`system`, `byTrees` set here first).
    bool initialFromSolve();
    void solveTrees();
    void solveBlocks();
    // Before the solve, the switches at a branch and their inactive controls noted; after, held (SwitchHold).
    void holdBranches(bool before);
    void finish(bool initialFromSolve);

    Solver::Impl& impl_;
    std::span<const JointTarget> targets_;
    std::span<double> values_;
    SolveSummary& summary_;
    SolveScratch& scratch_;
    const Plan& plan_;
    bool parallel_ = true;
    GiveUp giveUp_;                      // minimize's: a window of 0 never gives up
    const BlockPlan* system_ = nullptr;  // the one system whose evaluations are the whole's
    bool byTrees_ = false;               // several trees whose evaluations are the whole's, summed
    std::optional<Borrowed<BlockWorkspace>> systemWorkspace_;  // the one system's, read for the final errors
};

void SolveRun::errorsOf(const std::vector<int>& outputs, const ResidualWorkspace& residual, const Eigen::VectorXd& r,
                        TreeErrors& part)
{
    part.cost = 0.5 * r.squaredNorm();
    for (std::size_t o = 0; o < outputs.size(); ++o) {
        const std::size_t k = static_cast<std::size_t>(outputs[o]);
        const TargetError e = residual.error(static_cast<int>(o));
        const double position = targets_[k].positionWeight > 0 ? e.positionCm : 0.0;
        const double rotation = targets_[k].rotationWeight > 0 ? e.rotationRad : 0.0;
        part.maxPositionCm = std::max(part.maxPositionCm, position);
        part.maxRotationDeg = std::max(part.maxRotationDeg, rotation * 180.0 / std::numbers::pi);
        const double combined = std::max(position, impl_.options.rotationScaleCm * rotation);
        scratch_.missed[k] = !(combined <= impl_.options.targetTolerance);
        if (combined > part.worst) {
            part.worst = combined;
            part.worstOutput = static_cast<int>(k);
        }
    }
    part.valid = true;
}

void SolveRun::reportErrors(std::span<const TreeErrors> parts)
{
    summary_.finalCost = 0.0;
    double worst = -1.0;
    int worstOutput = -1;
    for (const TreeErrors& part : parts) {
        summary_.finalCost += part.cost;
        summary_.maxPositionErrorCm = std::max(summary_.maxPositionErrorCm, part.maxPositionCm);
        summary_.maxRotationErrorDeg = std::max(summary_.maxRotationErrorDeg, part.maxRotationDeg);
        if (part.worst > worst || (part.worst == worst && part.worstOutput < worstOutput)) {
            worst = part.worst;
            worstOutput = part.worstOutput;
        }
    }
    for (const int k : plan_.whole.outputs()) {
        char& missed = scratch_.missed[static_cast<std::size_t>(k)];
        if (missed) summary_.missedOutputs.push_back(k);
        missed = 0;
    }
    if (worstOutput >= 0)
        summary_.worstOutput = impl_.approximation.outputs[static_cast<std::size_t>(worstOutput)].name;
}

void SolveRun::finalErrors(const ResidualWorkspace& residual, const Eigen::VectorXd& r)
{
    TreeErrors whole;
    errorsOf(plan_.whole.outputs(), residual, r, whole);
    reportErrors({&whole, 1});
}

void SolveRun::measure(bool final)
{
    const ResidualStructure& whole = plan_.whole;
    Borrowed<WholeWorkspace> w(plan_.wholePool, [&] { return std::make_unique<WholeWorkspace>(whole); });
    w->residual.holdParameters(values_);
    w->residual.setTargets(scratch_.prepared);
    w->residual.residuals({}, w->r);
    if (final) finalErrors(w->residual, w->r);
    else summary_.initialCost = 0.5 * w->r.squaredNorm();
}

bool SolveRun::withinLimits(const BlockPlan& block) const
{
    const Unknowns& u = block.unknowns;
    for (std::size_t c = 0; c < u.size(); ++c) {
        const double v = values_[static_cast<std::size_t>(block.structure.columns()[c])];
        if (!(v >= u.lower[c] && v <= u.upper[c])) return false;
    }
    return true;
}

bool SolveRun::initialFromSolve()
{
    const bool analytic = impl_.options.jacobian == JacobianMethod::analytic;
    // The one system's evaluations are the whole's, bit for bit, when its residuals come straight from the
    // tree of products (analytic, twist form): its first one gives the initial cost at values within the
    // limits, and its last one the final errors when it is at the values returned.
    system_ = plan_.system;
    if (system_ && (!analytic || !system_->structure.twistForm())) system_ = nullptr;
    // The same with several trees (a crowd) that have every counted output between them: their costs summed.
    byTrees_ = plan_.treesCover && analytic;
    if (system_) return withinLimits(*system_);
    bool fromSolve = byTrees_;
    for (std::size_t t = 0; fromSolve && t < plan_.trees.size(); ++t) fromSolve = withinLimits(plan_.tree(t));
    return fromSolve;
}

void SolveRun::solveTrees()
{
    auto& results = scratch_.results;
    // Independent trees touch disjoint parameters and outputs: in parallel they give the serial values.
    if (byTrees_) scratch_.treeErrors.assign(plan_.trees.size(), TreeErrors{});
    const auto borrow = [&](std::optional<Borrowed<BlockWorkspace>>& slot, std::size_t t) -> BlockWorkspace& {
        const BlockPlan& tree = plan_.tree(t);
        return *slot.emplace(tree.pool, [&] { return tree.makeWorkspace(); });
    };
    const auto solveIn = [&](std::size_t t, BlockWorkspace& w) {
        const BlockPlan& tree = plan_.tree(t);
        results[t] = impl_.solveBlock(tree, w, scratch_.prepared, values_, parallel_, {}, giveUp_);
        if (byTrees_ && results[t].evaluatedAtEnd)
            errorsOf(tree.structure.outputs(), w.residual, w.state.r, scratch_.treeErrors[t]);
    };
    const std::size_t trees = plan_.trees.size();
    if (system_) {
        systemWorkspace_.emplace(system_->pool, [&] { return system_->makeWorkspace(); });
        results[0] = impl_.solveBlock(*system_, **systemWorkspace_, scratch_.prepared, values_, parallel_, {}, giveUp_);
    } else if (!parallel_ || trees == 1) {
        // One tree after another, the next one's workspace and data fetched into the cache while this one
        // is solved: a crowd's trees do not fit in the cache together, and each is otherwise missed anew
        // at every frame (docs/performance.md, crowds).
        std::optional<Borrowed<BlockWorkspace>> workspaces[2];
        borrow(workspaces[0], 0);
        for (std::size_t t = 0; t < trees; ++t) {
            if (t + 1 < trees)
                prefetchTree(plan_.tree(t + 1), borrow(workspaces[(t + 1) % 2], t + 1), scratch_.prepared);
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
        if (impl_.arena) impl_.arena->execute(runAll);
        else runAll();
    }
}

void SolveRun::solveBlocks()
{
    const Partition& partition = plan_.partition;
    const auto solveOne = [&](int b) {
        scratch_.results[static_cast<std::size_t>(b)] = impl_.solveBlock(
            *plan_.blocks[static_cast<std::size_t>(b)], scratch_.prepared, values_, parallel_, {}, giveUp_);
    };
    if (!parallel_ || partition.blocks.size() == 1) {
        // Serially, in dependency order: the blocks are listed parents first.
        for (std::size_t b = 0; b < partition.blocks.size(); ++b) solveOne(static_cast<int>(b));
        return;
    }
    // Siblings touch disjoint parameters and outputs: in parallel they give the values of the serial order.
    auto runAll = [&] {
        Borrowed<BlockGraph> graph(plan_.graphs, [&] { return std::make_unique<BlockGraph>(partition); });
        graph->run(std::function<void(int)>(solveOne));
    };
    // The graph is made in, and runs on, the solver's arena.
    if (impl_.arena) impl_.arena->execute(runAll);
    else runAll();
}

void SolveRun::run()
{
    if (plan_.whole.outputs().empty()) return;  // noTargets
    const bool fromSolve = initialFromSolve();
    if (!fromSolve) measure(false);
    summary_.blocks = static_cast<int>(plan_.partition.blocks.size());
    if (plan_.partition.blocks.empty()) {
        measure(true);
        return;  // noTargets: nothing reaches the targets
    }
    parallel_ = impl_.options.threads != 1;
    if (!impl_.aims.empty()) aimReaches(impl_.approximation, impl_.aims, values_, scratch_.aimReach);
    const bool coupled = !plan_.trees.empty();
    scratch_.results.assign(coupled ? plan_.trees.size() : plan_.partition.blocks.size(), MinimizerResult{});
    if (!impl_.switches.empty()) holdBranches(true);
    if (coupled) solveTrees();
    else solveBlocks();
    if (!impl_.switches.empty()) holdBranches(false);
    // The joints stay where the solve put them: the final evaluation still measures them.
    if (!impl_.poles.empty()) holdPoles(impl_.approximation, impl_.poles, values_);
    if (!impl_.aims.empty()) holdAims(impl_.approximation, impl_.aims, scratch_.aimReach, values_);
    finish(fromSolve);
}

void SolveRun::holdBranches(bool before)
{
    // A switch whose weight starts at a branch and ends within rounding of it: its weight put back on the branch and
    // the other branch's controls, which then move no joint, back at their warm start (blend_merge.h, SwitchHold).
    std::vector<double>& start = scratch_.branches;
    if (before) start.clear();
    std::size_t next = 0;
    for (const SwitchHold& hold : impl_.switches) {
        double& w = values_[static_cast<std::size_t>(hold.weight)];
        if (before) start.push_back(w);
        const double branch = start[next++];
        if (branch != 0.0 && branch != 1.0) continue;
        const std::vector<int>& held = branch == 1.0 ? hold.fk : hold.ik;
        if (before) {
            for (const int p : held) start.push_back(values_[static_cast<std::size_t>(p)]);
            continue;
        }
        const bool kept = std::abs(w - branch) <= branchRounding;
        if (kept) w = branch;
        for (const int p : held) {
            if (kept) values_[static_cast<std::size_t>(p)] = start[next];
            ++next;
        }
    }
}

void SolveRun::finish(bool initialFromSolve)
{
    const auto& results = scratch_.results;
    bool converged = true;
    for (const MinimizerResult& r : results) {
        summary_.gaussNewtonIterations += r.gaussNewton;
        summary_.levenbergMarquardtIterations += r.levenbergMarquardt;
        converged = converged && r.converged;
        summary_.longFirstStep = summary_.longFirstStep || r.longFirstStep;
        summary_.stalled = summary_.stalled || r.stalled;
    }
    summary_.iterations = summary_.gaussNewtonIterations + summary_.levenbergMarquardtIterations;
    if (initialFromSolve && system_) summary_.initialCost = results[0].initialCost;
    else if (initialFromSolve) {
        summary_.initialCost = 0.0;
        for (const MinimizerResult& r : results) summary_.initialCost += r.initialCost;
    }
    if (systemWorkspace_ && results[0].evaluatedAtEnd)
        finalErrors((*systemWorkspace_)->residual, (*systemWorkspace_)->state.r);
    else if (byTrees_ && std::all_of(scratch_.treeErrors.begin(), scratch_.treeErrors.end(),
                                     [](const TreeErrors& e) { return e.valid; }))
        reportErrors(scratch_.treeErrors);
    else measure(true);  // marks every counted output's miss anew
    if (!converged) summary_.termination = TerminationType::noConvergence;
    else summary_.termination = summary_.missedOutputs.empty() ? TerminationType::converged : TerminationType::stuck;
}

// A solve that missed an output a switch's weight moves, solved again from the warm start with each such weight at
// the branch end further from where it started, guessed anew from there (Solver::initialGuess): of two branches that
// both reach the first joint they blend (an IK and an FK thigh), the one the start favoured may not reach the rest
// (an FK leg does not stretch). The cheaper answer is kept.
void solveFromOtherBranches(const Solver& solver, Solver::Impl& impl, std::span<const JointTarget> targets,
                            std::span<double> values, SolveSummary& summary, SolveScratch& scratch, const Plan& plan)
{
    scratch.held.assign(values.begin(), values.end());
    std::copy(scratch.start.begin(), scratch.start.end(), values.begin());
    bool flipped = false;
    for (const SwitchHold& hold : impl.switches) {
        const bool missed = std::any_of(hold.outputs.begin(), hold.outputs.end(), [&](int k) {
            return std::binary_search(summary.missedOutputs.begin(), summary.missedOutputs.end(), k);
        });
        double& w = values[static_cast<std::size_t>(hold.weight)];
        if (missed) w = w < 0.5 ? 1.0 : 0.0;
        flipped = flipped || missed;
    }
    SolveSummary again;
    if (flipped) {
        solver.initialGuess(targets, values);
        SolveRun(impl, targets, values, again, scratch, plan).run();
    }
    if (flipped && again.finalCost < summary.finalCost) {
        again.initialCost = summary.initialCost;
        again.longFirstStep = summary.longFirstStep;  // of the start the solve was given
        again.gaussNewtonIterations += summary.gaussNewtonIterations;
        again.levenbergMarquardtIterations += summary.levenbergMarquardtIterations;
        again.iterations += summary.iterations;
        summary = std::move(again);
        return;
    }
    std::copy(scratch.held.begin(), scratch.held.end(), values.begin());
    summary.gaussNewtonIterations += again.gaussNewtonIterations;
    summary.levenbergMarquardtIterations += again.levenbergMarquardtIterations;
    summary.iterations += again.iterations;
}

}  // namespace

SolveSummary Solver::solve(std::span<const JointTarget> targets, std::span<double> values) const
{
    SolveSummary summary;
    solve(targets, values, summary);
    return summary;
}

void Solver::solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary) const
{
    solve(targets, values, summary, false);
}

void Solver::solveCold(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary) const
{
    solve(targets, values, summary, true);
}

void Solver::solveOrGiveUp(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary,
                           double aboveCost) const
{
    solve(targets, values, summary, false, GiveUp{giveUpWindow, aboveCost});
}

void Solver::solve(std::span<const JointTarget> targets, std::span<double> values, SolveSummary& summary, bool cold,
                   GiveUp giveUp) const
{
    Impl& impl = *impl_;
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
    const bool branches = cold && !impl.switches.empty();
    if (branches) scratch->start.assign(values.begin(), values.end());
    SolveRun(impl, targets, values, summary, *scratch, *plan, giveUp).run();
    if (summary.stalled) return;  // the caller starts afresh (solveOrGiveUp)
    if (!summary.converged() && branches)
        solveFromOtherBranches(*this, impl, targets, values, summary, *scratch, *plan);
    if (summary.converged() || impl.goals.empty()) return;
    // Targets missed with a rigid chain's goal past its reach, where no step brings it back (the chain straight where
    // its targets bend it): the goal held back inside the reach, and solved again from there once, the cheaper
    // answer kept.
    scratch->held.assign(values.begin(), values.end());
    if (!holdGoals(impl.approximation, impl.goals, targets, values)) return;
    SolveSummary again;
    SolveRun(impl, targets, values, again, *scratch, *plan).run();
    again.initialCost = summary.initialCost;
    again.longFirstStep = summary.longFirstStep;  // of the start the solve was given
    again.gaussNewtonIterations += summary.gaussNewtonIterations;
    again.levenbergMarquardtIterations += summary.levenbergMarquardtIterations;
    again.iterations += summary.iterations;
    if (again.finalCost < summary.finalCost) {
        summary = std::move(again);
        return;
    }
    std::copy(scratch->held.begin(), scratch->held.end(), values.begin());
    summary.gaussNewtonIterations = again.gaussNewtonIterations;
    summary.levenbergMarquardtIterations = again.levenbergMarquardtIterations;
    summary.iterations = again.iterations;
}

}  // namespace rig

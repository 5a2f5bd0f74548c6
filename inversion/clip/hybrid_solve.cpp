#include "inversion/clip/hybrid_solve.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "core/error.h"
#include "core/rotation_math.h"
#include "inversion/clip/continuity.h"

namespace rig {

std::vector<HybridBlock> hybridBlocks(const Approximation& approximation)
{
    const std::vector<std::vector<int>> reach = approximation.reach();
    // Union-find over the parameters with unmodelled outputs, joined through the outputs they move.
    std::vector<int> hybrid, moves;
    std::vector<std::vector<int>> moved;
    for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
        const ModelledParameter& m = approximation.parameters[p];
        if (m.unmodelledOutputs.empty()) continue;
        hybrid.push_back(static_cast<int>(p));
        std::vector<int> outputs = reach[p];
        outputs.insert(outputs.end(), m.unmodelledOutputs.begin(), m.unmodelledOutputs.end());
        std::sort(outputs.begin(), outputs.end());
        outputs.erase(std::unique(outputs.begin(), outputs.end()), outputs.end());
        moved.push_back(std::move(outputs));
    }
    std::vector<int> group(hybrid.size());
    std::iota(group.begin(), group.end(), 0);
    const auto find = [&](int g) {
        while (group[static_cast<std::size_t>(g)] != g) g = group[static_cast<std::size_t>(g)];
        return g;
    };
    std::vector<int> ownerOfOutput(approximation.outputs.size(), -1);
    for (std::size_t h = 0; h < hybrid.size(); ++h)
        for (const int k : moved[h]) {
            int& owner = ownerOfOutput[static_cast<std::size_t>(k)];
            if (owner < 0) owner = static_cast<int>(h);
            else group[static_cast<std::size_t>(find(static_cast<int>(h)))] = find(owner);
        }
    std::vector<HybridBlock> blocks;
    std::vector<int> blockOfGroup(hybrid.size(), -1);
    for (std::size_t h = 0; h < hybrid.size(); ++h) {
        int& b = blockOfGroup[static_cast<std::size_t>(find(static_cast<int>(h)))];
        if (b < 0) {
            b = static_cast<int>(blocks.size());
            blocks.emplace_back();
        }
        HybridBlock& block = blocks[static_cast<std::size_t>(b)];
        block.parameters.push_back(hybrid[h]);
        block.outputs.insert(block.outputs.end(), moved[h].begin(), moved[h].end());
    }
    for (HybridBlock& block : blocks) {
        std::sort(block.outputs.begin(), block.outputs.end());
        block.outputs.erase(std::unique(block.outputs.begin(), block.outputs.end()), block.outputs.end());
    }
    return blocks;
}

HybridSolver::HybridSolver(const Solver& solver, RigBinding& binding, int threads)
    : solver_(solver), binding_(binding), blocks_(hybridBlocks(solver.approximation()))
{
    if (&binding.approximation() != &solver.approximation())
        throw internalError("HybridSolver: the binding is not for the solver's approximation");
    for (const HybridBlock& block : blocks_)
        problems_.push_back(std::make_unique<RealRigProblem>(binding, solver.options().rotationScaleCm,
                                                             block.parameters, block.outputs, threads));
}

HybridSolver::~HybridSolver() = default;

RealRigSolve HybridSolver::solveBlock(std::size_t b, std::span<const JointTarget> targets, std::vector<double>& values)
{
    RealRigProblem& problem = *problems_[b];
    problem.setTargets(targets);
    problem.setHeld(values);
    const std::vector<int>& columns = blocks_[b].parameters;
    x_.resize(columns.size());
    for (std::size_t c = 0; c < columns.size(); ++c) x_[c] = values[static_cast<std::size_t>(columns[c])];
    const RealRigSolve s = solveOnRealRig(problem, x_, solver_.options(), &solver_.equivalences());
    for (std::size_t c = 0; c < columns.size(); ++c) values[static_cast<std::size_t>(columns[c])] = x_[c];
    return s;
}

bool HybridSolver::keepWarmStart(std::size_t b, std::span<const JointTarget> targets, std::span<const double> values,
                                 int& evaluations)
{
    RealRigProblem& problem = *problems_[b];
    problem.setTargets(targets);
    problem.setHeld(values);
    const std::vector<int>& columns = blocks_[b].parameters;
    const auto cost = [&](std::span<const double> from) {
        x_.resize(columns.size());
        for (std::size_t c = 0; c < columns.size(); ++c) x_[c] = from[static_cast<std::size_t>(columns[c])];
        return problem.residuals(x_, residual_);
    };
    const double approximationStart = cost(values);
    const double warmStart = cost(warm_);
    evaluations += 2;
    return warmStart < approximationStart;
}

RealRigSolve HybridSolver::continuation(std::size_t b, std::span<const JointTarget> targets,
                                        std::vector<double>& values, int& evaluations)
{
    const Approximation& approximation = solver_.approximation();
    for (const int p : blocks_[b].parameters)
        values[static_cast<std::size_t>(p)] =
            approximation.parameters[static_cast<std::size_t>(p)].parameter.defaultValue;
    binding_.evaluate(values, worlds_);
    ++evaluations;
    blended_.assign(targets.begin(), targets.end());
    RealRigSolve total;
    for (int step = 1; step <= continuationSteps; ++step) {
        const double t = static_cast<double>(step) / continuationSteps;
        for (const int k : blocks_[b].outputs) {
            const auto o = static_cast<std::size_t>(k);
            if (!targets[o].active) continue;
            const Eigen::Matrix4d& from = worlds_[o];
            const Eigen::Matrix4d& to = targets[o].world;
            Eigen::Matrix4d& world = blended_[o].world;
            world.setIdentity();
            world.block<3, 1>(0, 3) = (1.0 - t) * from.block<3, 1>(0, 3) + t * to.block<3, 1>(0, 3);
            const Eigen::Quaterniond a(polarRotation(from.topLeftCorner<3, 3>()));
            const Eigen::Quaterniond c(polarRotation(to.topLeftCorner<3, 3>()));
            world.topLeftCorner<3, 3>() = a.slerp(t, c).toRotationMatrix();
        }
        const RealRigSolve s = solveBlock(b, step == continuationSteps ? targets : blended_, values);
        if (step == 1) total.initialCost = s.initialCost;
        total.iterations += s.iterations;
        total.evaluations += s.evaluations;
        total.converged = s.converged;
        total.finalCost = s.finalCost;
    }
    evaluations += static_cast<int>(total.evaluations);
    return total;
}

void HybridSolver::solveFrame(std::span<const JointTarget> targets, std::vector<double>& values, double previousCost,
                              ChainScratch& scratch, ChainFrame& frame)
{
    warm_ = values;  // the previous frame's answer, in a warm-started chain
    solveChainFrame(solver_, targets, values, previousCost, scratch, frame);
    frame.realRigEvaluations = 0;
    SolveSummary& summary = frame.summary;
    if (summary.termination == TerminationType::invalidTargets) return;
    // Continuity: along a chain, near the frame before; from a restart, near the approximation's answer (the guess).
    reference_ = previousCost < retryNever ? warm_ : values;
    const SolverOptions& options = solver_.options();
    const double floor = 0.5 * options.targetTolerance * options.targetTolerance;
    bool converged = summary.termination != TerminationType::noConvergence;
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
        const auto& outputs = blocks_[b].outputs;
        if (std::none_of(outputs.begin(), outputs.end(),
                         [&](int k) { return targets[static_cast<std::size_t>(k)].active; }))
            continue;  // no target in this block
        // The approximation's answer fits the modelled outputs alone: it may move the root where the legs' goals,
        // held in world space, stretch them. The block's previous answer is kept as its start when it is cheaper.
        if (previousCost < retryNever && keepWarmStart(b, targets, values, frame.realRigEvaluations))
            for (const int p : blocks_[b].parameters)
                values[static_cast<std::size_t>(p)] = warm_[static_cast<std::size_t>(p)];
        start_ = values;
        RealRigSolve s = solveBlock(b, targets, values);
        frame.realRigEvaluations += static_cast<int>(s.evaluations);
        // From a start far from the answer (a restart: the root moved, an IK goal left at rest out of reach, where
        // moving it toward the body changes nothing), or after a jump in cost: again by continuation from the
        // rest pose, and the cheaper answer kept.
        if (!(previousCost < retryNever) || s.finalCost > 2.0 * previousCost + floor) {
            const RealRigSolve again = continuation(b, targets, start_, frame.realRigEvaluations);
            s.iterations += again.iterations;
            // Kept unless clearly costlier: where both reach the targets (a straight leg reaches its foot from an IK
            // goal anywhere past its reach), the answer tracked from the rest pose keeps the goal on the foot.
            if (again.finalCost <= s.finalCost * (1.0 + 1e-6) + floor) {
                values.swap(start_);
                s.finalCost = again.finalCost;
                s.converged = again.converged;
            }
        }
        summary.iterations += s.iterations;
        summary.gaussNewtonIterations += s.iterations;
        converged = converged && s.converged;
    }
    keepNearReference(values, frame.realRigEvaluations);
    // The result as the real rig gives it, over every active target.
    binding_.evaluate(values, worlds_);
    ++frame.realRigEvaluations;
    const Approximation& approximation = solver_.approximation();
    summary.finalCost = summary.maxPositionErrorCm = summary.maxRotationErrorDeg = 0.0;
    summary.missedOutputs.clear();
    summary.worstOutput.clear();
    double worst = -1.0;
    PreparedTarget prepared;
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active || (targets[k].positionWeight <= 0 && targets[k].rotationWeight <= 0)) continue;
        if (!prepareTarget(targets[k], options.rotationScaleCm, prepared)) continue;  // the solve said invalidTargets
        summary.finalCost += 0.5 * targetResidual(worlds_[k], prepared).squaredNorm();
        const TargetError e = targetError(worlds_[k], prepared);
        const double position = targets[k].positionWeight > 0 ? e.positionCm : 0.0;
        const double rotation = targets[k].rotationWeight > 0 ? e.rotationRad : 0.0;
        summary.maxPositionErrorCm = std::max(summary.maxPositionErrorCm, position);
        summary.maxRotationErrorDeg = std::max(summary.maxRotationErrorDeg, rotation * 180.0 / std::numbers::pi);
        const double combined = std::max(position, options.rotationScaleCm * rotation);
        if (!(combined <= options.targetTolerance)) summary.missedOutputs.push_back(static_cast<int>(k));
        if (combined > worst) {
            worst = combined;
            summary.worstOutput = approximation.outputs[k].name;
        }
    }
    if (worst < 0) summary.termination = TerminationType::noTargets;
    else if (!converged) summary.termination = TerminationType::noConvergence;
    else summary.termination = summary.missedOutputs.empty() ? TerminationType::converged : TerminationType::stuck;
}

void HybridSolver::keepNearReference(std::vector<double>& values, int& evaluations)
{
    PoseCheck samePose(solver_.approximation(), &binding_);
    const Equivalences& e = solver_.equivalences();
    applyShift(e, checkedContinuityShift(e, reference_, values, &samePose), values, values);
    evaluations += samePose.realRigEvaluations();
}

std::string HybridSolver::describe() const
{
    if (blocks_.empty()) return "every output is modelled: no block on the real rig";
    const Approximation& approximation = solver_.approximation();
    std::string text;
    for (std::size_t b = 0; b < blocks_.size(); ++b) {
        std::vector<std::string> unmodelled;
        for (const int k : blocks_[b].outputs)
            if (!approximation.outputs[static_cast<std::size_t>(k)].modelled)
                unmodelled.push_back(approximation.outputs[static_cast<std::size_t>(k)].name);
        text += fmt::format("{}block {}: {} parameters on the real rig, {} outputs, of which not modelled: {}",
                            b ? "\n" : "", b + 1, blocks_[b].parameters.size(), blocks_[b].outputs.size(),
                            fmt::join(unmodelled, ", "));
    }
    return text;
}

}  // namespace rig

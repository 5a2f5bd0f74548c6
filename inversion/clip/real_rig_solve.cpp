#include "inversion/clip/real_rig_solve.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "inversion/solve/minimizer.h"
#include "inversion/solve/step_strategy.h"

namespace rig {

// One rig evaluating residuals: the problem's own binding, or an instance of its rig with a binding of its own.
struct RealRigProblem::Evaluator {
    std::unique_ptr<RigFunction> instance;
    std::unique_ptr<RigBinding> ownBinding;
    RigBinding* binding = nullptr;
    std::vector<double> values;  // every approximation parameter
    std::vector<Eigen::Matrix4d> worlds;
    Eigen::VectorXd r;
    std::uint64_t evaluations = 0;
};

RealRigProblem::RealRigProblem(RigBinding& binding, double rotationScaleCm, std::vector<int> columns,
                               std::vector<int> outputs, int threads)
    : binding_(binding), rotationScaleCm_(rotationScaleCm), columns_(std::move(columns)), outputs_(std::move(outputs))
{
    const Approximation& approximation = binding.approximation();
    if (columns_.empty())
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) columns_.push_back(static_cast<int>(p));
    if (outputs_.empty())
        for (std::size_t k = 0; k < approximation.outputs.size(); ++k) outputs_.push_back(static_cast<int>(k));
    constexpr double free = std::numeric_limits<double>::infinity();
    for (const int c : columns_) {
        if (c < 0 || static_cast<std::size_t>(c) >= approximation.parameters.size())
            throw internalError(fmt::format("RealRigProblem: column {} is not a parameter", c));
        const RigParameter& p = approximation.parameters[static_cast<std::size_t>(c)].parameter;
        lower_.push_back(p.limited ? p.min : -free);
        upper_.push_back(p.limited ? p.max : free);
    }
    held_ = approximation.defaults();
    evaluators_.push_back(std::make_unique<Evaluator>());
    evaluators_.back()->binding = &binding_;
    for (int t = 1; t < std::max(threads, 1); ++t) {
        auto e = std::make_unique<Evaluator>();
        e->instance = binding.rig().instance();
        if (!e->instance) break;  // no instances: one evaluator
        e->ownBinding = std::make_unique<RigBinding>(approximation, *e->instance);
        e->binding = e->ownBinding.get();
        evaluators_.push_back(std::move(e));
    }
}

RealRigProblem::~RealRigProblem() = default;

void RealRigProblem::setTargets(std::span<const JointTarget> targets)
{
    const auto& outputs = binding_.approximation().outputs;
    if (targets.size() != outputs.size())
        throw internalError(fmt::format("RealRigProblem: {} targets for {} outputs", targets.size(), outputs.size()));
    active_.clear();
    terms_.clear();
    rowOffset_.assign(1, 0);
    prepared_.assign(targets.size(), PreparedTarget{});
    for (const int k : outputs_) {
        const auto o = static_cast<std::size_t>(k);
        if (!targets[o].active) continue;
        if (!prepareTarget(targets[o], rotationScaleCm_, prepared_[o]))
            throw Error(fmt::format("RealRigProblem: the target of {} is not usable", outputs[o].name));
        active_.push_back(k);
        terms_.push_back(&termOf(targets[o]));
        rowOffset_.push_back(rowOffset_.back() + terms_.back()->rows());
    }
}

void RealRigProblem::setHeld(std::span<const double> values)
{
    if (values.size() != held_.size())
        throw internalError(fmt::format("RealRigProblem: {} values for {} parameters", values.size(), held_.size()));
    held_.assign(values.begin(), values.end());
}

void RealRigProblem::evaluate(Evaluator& e, std::span<const double> x, int column, double value, Eigen::VectorXd& r)
{
    e.values = held_;
    for (std::size_t c = 0; c < columns_.size(); ++c) e.values[static_cast<std::size_t>(columns_[c])] = x[c];
    if (column >= 0) e.values[static_cast<std::size_t>(columns_[static_cast<std::size_t>(column)])] = value;
    e.binding->evaluate(e.values, e.worlds);
    ++e.evaluations;
    r.resize(rows());
    TermRows rows;
    for (std::size_t o = 0; o < active_.size(); ++o) {
        const auto k = static_cast<std::size_t>(active_[o]);
        terms_[o]->residual(e.worlds[k], prepared_[k], rows);
        r.segment(rowOffset_[o], rows.size()) = rows;
    }
}

double RealRigProblem::residuals(std::span<const double> x, Eigen::VectorXd& r)
{
    if (x.size() != columns_.size())
        throw internalError(fmt::format("RealRigProblem: {} values for {} unknowns", x.size(), columns_.size()));
    Evaluator& e = *evaluators_.front();
    evaluate(e, x, -1, 0.0, r);
    ++evaluations_;
    return 0.5 * r.squaredNorm();
}

void RealRigProblem::jacobian(std::span<const double> x, double h, bool central, Eigen::MatrixXd* jacobian,
                              Eigen::VectorXd& r, bool residualsKnown)
{
    if (!residualsKnown) residuals(x, r);
    if (jacobian) jacobian->resize(rows(), columns());
    const auto evaluators = evaluators_.size();
    // Column c on evaluator c mod T: each column depends only on x, so any T gives the same matrix.
    auto columnsOf = [&](std::size_t t) {
        Evaluator& e = *evaluators_[t];
        Eigen::VectorXd plus, minus, column;
        for (std::size_t c = t; c < columns_.size(); c += evaluators) {
            // The rig refuses a value past a control's limits: at a limit, the difference is one-sided inwards.
            const bool up = x[c] + h <= upper_[c];
            const bool down = x[c] - h >= lower_[c];
            if (central && up && down) {
                evaluate(e, x, static_cast<int>(c), x[c] + h, plus);
                evaluate(e, x, static_cast<int>(c), x[c] - h, minus);
                column = (plus - minus) / (2.0 * h);
            } else {
                const double step = up ? h : -h;
                evaluate(e, x, static_cast<int>(c), x[c] + step, plus);
                column = (plus - r) / step;
            }
            if (jacobian) jacobian->col(static_cast<Eigen::Index>(c)) = column;
        }
    };
    std::uint64_t before = 0;
    for (const auto& e : evaluators_) before += e->evaluations;
    if (evaluators == 1) columnsOf(0);
    else tbb::parallel_for(std::size_t{0}, evaluators, columnsOf);
    std::uint64_t after = 0;
    for (const auto& e : evaluators_) after += e->evaluations;
    evaluations_ += after - before;
}

namespace {

// The real rig as the minimizer's problem: forward-difference Jacobians (the cheapest black box), J^T J dense.
class RealRigMinimizerProblem final : public MinimizerProblem {
public:
    RealRigMinimizerProblem(RealRigProblem& problem, double step)
        : problem_(problem), step_(step), dense_(problem.columns())
    {
    }
    bool linearize(std::span<const double> x, bool atTrial, Eigen::VectorXd& r, Eigen::VectorXd& g) override
    {
        // An accepted trial point's residuals are the base of its forward differences: one evaluation saved.
        problem_.jacobian(x, step_, false, &J_, r, atTrial);
        dense_.matrix().triangularView<Eigen::Lower>() = J_.transpose() * J_;
        g.noalias() = J_.transpose() * r;
        return r.allFinite() && g.allFinite();
    }
    void residuals(std::span<const double> x, Eigen::VectorXd& r) override { problem_.residuals(x, r); }
    double diagonal(Eigen::Index i) const override { return dense_.diagonal(i); }
    void hold(Eigen::Index i) override { dense_.hold(i); }
    bool solveStep(const Eigen::VectorXd& gradient, double damping, std::span<const char> fixed,
                   Eigen::VectorXd& delta) override
    {
        return dense_.solve(gradient, damping, fixed, delta);
    }
    void multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) override { dense_.multiply(v, out); }

private:
    RealRigProblem& problem_;
    double step_;
    DenseSystem dense_;
    Eigen::MatrixXd J_;
};

}  // namespace

RealRigSolve solveOnRealRig(RealRigProblem& problem, std::span<double> values, const SolverOptions& options,
                            const Equivalences* equivalences)
{
    const std::uint64_t before = problem.evaluations();
    const std::size_t n = static_cast<std::size_t>(problem.columns());
    if (values.size() != n)
        throw internalError(fmt::format("solveOnRealRig: {} values for {} unknowns", values.size(), n));
    const Unknowns unknowns(problem.approximation(), equivalences, problem.columnParameters());
    // What whole turns and Euler flips are kept near: the start, every other parameter held.
    std::vector<double> reference = problem.held();
    MinimizerState state(problem.rows(), static_cast<Eigen::Index>(n));
    for (std::size_t c = 0; c < n; ++c) {
        reference[static_cast<std::size_t>(unknowns.columns[c])] = values[c];
        state.x[c] = std::clamp(values[c], unknowns.lower[c], unknowns.upper[c]);
    }
    RealRigMinimizerProblem minimizerProblem(problem, options.finiteDifferenceStep);
    SolverOptions realRig = options;
    realRig.maxAngularStep = options.realRigMaxAngularStep;
    const MinimizerResult result =
        minimize(minimizerProblem, unknowns, realRig, state, reference, StepPolicy::realRig());
    std::copy(state.x.begin(), state.x.end(), values.begin());
    RealRigSolve solve;
    solve.iterations = result.gaussNewton + result.levenbergMarquardt;
    solve.converged = result.converged;
    solve.initialCost = result.initialCost;
    solve.finalCost = result.cost;
    solve.evaluations = problem.evaluations() - before;
    return solve;
}

}  // namespace rig

#include "inversion/real_rig_solve.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"

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
                              Eigen::VectorXd& r)
{
    residuals(x, r);
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

RealRigSolve solveOnRealRig(RealRigProblem& problem, std::span<double> values, const SolverOptions& options)
{
    const std::uint64_t before = problem.evaluations();
    const int n = problem.columns();
    if (values.size() != static_cast<std::size_t>(n))
        throw internalError(fmt::format("solveOnRealRig: {} values for {} unknowns", values.size(), n));
    const auto& lower = problem.lower();
    const auto& upper = problem.upper();
    std::vector<double> x(values.begin(), values.end()), trial(x.size());
    for (int c = 0; c < n; ++c) {
        const auto i = static_cast<std::size_t>(c);
        x[i] = std::clamp(x[i], lower[i], upper[i]);
    }
    Eigen::MatrixXd J, H, damped;
    Eigen::VectorXd r, rTrial, g, delta;
    std::vector<char> fixed(x.size());
    RealRigSolve solve;
    problem.jacobian(x, options.finiteDifferenceStep, false, &J, r);
    double cost = 0.5 * r.squaredNorm();
    solve.initialCost = cost;
    while (solve.iterations < options.maxIterations) {
        g = J.transpose() * r;
        double projectedGradient = 0.0;
        for (int c = 0; c < n; ++c) {
            const auto i = static_cast<std::size_t>(c);
            projectedGradient =
                std::max(projectedGradient, std::abs(x[i] - std::clamp(x[i] - g[c], lower[i], upper[i])));
            fixed[i] = (x[i] <= lower[i] && g[c] > 0) || (x[i] >= upper[i] && g[c] < 0);
        }
        if (projectedGradient <= options.gradientTolerance) {
            solve.converged = true;
            break;
        }
        H = J.transpose() * J;
        for (int c = 0; c < n; ++c)
            if (fixed[static_cast<std::size_t>(c)]) {
                H.row(c).setZero();
                H.col(c).setZero();
                H(c, c) = 1.0;
                g[c] = 0.0;
            }
        // Cholesky when it is well conditioned, else the minimum-norm step (as the solver does).
        Eigen::LLT<Eigen::MatrixXd> llt(H);
        const double largest = H.diagonal().maxCoeff();
        bool ok = llt.info() == Eigen::Success && largest > 0;
        for (int c = 0; ok && c < n; ++c) ok = llt.matrixL()(c, c) * llt.matrixL()(c, c) > 1e-12 * largest;
        if (ok) {
            delta = llt.solve(-g);
        } else {
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(H);
            Eigen::VectorXd projected = eigen.eigenvectors().transpose() * g;
            const double top = eigen.eigenvalues().cwiseAbs().maxCoeff();
            for (int c = 0; c < n; ++c)
                projected[c] = eigen.eigenvalues()[c] > 1e-12 * top ? projected[c] / eigen.eigenvalues()[c] : 0.0;
            delta = -(eigen.eigenvectors() * projected);
        }
        ++solve.iterations;
        bool accepted = false, smallStep = false;
        double trialCost = cost;
        // Tries x + scale * delta (clamped to the limits): accepted when the real rig's cost goes down.
        const auto tryStep = [&](double scale) {
            double stepNorm2 = 0.0, xNorm2 = 0.0;
            for (int c = 0; c < n; ++c) {
                const auto i = static_cast<std::size_t>(c);
                trial[i] = std::clamp(x[i] + scale * delta[c], lower[i], upper[i]);
                stepNorm2 += (trial[i] - x[i]) * (trial[i] - x[i]);
                xNorm2 += x[i] * x[i];
            }
            smallStep =
                std::sqrt(stepNorm2) <= options.parameterTolerance * (std::sqrt(xNorm2) + options.parameterTolerance);
            trialCost = problem.residuals(trial, rTrial);
            accepted = std::isfinite(trialCost) && (trialCost < cost || (smallStep && trialCost <= cost));
            return accepted || smallStep;
        };
        // Backtracking: halve the step until the real rig's cost goes down.
        for (double scale = 1.0; scale > 1e-3; scale *= 0.5)
            if (tryStep(scale)) break;
        // Then Levenberg-Marquardt: where the Gauss-Newton direction is poor (a kink, as an IK chain's knee at
        // full extension, where the bend grows as the square root of the goal's approach), damped steps turn
        // toward the gradient, which descends for small enough steps.
        if (!accepted && !smallStep) {
            const double top = std::max(H.diagonal().maxCoeff(), std::numeric_limits<double>::min());
            for (double lambda = 1e-4 * top; !accepted && !smallStep && lambda <= 1e8 * top; lambda *= 10.0) {
                damped = H;
                damped.diagonal().array() += lambda;
                delta = damped.llt().solve(-g);
                if (delta.allFinite()) tryStep(1.0);
            }
        }
        if (!accepted) {
            solve.converged = smallStep;  // nowhere left to go along a descent direction
            break;
        }
        const double decrease = cost - trialCost;
        std::swap(x, trial);
        cost = trialCost;
        if (smallStep || decrease <= options.functionTolerance * (cost + decrease)) {
            solve.converged = true;
            break;
        }
        problem.jacobian(x, options.finiteDifferenceStep, false, &J, r);
    }
    std::copy(x.begin(), x.end(), values.begin());
    solve.finalCost = cost;
    solve.evaluations = problem.evaluations() - before;
    return solve;
}

}  // namespace rig

#include "tools/bench_blackbox.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"

namespace rig::bench {

BlackBoxProblem::BlackBoxProblem(RigBinding& binding, double rotationScaleCm)
    : binding_(binding), rotationScaleCm_(rotationScaleCm)
{
    constexpr double free = std::numeric_limits<double>::infinity();
    for (const auto& m : binding.approximation().parameters) {
        lower_.push_back(m.parameter.limited ? m.parameter.min : -free);
        upper_.push_back(m.parameter.limited ? m.parameter.max : free);
    }
}

void BlackBoxProblem::setTargets(std::span<const JointTarget> targets)
{
    const auto& outputs = binding_.approximation().outputs;
    if (targets.size() != outputs.size())
        throw internalError(fmt::format("BlackBoxProblem: {} targets for {} outputs", targets.size(), outputs.size()));
    active_.clear();
    prepared_.assign(targets.size(), PreparedTarget{});
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active) continue;
        if (!prepareTarget(targets[k], rotationScaleCm_, prepared_[k]))
            throw Error(fmt::format("BlackBoxProblem: the target of {} is not usable", outputs[k].name));
        active_.push_back(static_cast<int>(k));
    }
}

double BlackBoxProblem::residuals(std::span<const double> values, Eigen::VectorXd& r)
{
    binding_.evaluate(values, worlds_);
    ++evaluations_;
    r.resize(rows());
    for (std::size_t o = 0; o < active_.size(); ++o) {
        const auto k = static_cast<std::size_t>(active_[o]);
        // The solver's own residual rows, on the real rig's world matrix.
        r.segment<6>(static_cast<Eigen::Index>(6 * o)) = targetResidual(worlds_[k], prepared_[k]);
    }
    return 0.5 * r.squaredNorm();
}

void BlackBoxProblem::jacobian(std::span<const double> values, double h, bool central, Eigen::MatrixXd* jacobian,
                               Eigen::VectorXd& r)
{
    residuals(values, r);
    if (jacobian) jacobian->resize(rows(), columns());
    probe_.assign(values.begin(), values.end());
    for (int c = 0; c < columns(); ++c) {
        const auto i = static_cast<std::size_t>(c);
        // The rig refuses a value past a control's limits: at a limit, the difference is one-sided inwards.
        const bool up = values[i] + h <= upper_[i];
        const bool down = values[i] - h >= lower_[i];
        if (central && up && down) {
            probe_[i] = values[i] + h;
            residuals(probe_, rPlus_);
            probe_[i] = values[i] - h;
            residuals(probe_, rMinus_);
            column_ = (rPlus_ - rMinus_) / (2.0 * h);
        } else {
            const double step = up ? h : -h;
            probe_[i] = values[i] + step;
            residuals(probe_, rPlus_);
            column_ = (rPlus_ - r) / step;
        }
        if (jacobian) jacobian->col(c) = column_;
        probe_[i] = values[i];
    }
}

BlackBoxSolve gaussNewtonBlackBox(BlackBoxProblem& problem, std::span<double> values, const SolverOptions& options)
{
    const std::uint64_t before = problem.evaluations();
    const int n = problem.columns();
    const auto& lower = problem.lower();
    const auto& upper = problem.upper();
    std::vector<double> x(values.begin(), values.end()), trial(x.size());
    for (int c = 0; c < n; ++c) {
        const auto i = static_cast<std::size_t>(c);
        x[i] = std::clamp(x[i], lower[i], upper[i]);
    }
    Eigen::MatrixXd J, H;
    Eigen::VectorXd r, rTrial, g, delta;
    std::vector<char> fixed(x.size());
    BlackBoxSolve solve;
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
        // Backtracking: halve the step until the real rig's cost goes down.
        bool accepted = false, smallStep = false;
        double trialCost = cost;
        for (double scale = 1.0; scale > 1e-3; scale *= 0.5) {
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
            if (std::isfinite(trialCost) && (trialCost < cost || (smallStep && trialCost <= cost))) {
                accepted = true;
                break;
            }
            if (smallStep) break;
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

}  // namespace rig::bench

#include "inversion/solve/step_strategy.h"

#include <algorithm>
#include <cmath>

#include "inversion/solve/range_factor.h"

namespace rig {

StepControl::StepControl(const SolverOptions& options, StepPolicy policy)
    : options_(options), policy_(policy), gaussNewton_(options.gaussNewtonIterations > 0)
{
}

double StepControl::damping(double largestDiagonal)
{
    if (gaussNewton_) return 0.0;
    if (mu_ == 0.0) {
        const double scale = largestDiagonal > 0 ? largestDiagonal : 1.0;
        mu_ = initialDamping * scale;
        ceiling_ = policy_.maxDamping * scale;
    }
    return mu_;
}

bool StepControl::accept(double cost, double trialCost, bool smallStep, const std::function<double()>& predicted)
{
    const bool finite = std::isfinite(trialCost);
    if (gaussNewton_) {
        const bool taken = finite && (trialCost < cost || (smallStep && trialCost <= cost));
        if (taken || smallStep) {
            // Only a whole step clears the failures: one taken after halvings found the model poor as far as it went
            // (a leg's goal near its reach, the random characters' orient-constrained hands: Gauss-Newton overshot
            // by 1.5 cm, then descended at a sixteenth, again and again, between damped steps).
            failedInARow_ = taken && scale_ == 1.0 ? 0 : failedInARow_;
            scale_ = 1.0;
            return taken;
        }
        // Gauss-Newton failed to descend: shorter along its step, as the policy allows, else damp.
        if (scale_ > std::ldexp(1.0, -policy_.backtracks)) {
            scale_ *= 0.5;
            return false;
        }
        scale_ = 1.0;
        gaussNewton_ = false;
        ++failedInARow_;
        return false;
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

bool StepControl::exhausted() const { return !std::isfinite(mu_) || mu_ > ceiling_; }

void StepControl::accepted()
{
    if (gaussNewton_) ++gaussNewtonTaken_;
    // Gauss-Newton steps taken, not tried: a step halved four times before it is damped costs the budget nothing.
    // Two Gauss-Newton steps failed with a damped one between: the model does not hold this far from the answer, and
    // trying it before every damped step only doubles their cost (C_Robot_Run.ma's stuck frames).
    const bool budgetSpent =
        policy_.budgetEndsGaussNewton && (gaussNewtonTaken_ >= options_.gaussNewtonIterations || failedInARow_ >= 2);
    if (!gaussNewton_ && !budgetSpent) {
        gaussNewton_ = true;  // the next step Gauss-Newton again, damped afresh if it must be
        mu_ = 0.0;
        nu_ = 2.0;
    }
    if (gaussNewton_ && budgetSpent) gaussNewton_ = false;  // Levenberg-Marquardt to the end
}

DenseSystem::DenseSystem(Eigen::Index columns, Eigen::Index rows)
    : fewerRows_(rows >= 0 && rows < columns),
      singular_(fewerRows_),
      H_(columns, columns),
      damped_(columns, columns),
      llt_(columns),
      pivoted_(columns, columns),
      nullityByRank_(columns, columns),
      nullSquare_(columns, columns),
      permutation_(static_cast<std::size_t>(columns)),
      permuted_(columns),
      reduced_(columns),
      nullVector_(columns)
{
}

void DenseSystem::hold(Eigen::Index i)
{
    H_.row(i).head(i).setZero();
    H_.col(i).tail(H_.rows() - i - 1).setZero();
    H_(i, i) = 1.0;
}

bool DenseSystem::solve(const Eigen::VectorXd& gradient, double mu, std::span<const char> fixed, Eigen::VectorXd& delta)
{
    const Eigen::Index n = H_.rows();
    double maxDiagonal = 0.0;
    for (Eigen::Index i = 0; i < n; ++i)
        if (!fixed[static_cast<std::size_t>(i)]) maxDiagonal = std::max(maxDiagonal, H_(i, i));
    if (!(maxDiagonal > 0)) {
        delta.setZero();
        return true;
    }
    const double threshold = rankTolerance * maxDiagonal;
    // Undamped and known singular, the pivoted factor at once rather than after a Cholesky that fails. Damped,
    // J^T J + mu I is definite.
    if (mu == 0.0 && singular_) return rangeStep(H_, gradient, threshold, delta) && delta.allFinite();
    damped_.triangularView<Eigen::Lower>() = H_;
    damped_.diagonal().array() += mu;
    llt_.compute(damped_);
    bool wellConditioned = llt_.info() == Eigen::Success;
    if (wellConditioned) {
        const auto& l = llt_.matrixLLT();
        for (Eigen::Index i = 0; i < n; ++i)
            if (!(l(i, i) * l(i, i) > threshold)) wellConditioned = false;
    }
    if (wellConditioned) {
        delta = -gradient;
        llt_.solveInPlace(delta);
    } else {
        singular_ = singular_ || mu == 0.0;
        if (!rangeStep(damped_, gradient, threshold, delta)) return false;
    }
    return delta.allFinite();
}

bool DenseSystem::rangeStep(const Eigen::MatrixXd& s, const Eigen::VectorXd& gradient, double threshold,
                            Eigen::VectorXd& delta)
{
    // delta = -S^+ g = -R^T G^-2 R g with R = L^T P and G = L^T L; of full rank, -P^T L^-T L^-1 P g.
    const Eigen::Index n = H_.rows();
    pivoted_ = s.selfadjointView<Eigen::Lower>();
    const Eigen::Index rank = pivotedCholesky(pivoted_, permutation_, threshold);
    const auto l = pivoted_.leftCols(rank);
    for (Eigen::Index i = 0; i < n; ++i) permuted_[i] = gradient[permutation_[static_cast<std::size_t>(i)]];
    const auto lower = pivoted_.topLeftCorner(rank, rank).triangularView<Eigen::Lower>();
    if (rank == n) {
        lower.solveInPlace(permuted_);
        lower.transpose().solveInPlace(permuted_);
    } else {
        // L = [L1; L2] (L1 the rank's triangle) makes G = L1^T (I + M^T M) L1 with M = L2 L1^-1, and by Woodbury's
        // identity (I + M^T M)^-1 = I - M^T (I + M M^T)^-1 M: triangular solves and a system of the null space's
        // size, where forming G and factoring it cost n r^2 / 2 + r^3 / 3 (redundant controls leave few null
        // directions: C_Robot_Rig's 102 columns have 17 to 20).
        const Eigen::Index nullity = n - rank;
        auto m = nullityByRank_.topLeftCorner(nullity, rank);
        m = pivoted_.bottomLeftCorner(nullity, rank);
        lower.solveInPlace<Eigen::OnTheRight>(m);
        auto small = nullSquare_.topLeftCorner(nullity, nullity);
        small.setIdentity();
        small.selfadjointView<Eigen::Lower>().rankUpdate(m);
        Eigen::Ref<Eigen::MatrixXd> inPlace(small);
        const Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(inPlace);
        if (llt.info() != Eigen::Success) return false;
        auto y = reduced_.head(rank);
        auto t = nullVector_.head(nullity);
        y.noalias() = l.transpose() * permuted_;
        for (int twice = 0; twice < 2; ++twice) {  // y <- G^-1 y
            lower.transpose().solveInPlace(y);
            t.noalias() = m * y;
            llt.solveInPlace(t);
            y.noalias() -= m.transpose() * t;
            lower.solveInPlace(y);
        }
        permuted_.noalias() = l * y;
    }
    delta.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) delta[permutation_[static_cast<std::size_t>(i)]] = -permuted_[i];
    return true;
}

void DenseSystem::multiply(const Eigen::VectorXd& v, Eigen::VectorXd& out) const
{
    out.noalias() = H_.selfadjointView<Eigen::Lower>() * v;
}

}  // namespace rig

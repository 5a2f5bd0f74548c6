#pragma once
// The reference minimum-norm step of the solver's tests: (H + mu I)^+ (-gradient) from an eigendecomposition, on
// the range of eigenvalues above 1e-12 of the largest (what the solver's pivoted range factor must give).

#include <Eigen/Core>
#include <Eigen/Eigenvalues>

namespace rig::test {

inline Eigen::VectorXd minimumNormStep(const Eigen::MatrixXd& h, double mu, const Eigen::VectorXd& gradient)
{
    const Eigen::Index n = h.rows();
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(h + mu * Eigen::MatrixXd::Identity(n, n));
    const Eigen::VectorXd& lambda = eigen.eigenvalues();
    Eigen::VectorXd inverse = Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < n; ++i)
        if (lambda[i] > 1e-12 * lambda.maxCoeff()) inverse[i] = 1.0 / lambda[i];
    return -(eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose() * gradient);
}

}  // namespace rig::test

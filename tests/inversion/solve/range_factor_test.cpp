// The range of a singular J^T J from a pivoted Cholesky factor: its rank and its reconstruction, and the dense
// step's minimum-norm answer against an eigendecomposition's (the method it replaced, at a fraction of the cost).
#include <doctest/doctest.h>

#include <random>
#include <vector>

#include "inversion/solve/minimum_norm_step.h"
#include "inversion/solve/range_factor.h"
#include "inversion/solve/step_strategy.h"

namespace rig {
namespace {

// J^T J of a random m x n Jacobian whose columns repeat: its rank is at most the distinct columns'.
Eigen::MatrixXd singularNormalMatrix(std::mt19937& rng, Eigen::Index rows, Eigen::Index distinct, Eigen::Index columns)
{
    std::normal_distribution<double> normal;
    Eigen::MatrixXd j(rows, columns);
    for (Eigen::Index c = 0; c < columns; ++c)
        for (Eigen::Index r = 0; r < rows; ++r) j(r, c) = c < distinct ? normal(rng) : j(r, c % distinct);
    return j.transpose() * j;
}

}  // namespace

TEST_CASE("range factor: a pivoted Cholesky factor has the rank of a singular matrix and rebuilds it")
{
    std::mt19937 rng(5101);
    for (const Eigen::Index distinct : {1, 4, 7, 12}) {
        CAPTURE(distinct);
        const Eigen::Index n = 12;
        const Eigen::MatrixXd s = singularNormalMatrix(rng, 20, distinct, n);
        Eigen::MatrixXd a = s;
        std::vector<int> permutation(static_cast<std::size_t>(n));
        const Eigen::Index rank = pivotedCholesky(a, permutation, 1e-12 * s.diagonal().maxCoeff());
        CHECK(rank == distinct);
        const Eigen::MatrixXd l = a.leftCols(rank);
        CHECK(l.topRows(rank).triangularView<Eigen::StrictlyUpper>().toDenseMatrix().isZero());
        Eigen::MatrixXd rebuilt(n, n);
        for (Eigen::Index i = 0; i < n; ++i)
            for (Eigen::Index k = 0; k < n; ++k)
                rebuilt(permutation[static_cast<std::size_t>(i)], permutation[static_cast<std::size_t>(k)]) =
                    l.row(i).dot(l.row(k));
        CHECK((rebuilt - s).norm() <= 1e-12 * s.norm());
    }
}

TEST_CASE("range factor: the dense step of a singular system is the minimum-norm one, redundant columns split evenly")
{
    std::mt19937 rng(5102);
    const Eigen::Index n = 30;
    for (const Eigen::Index distinct : {10, 22}) {
        const Eigen::MatrixXd h = singularNormalMatrix(rng, 24, distinct, n);
        // A gradient of J^T r: in the range, as a least-squares problem's is.
        const Eigen::VectorXd gradient = h * Eigen::VectorXd::Random(n);
        for (const double mu : {0.0, 1e-14}) {
            CAPTURE(distinct);
            CAPTURE(mu);
            DenseSystem dense(n);
            dense.matrix() = h;
            const std::vector<char> fixed(static_cast<std::size_t>(n), 0);
            Eigen::VectorXd delta(n);
            REQUIRE(dense.solve(gradient, mu, fixed, delta));
            const Eigen::VectorXd expected = test::minimumNormStep(h, mu, gradient);
            CHECK((delta - expected).norm() <= 1e-8 * expected.norm());
            // Column distinct + c repeats column c: the two share its change.
            for (Eigen::Index c = distinct; c < n; ++c)
                CHECK(delta[c] == doctest::Approx(delta[c % distinct]).epsilon(1e-8));
        }
    }
}

TEST_CASE("range factor: a definite system's undamped step after a singular one is Cholesky's, from the pivoted factor")
{
    // Within one minimization, once an undamped Cholesky has failed, undamped steps take the pivoted factor at once:
    // of full rank, it gives Cholesky's step.
    std::mt19937 rng(5103);
    const Eigen::Index n = 40;
    const Eigen::MatrixXd singular = singularNormalMatrix(rng, 60, 25, n);
    const Eigen::MatrixXd h = singularNormalMatrix(rng, 60, n, n);
    const Eigen::VectorXd gradient = Eigen::VectorXd::Random(n);
    for (const bool restarted : {false, true}) {
        CAPTURE(restarted);
        DenseSystem dense(n);
        dense.matrix() = singular;
        const std::vector<char> fixed(static_cast<std::size_t>(n), 0);
        Eigen::VectorXd delta(n);
        REQUIRE(dense.solve(singular * gradient, 0.0, fixed, delta));
        if (restarted) dense.restart();
        dense.matrix() = h;
        REQUIRE(dense.solve(gradient, 0.0, fixed, delta));
        const Eigen::VectorXd expected = -h.llt().solve(gradient);
        CHECK((delta - expected).norm() <= 1e-10 * expected.norm());
        CHECK((h * delta + gradient).norm() <= 1e-10 * gradient.norm());
    }
    // Fewer rows than columns: singular whatever the values, the pivoted factor from the first step.
    DenseSystem wide(n, 30);
    wide.matrix() = singularNormalMatrix(rng, 30, n, n);
    const Eigen::VectorXd g = wide.matrix() * Eigen::VectorXd::Random(n);
    Eigen::VectorXd delta(n);
    REQUIRE(wide.solve(g, 0.0, std::vector<char>(static_cast<std::size_t>(n), 0), delta));
    const Eigen::VectorXd expected = test::minimumNormStep(wide.matrix(), 0.0, g);
    CHECK((delta - expected).norm() <= 1e-8 * expected.norm());
}

}  // namespace rig

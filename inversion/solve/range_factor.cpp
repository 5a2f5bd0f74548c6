#include "inversion/solve/range_factor.h"

#include <numeric>
#include <utility>

namespace rig {
namespace {

constexpr Eigen::Index smallSystem = 24;

}  // namespace

// Left-looking, as LAPACK's dpstf2: column k of L is formed from S's column and the k columns before it, and the
// trailing diagonal carries S's diagonal less the squares of L's rows so far (the pivots' candidates). Unlike the
// right-looking form, no trailing square is updated: the work is n r^2 / 2 rather than n^3 / 3, and it stops at r.
Eigen::Index pivotedCholesky(Eigen::Ref<Eigen::MatrixXd> a, std::span<int> permutation, double threshold)
{
    const Eigen::Index n = a.rows(), ld = a.outerStride();
    double* const base = a.data();
    const auto at = [&](Eigen::Index i, Eigen::Index j) -> double& { return base[i + j * ld]; };
    std::iota(permutation.begin(), permutation.begin() + n, 0);
    Eigen::Index rank = 0;
    // Plain loops for the pivots and the diagonal: the systems are mostly small (a joint's 3 to 20 columns), where
    // expressions cost more than the arithmetic. A column's update by the columns before it is one matrix-vector
    // product, which keeps its sums in registers: as k updates of the column in turn, the factor of C_Robot_Rig's
    // 102 columns was a quarter of its clip's instructions (callgrind; with DenseSystem's step by Woodbury's identity,
    // a third fewer an iteration; a small rig's clip the same to 0.3%). Up to smallSystem columns (a limb's block of
    // the elimination) the update is a plain loop over the columns before it: the product's dispatch cost more there.
    for (Eigen::Index k = 0; k < n; ++k, ++rank) {
        Eigen::Index p = k;
        for (Eigen::Index j = k + 1; j < n; ++j)
            if (at(j, j) > at(p, p)) p = j;
        const double pivot = at(p, p);
        if (!(pivot > threshold)) break;
        if (p != k) {
            // L's rows so far, and S's trailing rows and columns (both triangles: a swap moves one into the other).
            for (Eigen::Index l = 0; l < k; ++l) std::swap(at(k, l), at(p, l));
            for (Eigen::Index i = k; i < n; ++i) std::swap(at(i, k), at(i, p));
            for (Eigen::Index j = k; j < n; ++j) std::swap(at(k, j), at(p, j));
            std::swap(permutation[static_cast<std::size_t>(k)], permutation[static_cast<std::size_t>(p)]);
        }
        const double diagonal = std::sqrt(pivot);
        at(k, k) = diagonal;
        double* const column = &at(k + 1, k);
        const Eigen::Index m = n - k - 1;
        if (k > 0 && m > 0 && n <= smallSystem) {
            for (Eigen::Index l = 0; l < k; ++l) {
                const double s = at(k, l);
                const double* source = &at(k + 1, l);
                for (Eigen::Index i = 0; i < m; ++i) column[i] -= s * source[i];
            }
        } else if (k > 0 && m > 0) {
            a.col(k).tail(m).noalias() -= a.block(k + 1, 0, m, k) * a.row(k).head(k).transpose();
        }
        const double inverse = 1.0 / diagonal;  // one division: the column's many multiply
        for (Eigen::Index i = 0; i < m; ++i) {
            column[i] *= inverse;
            at(k + 1 + i, k + 1 + i) -= column[i] * column[i];
        }
    }
    a.topLeftCorner(rank, rank).triangularView<Eigen::StrictlyUpper>().setZero();
    return rank;
}

}  // namespace rig

#include "inversion/solve/range_factor.h"

#include <numeric>
#include <utility>

namespace rig {

Eigen::Index pivotedCholesky(Eigen::Ref<Eigen::MatrixXd> a, std::span<int> permutation, double threshold)
{
    const Eigen::Index n = a.rows();
    std::iota(permutation.begin(), permutation.begin() + n, 0);
    Eigen::Index rank = 0;
    for (Eigen::Index k = 0; k < n; ++k, ++rank) {
        Eigen::Index p = 0;
        const double pivot = a.diagonal().tail(n - k).maxCoeff(&p);
        if (!(pivot > threshold)) break;
        p += k;
        if (p != k) {
            a.row(k).swap(a.row(p));
            a.col(k).swap(a.col(p));
            std::swap(permutation[static_cast<std::size_t>(k)], permutation[static_cast<std::size_t>(p)]);
        }
        a(k, k) = std::sqrt(pivot);
        a.col(k).tail(n - k - 1) /= a(k, k);
        a.bottomRightCorner(n - k - 1, n - k - 1).noalias() -=
            a.col(k).tail(n - k - 1) * a.col(k).tail(n - k - 1).transpose();
    }
    a.topLeftCorner(rank, rank).triangularView<Eigen::StrictlyUpper>().setZero();
    return rank;
}

}  // namespace rig

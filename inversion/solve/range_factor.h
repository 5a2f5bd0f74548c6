#pragma once
// A symmetric positive semi-definite matrix's range as a Cholesky factor with diagonal pivoting: P S P^T = L L^T, L
// n x r with r the pivots above a threshold (S's rank to that tolerance). With R = L^T P and G = L^T L, the
// pseudo-inverse is S^+ = R^T G^-2 R: the minimum-norm solution of S x = b, which leaves S's null directions alone
// (redundant parameters split a change evenly, one with no effect stays), at a fraction of an eigendecomposition's
// cost. The block elimination (block_elimination.h) and the dense step (step_strategy.h) both take it.

#include <span>

#include <Eigen/Core>

namespace rig {

// Directions whose curvature is at or below this fraction of the whole system's largest diagonal entry are null: the
// minimum-norm step leaves them alone (the dense step and the block elimination alike, docs/solver.md, Step).
inline constexpr double rankTolerance = 1e-12;

// `a` holds S in full (both triangles) and leaves with L in its first r columns, zero above their diagonal (the rest
// is scratch); row i of L is row permutation[i] of S. Returns r. `permutation` has a's size.
Eigen::Index pivotedCholesky(Eigen::Ref<Eigen::MatrixXd> a, std::span<int> permutation, double threshold);

}  // namespace rig

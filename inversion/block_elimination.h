#pragma once
// The coupled step of a partitioned problem (DESIGN: inversion): the Gauss-Newton / Levenberg-Marquardt
// system (J^T J + mu I) d = -g of every block at once, solved by eliminating the blocks of the partition
// tree from the leaves up.
//
// The partition (inversion/partition.h) gives each counted output to one block, and the only
// parameters that move it are that block's and its ancestors'. J^T J then couples a block only with
// its ancestors: a block-arrowhead matrix (a tree of them), whose Schur complements onto the parents
// fill nothing outside the ancestor chains. Eliminating a leaf b costs its size cubed plus products
// with its ancestors' blocks, so the coupled step costs about what the blocks' own steps cost, and the
// solve reaches the whole problem's optimum where the block-by-block order (an outer block fitted first,
// then held) stops at a worse one on unreachable targets.
//
// A block's own matrix that is singular (redundant controls, a straight limb) is inverted on its range
// only (eigenvalues above 1e-12 of its largest): the minimum-norm step within the block, as the
// one-block solve takes.

#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>

#include "inversion/jacobian.h"
#include "inversion/partition.h"

namespace rig {

// Built once per partition; shared read-only by the solves that use it.
class BlockElimination {
public:
    // `structure`: the whole problem (every block's parameters as columns, every block's outputs as rows).
    BlockElimination(const Partition& partition, const ResidualStructure& structure);

    int blocks() const { return static_cast<int>(size_.size()); }

private:
    friend class BlockEliminationWorkspace;

    std::vector<int> size_;                   // per block: its columns
    std::vector<std::vector<int>> chain_;     // per block: itself, then its ancestors up to its root
    std::vector<std::vector<int>> columns_;   // per block: its structure columns, in order
    std::vector<int> blockOfColumn_, localOfColumn_;
    // Per block and chain entry: where each entry of that block of J^T J is in the whole matrix's lower
    // triangle (column-major offsets, in the block's own column-major order).
    std::vector<std::vector<std::vector<int>>> gather_;
};

// Per-solve state: the blocks of J^T J along each chain, the right-hand sides and the blocks' factors.
// Sized once; allocates nothing per step.
class BlockEliminationWorkspace {
public:
    explicit BlockEliminationWorkspace(const BlockElimination& elimination);

    // The blocks along each chain from J^T J given whole (its lower triangle, structure columns; held
    // columns already replaced by identity rows and columns).
    void form(const Eigen::MatrixXd& h);
    // Solves (J^T J + mu I) delta = -gradient (gradient: zero on fixed columns). False when a block's
    // matrix has no finite inverse.
    bool solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu, Eigen::Ref<Eigen::VectorXd> delta);

private:
    bool factor(std::size_t b);  // factor_[b] from work_[b][0]; false when it has no finite inverse

    const BlockElimination* e_;
    std::vector<std::vector<Eigen::MatrixXd>> h_;  // h_[b][i]: block b against its i-th chain entry (0: itself)
    std::vector<std::vector<Eigen::MatrixXd>> work_;      // copies of h_ that the elimination overwrites
    std::vector<std::vector<Eigen::MatrixXd>> coupling_;  // coupling_[b][i] = F_b work_[b][i] (i >= 1), eliminated
    std::vector<Eigen::MatrixXd> factor_;  // per block: F^T, F^T F the (pseudo-)inverse of its eliminated matrix
    std::vector<Eigen::LLT<Eigen::MatrixXd>> llt_;
    std::vector<Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>> eigen_;
    std::vector<Eigen::VectorXd> rhs_, y_, step_;
};

}  // namespace rig

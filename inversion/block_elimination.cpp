#include "inversion/block_elimination.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>

namespace rig {
namespace {

// Directions whose curvature is below this fraction of the block's largest are left alone.
constexpr double rankTolerance = 1e-12;

int positionOf(const std::vector<int>& sorted, int value)
{
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), value);
    if (it == sorted.end() || *it != value)
        throw std::invalid_argument(fmt::format("BlockElimination: index {} is not in the problem", value));
    return static_cast<int>(it - sorted.begin());
}

}  // namespace

BlockElimination::BlockElimination(const Partition& partition, const ResidualStructure& structure)
{
    const std::size_t blocks = partition.blocks.size();
    size_.resize(blocks);
    chain_.resize(blocks);
    columns_.resize(blocks);
    blockOfColumn_.assign(static_cast<std::size_t>(structure.columnCount()), -1);
    localOfColumn_.assign(blockOfColumn_.size(), -1);
    std::vector<int> blockOfOutput(structure.outputs().size(), -1);
    for (std::size_t b = 0; b < blocks; ++b) {
        const PartitionBlock& block = partition.blocks[b];
        size_[b] = static_cast<int>(block.parameters.size());
        for (int a = static_cast<int>(b); a >= 0; a = partition.blocks[static_cast<std::size_t>(a)].parent)
            chain_[b].push_back(a);
        for (const int p : block.parameters) {
            const int c = positionOf(structure.columns(), p);
            blockOfColumn_[static_cast<std::size_t>(c)] = static_cast<int>(b);
            localOfColumn_[static_cast<std::size_t>(c)] = static_cast<int>(columns_[b].size());
            columns_[b].push_back(c);
        }
        for (const int k : block.outputs)
            blockOfOutput[static_cast<std::size_t>(positionOf(structure.outputs(), k))] = static_cast<int>(b);
    }
    if (std::find(blockOfColumn_.begin(), blockOfColumn_.end(), -1) != blockOfColumn_.end())
        throw std::invalid_argument("BlockElimination: a column of the problem is in no block");
    // Every column a row moves must be in that row's chain: the partition's promise, checked once. Then
    // J^T J has no entry outside the blocks gathered below.
    for (int c = 0; c < structure.columnCount(); ++c)
        for (const int o : structure.outputsOfColumn(c)) {
            const int owner = blockOfOutput[static_cast<std::size_t>(o)];
            const int block = blockOfColumn_[static_cast<std::size_t>(c)];
            if (owner < 0 || std::find(chain_[static_cast<std::size_t>(owner)].begin(),
                                       chain_[static_cast<std::size_t>(owner)].end(),
                                       block) == chain_[static_cast<std::size_t>(owner)].end())
                throw std::invalid_argument("BlockElimination: a parameter moves an output outside its block's chain");
        }
    const int n = structure.columnCount();
    layout_.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(n), -1);
    base_.resize(blocks);
    coupledBelow_.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t i = 0; i < chain_[b].size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain_[b][i]);
            base_[b].push_back(entryCount_);
            if (i > 0) coupledBelow_[a].emplace_back(static_cast<int>(b), static_cast<int>(i));
            // Column-major within the block; J^T J's entry (max, min) of the two structure columns.
            for (std::size_t la = 0; la < columns_[a].size(); ++la)
                for (std::size_t lb = 0; lb < columns_[b].size(); ++lb) {
                    const int ca = columns_[a][la], cb = columns_[b][lb];
                    const int index = entryCount_ + static_cast<int>(la * columns_[b].size() + lb);
                    const std::size_t dense = static_cast<std::size_t>(std::min(ca, cb)) * static_cast<std::size_t>(n) +
                                              static_cast<std::size_t>(std::max(ca, cb));
                    // A diagonal block keeps its lower triangle (the factor reads no other).
                    if (i > 0 || lb >= la) layout_[dense] = index;
                }
            entryCount_ += static_cast<int>(columns_[a].size() * columns_[b].size());
        }
}

BlockEliminationWorkspace::BlockEliminationWorkspace(const BlockElimination& elimination)
    : e_(&elimination), entries_(static_cast<std::size_t>(elimination.entryCount_), 0.0)
{
    const std::size_t blocks = elimination.size_.size();
    work_.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b)
        for (const int a : elimination.chain_[b])
            work_[b].emplace_back(elimination.size_[b], elimination.size_[static_cast<std::size_t>(a)]);
    coupling_ = work_;
    for (std::size_t b = 0; b < blocks; ++b) {
        factor_.emplace_back(elimination.size_[b], elimination.size_[b]);
        llt_.emplace_back(elimination.size_[b]);
        eigen_.emplace_back(elimination.size_[b]);
        rhs_.emplace_back(elimination.size_[b]);
        y_.emplace_back(elimination.size_[b]);
        step_.emplace_back(elimination.size_[b]);
    }
}

BlockEliminationWorkspace::BlockMap BlockEliminationWorkspace::block(std::size_t b, std::size_t i)
{
    const BlockElimination& e = *e_;
    return BlockMap(entries_.data() + e.base_[b][i], e.size_[b], e.size_[static_cast<std::size_t>(e.chain_[b][i])]);
}

BlockEliminationWorkspace::ConstBlockMap BlockEliminationWorkspace::block(std::size_t b, std::size_t i) const
{
    const BlockElimination& e = *e_;
    return ConstBlockMap(entries_.data() + e.base_[b][i], e.size_[b], e.size_[static_cast<std::size_t>(e.chain_[b][i])]);
}

double BlockEliminationWorkspace::diagonal(int column) const
{
    const BlockElimination& e = *e_;
    const std::size_t b = static_cast<std::size_t>(e.blockOfColumn_[static_cast<std::size_t>(column)]);
    const Eigen::Index l = e.localOfColumn_[static_cast<std::size_t>(column)];
    return block(b, 0)(l, l);
}

void BlockEliminationWorkspace::hold(int column)
{
    const BlockElimination& e = *e_;
    const std::size_t b = static_cast<std::size_t>(e.blockOfColumn_[static_cast<std::size_t>(column)]);
    const Eigen::Index l = e.localOfColumn_[static_cast<std::size_t>(column)];
    // Its row against its own block (lower triangle) and its ancestors, its column against descendants.
    BlockMap own = block(b, 0);
    own.row(l).head(l).setZero();
    own.col(l).tail(own.rows() - l - 1).setZero();
    own(l, l) = 1.0;
    for (std::size_t i = 1; i < e.chain_[b].size(); ++i) block(b, i).row(l).setZero();
    for (const auto& [d, i] : e.coupledBelow_[b]) block(static_cast<std::size_t>(d), static_cast<std::size_t>(i)).col(l).setZero();
}

void BlockEliminationWorkspace::multiply(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out) const
{
    const BlockElimination& e = *e_;
    out.setZero();
    for (std::size_t b = 0; b < e.size_.size(); ++b) {
        const auto& columns = e.columns_[b];
        for (std::size_t i = 0; i < e.chain_[b].size(); ++i) {
            const ConstBlockMap h = block(b, i);
            const auto& other = e.columns_[static_cast<std::size_t>(e.chain_[b][i])];
            for (Eigen::Index j = 0; j < h.cols(); ++j)
                for (Eigen::Index k = i == 0 ? j : 0; k < h.rows(); ++k) {
                    const int row = columns[static_cast<std::size_t>(k)], col = other[static_cast<std::size_t>(j)];
                    out[row] += h(k, j) * v[col];
                    if (row != col) out[col] += h(k, j) * v[row];
                }
        }
    }
}

bool BlockEliminationWorkspace::factor(std::size_t b)
{
    // factor_[b] = F^T with F^T F = S^-1 (S^+ where S is singular).
    const Eigen::MatrixXd& s = work_[b][0];  // symmetric by construction; only its lower triangle is read
    const Eigen::Index n = s.rows();
    Eigen::MatrixXd& f = factor_[b];
    Eigen::LLT<Eigen::MatrixXd>& llt = llt_[b];
    llt.compute(s);
    const double largestDiagonal = s.diagonal().maxCoeff();
    bool wellConditioned = llt.info() == Eigen::Success && largestDiagonal > 0;
    const auto& l = llt.matrixLLT();
    if (wellConditioned)
        for (Eigen::Index i = 0; i < n; ++i)
            if (!(l(i, i) * l(i, i) > rankTolerance * largestDiagonal)) wellConditioned = false;
    if (wellConditioned) {
        // F = L^-1 by forward substitution, kept transposed: a block is small, and the blocked triangular
        // kernels' set-up costs more than the arithmetic.
        f.setZero();
        for (Eigen::Index j = 0; j < n; ++j) {
            f(j, j) = 1.0 / l(j, j);
            for (Eigen::Index i = j + 1; i < n; ++i) {
                double sum = 0.0;
                for (Eigen::Index k = j; k < i; ++k) sum += l(i, k) * f(j, k);
                f(j, i) = -sum / l(i, i);
            }
        }
    } else {
        // S+ = V diag(1 / lambda) V^T on the range: F = diag(1 / sqrt(lambda)) V^T, zero rows elsewhere.
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eigen = eigen_[b];
        eigen.compute(s);
        if (eigen.info() != Eigen::Success) return false;
        const auto& lambda = eigen.eigenvalues();
        const double largest = lambda.cwiseAbs().maxCoeff();
        for (Eigen::Index i = 0; i < n; ++i)
            f.col(i) = (lambda[i] > rankTolerance * largest ? 1.0 / std::sqrt(lambda[i]) : 0.0) * eigen.eigenvectors().col(i);
    }
    return f.allFinite();
}

bool BlockEliminationWorkspace::solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                      Eigen::Ref<Eigen::VectorXd> delta)
{
    const BlockElimination& e = *e_;
    const std::size_t blocks = e.size_.size();
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = 0; i < work_[b].size(); ++i) work_[b][i] = block(b, i);
        work_[b][0].diagonal().array() += mu;
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l)
            rhs_[b][static_cast<Eigen::Index>(l)] = -gradient[e.columns_[b][l]];
    }
    // Leaves first (the partition lists parents before children): with S_b^-1 = F^T F, each block's
    // couplings become T_i = F H_{b,a_i}, its right-hand side y = F rhs, and its ancestors lose
    // T_i^T T_j and T_i^T y (the Schur complement).
    for (std::size_t b = blocks; b-- > 0;) {
        if (e.size_[b] == 0) continue;
        if (!factor(b)) return false;
        // F^T is kept: F X as (F^T)^T X reads both operands' columns contiguously.
        const Eigen::MatrixXd& ft = factor_[b];
        y_[b].noalias() = ft.transpose().lazyProduct(rhs_[b]);
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) coupling_[b][i].noalias() = ft.transpose().lazyProduct(work_[b][i]);
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain[i]);
            rhs_[a].noalias() -= coupling_[b][i].transpose().lazyProduct(y_[b]);
            for (std::size_t j = i; j < chain.size(); ++j)
                work_[a][j - i].noalias() -= coupling_[b][i].transpose().lazyProduct(coupling_[b][j]);
        }
    }
    // Roots first: each block's step from its ancestors', F^T (y - sum T_i step_a).
    for (std::size_t b = 0; b < blocks; ++b) {
        if (e.size_[b] == 0) continue;
        Eigen::VectorXd& z = y_[b];
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) z.noalias() -= coupling_[b][i] * step_[static_cast<std::size_t>(chain[i])];
        step_[b].noalias() = factor_[b] * z;
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l) delta[e.columns_[b][l]] = step_[b][static_cast<Eigen::Index>(l)];
    }
    return delta.allFinite();
}

}  // namespace rig

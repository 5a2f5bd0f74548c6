#include "inversion/block_elimination.h"

#include <algorithm>
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
    chainColumns_.resize(blocks);
    chainSegments_.resize(blocks);
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
        for (const int k : block.outputs) blockOfOutput[static_cast<std::size_t>(positionOf(structure.outputs(), k))] = static_cast<int>(b);
    }
    if (std::find(blockOfColumn_.begin(), blockOfColumn_.end(), -1) != blockOfColumn_.end())
        throw std::invalid_argument("BlockElimination: a column of the problem is in no block");
    blockRows_.resize(blocks);
    for (std::size_t o = 0; o < blockOfOutput.size(); ++o)
        if (blockOfOutput[o] >= 0) blockRows_[static_cast<std::size_t>(blockOfOutput[o])].push_back(static_cast<int>(o));
    std::size_t mostRows = 0;
    for (std::size_t b = 0; b < blocks; ++b) {
        for (const int a : chain_[b]) {
            chainSegments_[b].push_back(static_cast<int>(chainColumns_[b].size()));
            chainColumns_[b].insert(chainColumns_[b].end(), columns_[static_cast<std::size_t>(a)].begin(),
                                    columns_[static_cast<std::size_t>(a)].end());
        }
        widest_ = std::max(widest_, static_cast<int>(chainColumns_[b].size()));
        mostRows = std::max(mostRows, blockRows_[b].size());
    }
    mostRows_ = static_cast<int>(mostRows);
    // Every column a row moves must be in that row's chain: the partition's promise, checked once.
    for (int c = 0; c < structure.columnCount(); ++c)
        for (const int o : structure.outputsOfColumn(c)) {
            const int owner = blockOfOutput[static_cast<std::size_t>(o)];
            const auto& columns = chainColumns_[static_cast<std::size_t>(owner < 0 ? 0 : owner)];
            if (owner < 0 || std::find(columns.begin(), columns.end(), c) == columns.end())
                throw std::invalid_argument("BlockElimination: a parameter moves an output outside its block's chain");
        }
}

BlockEliminationWorkspace::BlockEliminationWorkspace(const BlockElimination& elimination) : e_(&elimination)
{
    const std::size_t blocks = elimination.size_.size();
    h_.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b)
        for (const int a : elimination.chain_[b])
            h_[b].emplace_back(elimination.size_[b], elimination.size_[static_cast<std::size_t>(a)]);
    work_ = h_;
    for (std::size_t b = 0; b < blocks; ++b) {
        inverse_.emplace_back(elimination.size_[b], elimination.size_[b]);
        llt_.emplace_back(elimination.size_[b]);
        eigen_.emplace_back(elimination.size_[b]);
        rhs_.emplace_back(elimination.size_[b]);
        step_.emplace_back(elimination.size_[b]);
        scratch_.emplace_back(elimination.size_[b], elimination.widest_);
    }
    gathered_.resize(rowsPerTarget * elimination.mostRows_, elimination.widest_);
    product_.resize(elimination.widest_, elimination.widest_);
}

double BlockEliminationWorkspace::form(const Eigen::Ref<const Eigen::MatrixXd>& jacobian, std::span<const char> fixed)
{
    const BlockElimination& e = *e_;
    for (auto& row : h_)
        for (auto& m : row) m.setZero();
    // Per block, its outputs' rows against its chain's columns at once: one product a block.
    for (std::size_t b = 0; b < e.blockRows_.size(); ++b) {
        const auto& rows = e.blockRows_[b];
        if (rows.empty()) continue;
        const auto& columns = e.chainColumns_[b];
        const auto& segments = e.chainSegments_[b];
        const Eigen::Index m = static_cast<Eigen::Index>(columns.size());
        auto g = gathered_.topLeftCorner(static_cast<Eigen::Index>(rowsPerTarget * rows.size()), m);
        for (Eigen::Index i = 0; i < m; ++i) {
            const int c = columns[static_cast<std::size_t>(i)];
            if (fixed[static_cast<std::size_t>(c)]) {
                g.col(i).setZero();
                continue;
            }
            for (std::size_t r = 0; r < rows.size(); ++r)
                g.block<rowsPerTarget, 1>(static_cast<Eigen::Index>(rowsPerTarget * r), i) =
                    jacobian.block<rowsPerTarget, 1>(static_cast<Eigen::Index>(rowsPerTarget * rows[r]), c);
        }
        auto p = product_.topLeftCorner(m, m);
        p.noalias() = g.transpose() * g;
        // The chain runs from the block to its root: entry i's block against entry j >= i, an ancestor.
        const auto& chain = e.chain_[b];
        for (std::size_t i = 0; i < chain.size(); ++i) {
            const std::size_t x = static_cast<std::size_t>(chain[i]);
            for (std::size_t j = i; j < chain.size(); ++j) {
                const std::size_t y = static_cast<std::size_t>(chain[j]);
                h_[x][j - i] += p.block(segments[i], segments[j], e.size_[x], e.size_[y]);
            }
        }
    }
    double largest = 0.0;
    for (std::size_t c = 0; c < fixed.size(); ++c) {
        const std::size_t b = static_cast<std::size_t>(e.blockOfColumn_[c]);
        const Eigen::Index l = e.localOfColumn_[c];
        if (fixed[c]) h_[b][0](l, l) = 1.0;
        else largest = std::max(largest, h_[b][0](l, l));
    }
    return largest;
}

bool BlockEliminationWorkspace::solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                      Eigen::Ref<Eigen::VectorXd> delta)
{
    const BlockElimination& e = *e_;
    const std::size_t blocks = e.size_.size();
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = 0; i < h_[b].size(); ++i) work_[b][i] = h_[b][i];
        work_[b][0].diagonal().array() += mu;
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l)
            rhs_[b][static_cast<Eigen::Index>(l)] = -gradient[e.columns_[b][l]];
    }
    // Leaves first (the partition lists parents before children): each block's Schur complement onto
    // its ancestors.
    for (std::size_t b = blocks; b-- > 0;) {
        const Eigen::Index n = e.size_[b];
        if (n == 0) continue;
        const Eigen::MatrixXd& s = work_[b][0];
        // Symmetric by construction; only its lower triangle is read below (Cholesky, eigen solver).
        Eigen::LLT<Eigen::MatrixXd>& llt = llt_[b];
        llt.compute(s);
        const double largestDiagonal = s.diagonal().maxCoeff();
        bool wellConditioned = llt.info() == Eigen::Success && largestDiagonal > 0;
        if (wellConditioned)
            for (Eigen::Index i = 0; i < n; ++i)
                if (!(llt.matrixLLT()(i, i) * llt.matrixLLT()(i, i) > rankTolerance * largestDiagonal)) wellConditioned = false;
        if (wellConditioned) {
            inverse_[b].setIdentity();
            llt.solveInPlace(inverse_[b]);
        } else {
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eigen = eigen_[b];
            eigen.compute(s);
            if (eigen.info() != Eigen::Success) return false;
            const auto& lambda = eigen.eigenvalues();
            const double largest = lambda.cwiseAbs().maxCoeff();
            Eigen::VectorXd& inverted = step_[b];  // free until the back-substitution
            for (Eigen::Index i = 0; i < n; ++i) inverted[i] = lambda[i] > rankTolerance * largest ? 1.0 / lambda[i] : 0.0;
            inverse_[b].noalias() = eigen.eigenvectors() * inverted.asDiagonal() * eigen.eigenvectors().transpose();
        }
        if (!inverse_[b].allFinite()) return false;
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain[i]);
            // scratch = S^-1 H_{b,a}; then every pair of ancestors (a, a') with a' above a loses H_{b,a}^T S^-1 H_{b,a'}.
            auto w = scratch_[b].leftCols(e.size_[a]);
            w.noalias() = inverse_[b] * work_[b][i];
            rhs_[a].noalias() -= w.transpose() * rhs_[b];
            for (std::size_t j = i; j < chain.size(); ++j) work_[a][j - i].noalias() -= w.transpose() * work_[b][j];
        }
    }
    // Roots first: each block's step from its ancestors'.
    for (std::size_t b = 0; b < blocks; ++b) {
        if (e.size_[b] == 0) continue;
        Eigen::VectorXd& r = rhs_[b];
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) r.noalias() -= work_[b][i] * step_[static_cast<std::size_t>(chain[i])];
        step_[b].noalias() = inverse_[b] * r;
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l) delta[e.columns_[b][l]] = step_[b][static_cast<Eigen::Index>(l)];
    }
    return delta.allFinite();
}

}  // namespace rig

#include "inversion/block_elimination.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"

namespace rig {
namespace {

// Directions whose curvature is below this fraction of the block's largest are left alone.
constexpr double rankTolerance = 1e-12;

int positionOf(const std::vector<int>& sorted, int value)
{
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), value);
    if (it == sorted.end() || *it != value)
        throw internalError(fmt::format("BlockElimination: index {} is not in the problem", value));
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
        throw internalError("BlockElimination: a column of the problem is in no block");
    // Every column a row moves must be in that row's chain: the partition's promise, checked once. Then
    // J^T J has no entry outside the blocks gathered below.
    for (int c = 0; c < structure.columnCount(); ++c)
        for (const int o : structure.outputsOfColumn(c)) {
            const int owner = blockOfOutput[static_cast<std::size_t>(o)];
            const int block = blockOfColumn_[static_cast<std::size_t>(c)];
            if (owner < 0 || std::find(chain_[static_cast<std::size_t>(owner)].begin(),
                                       chain_[static_cast<std::size_t>(owner)].end(),
                                       block) == chain_[static_cast<std::size_t>(owner)].end())
                throw internalError("BlockElimination: a parameter moves an output outside its block's chain");
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
    : e_(&elimination),
      entries_(static_cast<std::size_t>(elimination.entryCount_), 0.0),
      work_(entries_.size()),
      coupling_(entries_.size()),
      transposed_(entries_.size())
{
    const std::size_t blocks = elimination.size_.size();
    triangular_.assign(blocks, 0);
    const int largest = *std::max_element(elimination.size_.begin(), elimination.size_.end());
    scratch_.assign(static_cast<std::size_t>(largest), 0.0);
    for (std::size_t b = 0; b < blocks; ++b) {
        factor_.emplace_back(elimination.size_[b], elimination.size_[b]);
        llt_.emplace_back(elimination.size_[b]);
        eigen_.emplace_back(elimination.size_[b]);
        rhs_.emplace_back(elimination.size_[b]);
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
    return ConstBlockMap(entries_.data() + e.base_[b][i], e.size_[b],
                         e.size_[static_cast<std::size_t>(e.chain_[b][i])]);
}

BlockEliminationWorkspace::BlockMap BlockEliminationWorkspace::eliminated(std::size_t b, std::size_t i)
{
    const BlockElimination& e = *e_;
    return BlockMap(work_.data() + e.base_[b][i], e.size_[b], e.size_[static_cast<std::size_t>(e.chain_[b][i])]);
}

double* BlockEliminationWorkspace::coupling(std::size_t b, std::size_t i) { return coupling_.data() + e_->base_[b][i]; }

double* BlockEliminationWorkspace::transposed(std::size_t b, std::size_t i)
{
    return transposed_.data() + e_->base_[b][i];
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
    for (const auto& [d, i] : e.coupledBelow_[b])
        block(static_cast<std::size_t>(d), static_cast<std::size_t>(i)).col(l).setZero();
}

void BlockEliminationWorkspace::multiply(const Eigen::Ref<const Eigen::VectorXd>& v,
                                         Eigen::Ref<Eigen::VectorXd> out) const
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
    // S_b^-1 = F^T F with F = L^-1 (S = L L^T), or S^+ = F^T F with F = diag(lambda^-1/2) V^T on the range.
    const BlockMap s = eliminated(b, 0);  // symmetric by construction; only its lower triangle is read
    const Eigen::Index n = s.rows();
    Eigen::LLT<Eigen::MatrixXd>& llt = llt_[b];
    llt.compute(s);
    const double largestDiagonal = s.diagonal().maxCoeff();
    bool wellConditioned = llt.info() == Eigen::Success && largestDiagonal > 0;
    const auto& l = llt.matrixLLT();
    if (wellConditioned)
        for (Eigen::Index i = 0; i < n; ++i)
            if (!(l(i, i) * l(i, i) > rankTolerance * largestDiagonal)) wellConditioned = false;
    triangular_[b] = wellConditioned;
    if (wellConditioned) return l.allFinite();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eigen = eigen_[b];
    eigen.compute(s);
    if (eigen.info() != Eigen::Success) return false;
    const auto& lambda = eigen.eigenvalues();
    const double largest = lambda.cwiseAbs().maxCoeff();
    Eigen::MatrixXd& f = factor_[b];
    for (Eigen::Index i = 0; i < n; ++i)
        f.row(i) = (lambda[i] > rankTolerance * largest ? 1.0 / std::sqrt(lambda[i]) : 0.0) *
                   eigen.eigenvectors().col(i).transpose();
    return f.allFinite();
}

namespace {

// The blocks are a few to a dozen columns: plain loops over contiguous columns cost less than the
// general kernels' dispatch, and updates written as x += s y vectorize where dot products would not.
void axpy(double s, const double* y, double* x, Eigen::Index n)
{
    for (Eigen::Index k = 0; k < n; ++k) x[k] += s * y[k];
}

double dot(const double* x, const double* y, Eigen::Index n)
{
    double sum = 0.0;
    for (Eigen::Index k = 0; k < n; ++k) sum += x[k] * y[k];
    return sum;
}

}  // namespace

void BlockEliminationWorkspace::applyF(std::size_t b, double* x)
{
    const Eigen::Index n = e_->size_[b];
    if (triangular_[b]) {  // x <- L^-1 x, column by column of L
        const Eigen::MatrixXd& l = llt_[b].matrixLLT();
        for (Eigen::Index k = 0; k < n; ++k) {
            x[k] /= l(k, k);
            axpy(-x[k], l.data() + k * n + k + 1, x + k + 1, n - k - 1);
        }
        return;
    }
    double* product = scratch_.data();
    std::fill(product, product + n, 0.0);
    for (Eigen::Index k = 0; k < n; ++k) axpy(x[k], factor_[b].data() + k * n, product, n);
    std::copy(product, product + n, x);
}

void BlockEliminationWorkspace::applyFTransposed(std::size_t b, double* x)
{
    const Eigen::Index n = e_->size_[b];
    if (triangular_[b]) {  // x <- L^-T x
        const Eigen::MatrixXd& l = llt_[b].matrixLLT();
        for (Eigen::Index k = n; k-- > 0;)
            x[k] = (x[k] - dot(l.data() + k * n + k + 1, x + k + 1, n - k - 1)) / l(k, k);
        return;
    }
    double* product = scratch_.data();
    for (Eigen::Index k = 0; k < n; ++k) product[k] = dot(factor_[b].data() + k * n, x, n);
    std::copy(product, product + n, x);
}

bool BlockEliminationWorkspace::solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                      Eigen::Ref<Eigen::VectorXd> delta)
{
    const BlockElimination& e = *e_;
    const std::size_t blocks = e.size_.size();
    std::copy(entries_.begin(), entries_.end(), work_.begin());
    for (std::size_t b = 0; b < blocks; ++b) {
        eliminated(b, 0).diagonal().array() += mu;
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l)
            rhs_[b][static_cast<Eigen::Index>(l)] = -gradient[e.columns_[b][l]];
    }
    // Leaves first (the partition lists parents before children): with S_b^-1 = F^T F, each block's
    // couplings become T_i = F W_{b,a_i}, its right-hand side y = F rhs, and its ancestors lose
    // T_i^T T_j and T_i^T y (the Schur complement).
    for (std::size_t b = blocks; b-- > 0;) {
        const Eigen::Index nb = e.size_[b];
        if (nb == 0) continue;
        if (!factor(b)) return false;
        double* y = rhs_[b].data();  // becomes y
        applyF(b, y);
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const BlockMap w = eliminated(b, i);
            double* t = coupling(b, i);
            double* u = transposed(b, i);
            const Eigen::Index na = w.cols();
            for (Eigen::Index c = 0; c < na; ++c) {
                std::copy(w.data() + c * nb, w.data() + (c + 1) * nb, t + c * nb);
                applyF(b, t + c * nb);
                for (Eigen::Index k = 0; k < nb; ++k) u[k * na + c] = t[c * nb + k];
            }
        }
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain[i]);
            const Eigen::Index na = e.size_[a];
            const double* ui = transposed(b, i);  // T_i^T: its column k is row k of T_i
            for (Eigen::Index k = 0; k < nb; ++k) axpy(-y[k], ui + k * na, rhs_[a].data(), na);
            for (std::size_t j = i; j < chain.size(); ++j) {
                const double* tj = coupling(b, j);
                BlockMap target = eliminated(a, j - i);
                // Column q loses sum_k T_j(k, q) T_i^T(:, k); the ancestor's own block keeps its lower triangle.
                for (Eigen::Index q = 0; q < target.cols(); ++q) {
                    const Eigen::Index from = j == i ? q : 0;
                    for (Eigen::Index k = 0; k < nb; ++k)
                        axpy(-tj[q * nb + k], ui + k * na + from, target.data() + q * na + from, na - from);
                }
            }
        }
    }
    // Roots first: each block's step from its ancestors', F^T (y - sum T_i step_a).
    for (std::size_t b = 0; b < blocks; ++b) {
        const Eigen::Index nb = e.size_[b];
        if (nb == 0) continue;
        double* z = rhs_[b].data();
        const auto& chain = e.chain_[b];
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const Eigen::VectorXd& above = rhs_[static_cast<std::size_t>(chain[i])];  // its step by now
            const double* t = coupling(b, i);
            for (Eigen::Index c = 0; c < above.size(); ++c) axpy(-above[c], t + c * nb, z, nb);
        }
        applyFTransposed(b, z);
        for (std::size_t l = 0; l < e.columns_[b].size(); ++l)
            delta[e.columns_[b][l]] = z[static_cast<Eigen::Index>(l)];
    }
    return delta.allFinite();
}

}  // namespace rig

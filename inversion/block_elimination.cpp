#include "inversion/block_elimination.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
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
    ancestors_.assign(blocks, 0);
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = 1; i < chain_[b].size(); ++i)
            ancestors_[b] += size_[static_cast<std::size_t>(chain_[b][i])];
        square_.push_back(squareCount_);
        coupling_.push_back(couplingCount_);
        squareCount_ += size_[b] * size_[b];
        couplingCount_ += size_[b] * ancestors_[b];
    }
}

BlockEliminationWorkspace::BlockEliminationWorkspace(const BlockElimination& elimination)
    : e_(&elimination),
      entries_(static_cast<std::size_t>(elimination.entryCount_), 0.0),
      work_(entries_.size()),
      squares_(static_cast<std::size_t>(elimination.squareCount_)),
      couplings_(static_cast<std::size_t>(elimination.couplingCount_))
{
    const std::size_t blocks = elimination.size_.size();
    triangular_.assign(blocks, 0);
    const int largest = *std::max_element(elimination.size_.begin(), elimination.size_.end());
    scratch_.assign(static_cast<std::size_t>(largest), 0.0);
    for (std::size_t b = 0; b < blocks; ++b) {
        factor_.emplace_back(elimination.size_[b], elimination.size_[b]);
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

namespace {

// The blocks are a few to a dozen columns: plain loops over contiguous columns cost less than the
// general kernels' dispatch, and updates written as x += s y vectorize where dot products would not.
void axpy(double s, const double* y, double* x, Eigen::Index n)
{
    for (Eigen::Index k = 0; k < n; ++k) x[k] += s * y[k];
}

// x -= s_0 y_0 + s_1 y_1 + ... (s_i = s[i * sStride], y_i = y + i * yStride), term by term in that order as
// successive axpy calls would, but up to four terms per pass: x is loaded and stored a quarter as often.
void subtractMany(const double* s, Eigen::Index sStride, const double* y, Eigen::Index yStride, Eigen::Index count,
                  double* x, Eigen::Index n)
{
    Eigen::Index i = 0;
    for (; i + 4 <= count; i += 4) {
        const double s0 = s[i * sStride], s1 = s[(i + 1) * sStride], s2 = s[(i + 2) * sStride],
                     s3 = s[(i + 3) * sStride];
        const double *y0 = y + i * yStride, *y1 = y0 + yStride, *y2 = y1 + yStride, *y3 = y2 + yStride;
        for (Eigen::Index k = 0; k < n; ++k) x[k] = (((x[k] - s0 * y0[k]) - s1 * y1[k]) - s2 * y2[k]) - s3 * y3[k];
    }
    if (i + 2 <= count) {
        const double s0 = s[i * sStride], s1 = s[(i + 1) * sStride];
        const double *y0 = y + i * yStride, *y1 = y0 + yStride;
        for (Eigen::Index k = 0; k < n; ++k) x[k] = (x[k] - s0 * y0[k]) - s1 * y1[k];
        i += 2;
    }
    if (i < count) {
        const double si = s[i * sStride];
        const double* yi = y + i * yStride;
        for (Eigen::Index k = 0; k < n; ++k) x[k] -= si * yi[k];
    }
}

// Two partial sums, which the compiler can pair in one register (one running sum it could not).
double dot(const double* x, const double* y, Eigen::Index n)
{
    double even = 0.0, odd = 0.0;
    Eigen::Index k = 0;
    for (; k + 1 < n; k += 2) {
        even += x[k] * y[k];
        odd += x[k + 1] * y[k + 1];
    }
    if (k < n) even += x[k] * y[k];
    return even + odd;
}

}  // namespace

bool BlockEliminationWorkspace::factor(std::size_t b, const double* s, double mu)
{
    // S_b^-1 = F^T F with F = L^-1 (S = L L^T), or S^+ = F^T F with F = diag(lambda^-1/2) V^T on the range.
    // S is symmetric by construction; only its lower triangle is read.
    const Eigen::Index n = e_->size_[b];
    double* l = squares_.data() + e_->square_[b];
    std::copy(s, s + n * n, l);
    double largestDiagonal = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) largestDiagonal = std::max(largestDiagonal, l[i * n + i] += mu);
    // Cholesky in place, a column at a time: column j loses its products with the columns before it, then
    // is divided by its pivot's root. A pivot at or below the rank tolerance leaves it to the range. The
    // diagonal keeps 1 / L(j, j): the triangular solves multiply by it.
    bool wellConditioned = largestDiagonal > 0;
    for (Eigen::Index j = 0; wellConditioned && j < n; ++j) {
        double* column = l + j * n;
        subtractMany(l + j, n, l + j, n, j, column + j, n - j);
        if (!(column[j] > rankTolerance * largestDiagonal)) {
            wellConditioned = false;
            break;
        }
        column[j] = 1.0 / std::sqrt(column[j]);
        for (Eigen::Index i = j + 1; i < n; ++i) column[i] *= column[j];
    }
    triangular_[b] = wellConditioned;
    if (wellConditioned) {
        for (Eigen::Index j = 0; j < n; ++j)
            for (Eigen::Index i = j; i < n; ++i)
                if (!std::isfinite(l[j * n + i])) return false;
        return true;
    }
    Eigen::MatrixXd& f = factor_[b];
    f = ConstBlockMap(s, n, n);
    f.diagonal().array() += mu;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>& eigen = eigen_[b];
    eigen.compute(f);
    if (eigen.info() != Eigen::Success) return false;
    const auto& lambda = eigen.eigenvalues();
    const double largest = lambda.cwiseAbs().maxCoeff();
    for (Eigen::Index i = 0; i < n; ++i)
        f.row(i) = (lambda[i] > rankTolerance * largest ? 1.0 / std::sqrt(lambda[i]) : 0.0) *
                   eigen.eigenvectors().col(i).transpose();
    return f.allFinite();
}

void BlockEliminationWorkspace::applyF(std::size_t b, double* x)
{
    const Eigen::Index n = e_->size_[b];
    if (triangular_[b]) {  // x <- L^-1 x, column by column of L
        const double* l = squares_.data() + e_->square_[b];
        for (Eigen::Index k = 0; k < n; ++k) {
            x[k] *= l[k * n + k];
            axpy(-x[k], l + k * n + k + 1, x + k + 1, n - k - 1);
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
        const double* l = squares_.data() + e_->square_[b];
        for (Eigen::Index k = n; k-- > 0;) x[k] = (x[k] - dot(l + k * n + k + 1, x + k + 1, n - k - 1)) * l[k * n + k];
        return;
    }
    double* product = scratch_.data();
    for (Eigen::Index k = 0; k < n; ++k) product[k] = dot(factor_[b].data() + k * n, x, n);
    std::copy(product, product + n, x);
}

void BlockEliminationWorkspace::couplingRows(std::size_t b, const double* w, double* rows)
{
    const Eigen::Index n = e_->size_[b], m = e_->ancestors_[b];
    if (triangular_[b]) {  // forward substitution on whole rows: row k = (w_k - sum_j L(k, j) row j) / L(k, k)
        const double* l = squares_.data() + e_->square_[b];
        for (Eigen::Index k = 0; k < n; ++k) {
            double* row = rows + k * m;
            for (Eigen::Index c = 0; c < m; ++c) row[c] = w[c * n + k];
            subtractMany(l + k, n, rows, m, k, row, m);
            for (Eigen::Index c = 0; c < m; ++c) row[c] *= l[k * n + k];
        }
        return;
    }
    const Eigen::MatrixXd& f = factor_[b];
    for (Eigen::Index r = 0; r < n; ++r) {
        double* row = rows + r * m;
        std::fill(row, row + m, 0.0);
        for (Eigen::Index k = 0; k < n; ++k)
            for (Eigen::Index c = 0; c < m; ++c) row[c] += f(r, k) * w[c * n + k];
    }
}

bool BlockEliminationWorkspace::solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                      Eigen::Ref<Eigen::VectorXd> delta)
{
    const BlockElimination& e = *e_;
    const std::size_t blocks = e.size_.size();
    // Only a parent's panel changes (its children's Schur complements): that copy is damped at once, a
    // leaf's S_b as it is factored.
    for (std::size_t b = 0; b < blocks; ++b) {
        const Eigen::Index nb = e.size_[b];
        if (!e.coupledBelow_[b].empty()) {
            const auto begin = entries_.begin() + e.base_[b][0];
            std::copy(begin, begin + nb * (nb + e.ancestors_[b]), work_.begin() + e.base_[b][0]);
            BlockMap(work_.data() + e.base_[b][0], nb, nb).diagonal().array() += mu;
        }
        for (Eigen::Index l = 0; l < nb; ++l) rhs_[b][l] = -gradient[e.columns_[b][static_cast<std::size_t>(l)]];
    }
    // Leaves first (the partition lists parents before children): with S_b^-1 = F^T F, each block's
    // couplings become T = F W_b (W_b: its rows against all its ancestors' columns), its right-hand side
    // y = F rhs, and each ancestor's panel (its rows against its own and its ancestors' columns, the
    // same columns of T from there on) loses T_a^T T and T_a^T y (the Schur complement).
    for (std::size_t b = blocks; b-- > 0;) {
        const Eigen::Index nb = e.size_[b];
        if (nb == 0) continue;
        const bool parent = !e.coupledBelow_[b].empty();
        const double* panel = (parent ? work_.data() : entries_.data()) + e.base_[b][0];
        if (!factor(b, panel, parent ? 0.0 : mu)) return false;
        double* y = rhs_[b].data();  // becomes y
        applyF(b, y);
        const Eigen::Index m = e.ancestors_[b];
        if (m == 0) continue;
        double* rows = couplings_.data() + e.coupling_[b];
        couplingRows(b, panel + nb * nb, rows);
        const auto& chain = e.chain_[b];
        Eigen::Index offset = 0;  // the ancestor's first column in T
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain[i]);
            const Eigen::Index na = e.size_[a];
            subtractMany(y, 1, rows + offset, m, nb, rhs_[a].data(), na);
            // Column q loses sum_k T(k, q) T(k, its rows); the ancestor's own block keeps its lower triangle.
            double* target = work_.data() + e.base_[a][0];
            for (Eigen::Index q = 0; q < m - offset; ++q) {
                const Eigen::Index from = q < na ? q : 0;
                subtractMany(rows + offset + q, m, rows + offset + from, m, nb, target + q * na + from, na - from);
            }
            offset += na;
        }
    }
    // Roots first: each block's step from its ancestors', F^T (y - T step_ancestors).
    for (std::size_t b = 0; b < blocks; ++b) {
        const Eigen::Index nb = e.size_[b];
        if (nb == 0) continue;
        double* z = rhs_[b].data();
        const Eigen::Index m = e.ancestors_[b];
        const double* rows = couplings_.data() + e.coupling_[b];
        const auto& chain = e.chain_[b];
        Eigen::Index offset = 0;
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const Eigen::VectorXd& above = rhs_[static_cast<std::size_t>(chain[i])];  // its step by now
            for (Eigen::Index c = 0; c < above.size(); ++c)
                for (Eigen::Index k = 0; k < nb; ++k) z[k] -= above[c] * rows[k * m + offset + c];
            offset += above.size();
        }
        applyFTransposed(b, z);
        for (Eigen::Index l = 0; l < nb; ++l) delta[e.columns_[b][static_cast<std::size_t>(l)]] = z[l];
    }
    return delta.allFinite();
}

}  // namespace rig

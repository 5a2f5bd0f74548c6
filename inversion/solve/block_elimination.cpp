#include "inversion/solve/block_elimination.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <numeric>

#include <Eigen/Cholesky>

#include "core/error.h"
#include "core/prefetch.h"
#include "inversion/solve/range_factor.h"

namespace rig {
namespace {

int positionOf(const std::vector<int>& sorted, int value)
{
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), value);
    if (it == sorted.end() || *it != value)
        throw internalError(fmt::format("BlockElimination: index {} is not in the problem", value));
    return static_cast<int>(it - sorted.begin());
}

}  // namespace

BlockElimination::BlockElimination(const Partition& partition, const ResidualStructure& structure, bool twists)
{
    build(partition, structure, twists);
    if (!folded_) return;
    Partition finer;
    std::vector<int> group;
    if (!splitLongBlocks(partition, structure, finer, group)) return;
    BlockElimination recursive(finer, structure, true);
    if (!recursive.folded_) return;
    auto whole = std::make_unique<BlockElimination>(std::move(*this));
    *this = std::move(recursive);
    whole_ = std::move(whole);
    groupOf_ = std::move(group);
}

void BlockElimination::build(const Partition& partition, const ResidualStructure& structure, bool twists)
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
    folded_ = twists && structure.twistForm() && planFold(partition, structure);
    const int n = structure.columnCount();
    layout_.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(n), -1);
    base_.resize(blocks);
    coupledBelow_.resize(blocks);
    for (std::size_t b = 0; b < blocks; ++b)
        for (std::size_t i = 0; i < (folded_ ? 1 : chain_[b].size()); ++i) {
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
    diagonal_.resize(blockOfColumn_.size());
    for (std::size_t c = 0; c < diagonal_.size(); ++c) {
        const std::size_t b = static_cast<std::size_t>(blockOfColumn_[c]);
        diagonal_[c] = base_[b][0] + localOfColumn_[c] * (size_[b] + 1);
    }
    ancestors_.assign(blocks, 0);
    for (std::size_t b = 0; b < blocks; ++b) {
        for (std::size_t i = 1; i < chain_[b].size(); ++i)
            ancestors_[b] += size_[static_cast<std::size_t>(chain_[b][i])];
        square_.push_back(squareCount_);
        coupling_.push_back(couplingCount_);
        squareCount_ += size_[b] * size_[b];
        couplingCount_ += size_[b] * (folded_ ? 6 : ancestors_[b]);
    }
    if (!folded_) return;
    heldBase_ = entryCount_;
    entryCount_ += n;
    for (int& entry : pairEntry_) entry = layout_[static_cast<std::size_t>(entry)];
}

bool BlockElimination::splitLongBlocks(const Partition& partition, const ResidualStructure& s, Partition& finer,
                                       std::vector<int>& group) const
{
    // A long block whose columns each have one unknown node becomes a block per column, below the block of its
    // node's unknown parent (or, at its top, of its attach node): the fold then runs node by node.
    std::vector<int> nodeOf(blockOfColumn_.size(), -1), count(blockOfColumn_.size(), 0);
    for (std::size_t k = 0; k < s.unknownNodes_.size(); ++k) {
        const std::size_t c = static_cast<std::size_t>(s.unknownColumn_[k]);
        ++count[c];
        nodeOf[c] = s.unknownNodes_[k];
    }
    std::vector<int> columnOfNode(s.nodes_.size(), -1);
    for (std::size_t k = 0; k < s.unknownNodes_.size(); ++k)
        columnOfNode[static_cast<std::size_t>(s.unknownNodes_[k])] = s.unknownColumn_[k];
    std::vector<char> split(size_.size(), 0);
    for (std::size_t b = 0; b < size_.size(); ++b)
        split[b] = size_[b] > recursiveAbove && std::all_of(columns_[b].begin(), columns_[b].end(), [&](int c) {
                       return count[static_cast<std::size_t>(c)] == 1;
                   });
    if (std::find(split.begin(), split.end(), 1) == split.end()) return false;
    std::vector<int> blockOf(blockOfColumn_.size(), -1), depth;
    const auto add = [&](std::vector<int> parameters, int parent, int g) {
        const int index = static_cast<int>(finer.blocks.size());
        if (parent >= 0) finer.blocks[static_cast<std::size_t>(parent)].children.push_back(index);
        else finer.roots.push_back(index);
        finer.blocks.push_back({std::move(parameters), {}, parent, {}});
        depth.push_back(parent < 0 ? 0 : depth[static_cast<std::size_t>(parent)] + 1);
        group.push_back(g);
        return index;
    };
    int groups = 0;
    for (std::size_t b = 0; b < size_.size(); ++b) {
        if (!split[b]) {  // kept whole, below the block of its attach node
            const int attach = attach_[b] < 0 ? -1 : nodeColumn_[static_cast<std::size_t>(attach_[b])];
            const int index =
                add(partition.blocks[b].parameters, attach < 0 ? -1 : blockOf[static_cast<std::size_t>(attach)], -1);
            for (const int c : columns_[b]) blockOf[static_cast<std::size_t>(c)] = index;
            continue;
        }
        std::vector<int> columns = columns_[b];  // parents first: in the structure's order of their nodes
        std::sort(columns.begin(), columns.end(), [&](int x, int y) {
            return nodeOf[static_cast<std::size_t>(x)] < nodeOf[static_cast<std::size_t>(y)];
        });
        for (const int c : columns) {
            const int up = s.unknownUp_[static_cast<std::size_t>(nodeOf[static_cast<std::size_t>(c)])];
            const int parent =
                up < 0 ? -1 : blockOf[static_cast<std::size_t>(columnOfNode[static_cast<std::size_t>(up)])];
            if (up >= 0 && parent < 0) return false;
            blockOf[static_cast<std::size_t>(c)] = add({s.columns()[static_cast<std::size_t>(c)]}, parent, groups);
        }
        ++groups;
    }
    // Each output to the deepest block that moves it (the others are in that block's chain, which the build checks).
    std::vector<int> owner(s.outputs().size(), -1);
    for (std::size_t c = 0; c < blockOf.size(); ++c)
        for (const int o : s.outputsOfColumn(static_cast<int>(c))) {
            int& own = owner[static_cast<std::size_t>(o)];
            const int block = blockOf[c];
            if (own < 0 || depth[static_cast<std::size_t>(block)] > depth[static_cast<std::size_t>(own)]) own = block;
        }
    for (std::size_t o = 0; o < owner.size(); ++o)
        if (owner[o] >= 0) finer.blocks[static_cast<std::size_t>(owner[o])].outputs.push_back(s.outputs()[o]);
    return true;
}

bool BlockElimination::planFold(const Partition& partition, const ResidualStructure& s)
{
    const std::size_t blocks = size_.size();
    const auto& unknown = s.unknownNodes_;
    std::vector<int> position(s.nodes_.size(), -1);  // node id -> its index in unknown
    for (std::size_t k = 0; k < unknown.size(); ++k)
        position[static_cast<std::size_t>(unknown[k])] = static_cast<int>(k);
    const auto blockOfNode = [&](int node) {
        return blockOfColumn_[static_cast<std::size_t>(s.unknownColumn_[static_cast<std::size_t>(node)])];
    };
    std::vector<std::vector<int>> ofBlock(blocks);  // per block: its unknown nodes' indices, parents first
    for (std::size_t k = 0; k < unknown.size(); ++k)
        ofBlock[static_cast<std::size_t>(blockOfNode(static_cast<int>(k)))].push_back(static_cast<int>(k));
    std::vector<int> flatOf(unknown.size(), -1);
    nodeBegin_.assign(1, 0);
    for (std::size_t b = 0; b < blocks; ++b) {
        if (ofBlock[b].empty()) return false;
        for (const int k : ofBlock[b]) {
            flatOf[static_cast<std::size_t>(k)] = static_cast<int>(nodeId_.size());
            nodeId_.push_back(unknown[static_cast<std::size_t>(k)]);
            nodeColumn_.push_back(s.unknownColumn_[static_cast<std::size_t>(k)]);
        }
        nodeBegin_.push_back(static_cast<int>(nodeId_.size()));
    }
    // Each block's nodes leave it (going up) at one node, of its parent's; a root's at none.
    attach_.assign(blocks, -2);
    children_.assign(blocks, {});
    nodeUp_.assign(nodeId_.size(), -1);
    for (std::size_t b = 0; b < blocks; ++b) {
        for (int i = nodeBegin_[b]; i < nodeBegin_[b + 1]; ++i) {
            const int up = s.unknownUp_[static_cast<std::size_t>(nodeId_[static_cast<std::size_t>(i)])];
            const int k = up < 0 ? -1 : position[static_cast<std::size_t>(up)];
            nodeUp_[static_cast<std::size_t>(i)] = k < 0 ? -1 : flatOf[static_cast<std::size_t>(k)];
            if (k >= 0 && blockOfNode(k) == static_cast<int>(b)) continue;
            if (attach_[b] == -2) attach_[b] = nodeUp_[static_cast<std::size_t>(i)];
            else if (attach_[b] != nodeUp_[static_cast<std::size_t>(i)]) return false;
        }
        const int parent = partition.blocks[b].parent;
        if (parent < 0) {
            if (attach_[b] != -1) return false;
            continue;
        }
        if (attach_[b] < 0 ||
            blockOfColumn_[static_cast<std::size_t>(nodeColumn_[static_cast<std::size_t>(attach_[b])])] != parent)
            return false;
        children_[static_cast<std::size_t>(parent)].push_back(static_cast<int>(b));
    }
    // Each node's pairs within its block: the first of the structure's (itself, then up).
    pairBegin_.clear();
    for (std::size_t b = 0; b < blocks; ++b)
        for (int i = nodeBegin_[b]; i < nodeBegin_[b + 1]; ++i) {
            pairBegin_.push_back(static_cast<int>(pairOther_.size()));
            const std::size_t k =
                static_cast<std::size_t>(position[static_cast<std::size_t>(nodeId_[static_cast<std::size_t>(i)])]);
            for (int p = s.pairBegin_[k]; p < s.pairBegin_[k + 1]; ++p) {
                const int other = position[static_cast<std::size_t>(s.pairNode_[static_cast<std::size_t>(p)])];
                if (blockOfNode(other) != static_cast<int>(b)) break;
                pairOther_.push_back(flatOf[static_cast<std::size_t>(other)]);
                pairEntry_.push_back(s.pairOffset_[static_cast<std::size_t>(p)]);  // the layout's entry, later
                pairFactor_.push_back(s.pairFactor_[static_cast<std::size_t>(p)]);
            }
        }
    pairBegin_.push_back(static_cast<int>(pairOther_.size()));
    return true;
}

BlockEliminationWorkspace::BlockEliminationWorkspace(const BlockElimination& elimination,
                                                     const ResidualWorkspace* twists)
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
    pivoted_.resize(largest, largest);
    rank_.assign(blocks, 0);
    nullRows_.resize(largest, largest);
    nullSolved_.resize(largest, largest);
    rangeRows_.assign(static_cast<std::size_t>(largest) * static_cast<std::size_t>(largest), 0.0);
    nullSquare_.resize(largest, largest);
    pivotInverse_.assign(static_cast<std::size_t>(largest), 0.0);
    nullInverse_.assign(static_cast<std::size_t>(largest), 0.0);
    permutation_.assign(static_cast<std::size_t>(largest), 0);
    for (std::size_t b = 0; b < blocks; ++b) {
        factor_.emplace_back(elimination.size_[b], elimination.size_[b]);
        rhs_.emplace_back(elimination.size_[b]);
    }
    if (!elimination.folded_) return;
    if (!twists) throw internalError("BlockEliminationWorkspace: a folded elimination reads a ResidualWorkspace");
    twists_ = twists;
    const std::size_t nodes = elimination.nodeId_.size();
    foldWeight_.assign(nodes, Matrix6::Zero());
    foldLoad_.assign(nodes, Vector6::Zero());
    foldWeightOf_.assign(nodes, nullptr);
    foldLoadOf_.assign(nodes, nullptr);
    foldProduct_.assign(nodes, Vector6::Zero());
    motion_.assign(nodes, Vector6::Zero());
    force_.assign(nodes, Vector6::Zero());
    folded_.assign(nodes, 0);
    blockWeight_.assign(blocks, Matrix6::Zero());
    blockLoad_.assign(blocks, Vector6::Zero());
    foldCoupling_.assign(static_cast<std::size_t>(6 * largest), 0.0);
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
    return entries_[static_cast<std::size_t>(e_->diagonal_[static_cast<std::size_t>(column)])];
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
    if (e.folded_) {  // its couplings are formed in the solve, which reads the marker
        entries_[static_cast<std::size_t>(e.heldBase_ + column)] = 1.0;
        return;
    }
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
        for (std::size_t i = 0; i < e.base_[b].size(); ++i) {
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
    if (e.folded_) multiplyFolded(v, out);
}

void BlockEliminationWorkspace::multiplyFolded(const Eigen::Ref<const Eigen::VectorXd>& v,
                                               Eigen::Ref<Eigen::VectorXd> out) const
{
    // The couplings between blocks: a block's columns against its ancestors' move the outputs below its
    // attach node by that node's motion (sum of t v above it); they push back on the ancestors' nodes above
    // with W t v (the force, summed up the tree).
    const BlockElimination& e = *e_;
    const ResidualWorkspace& rw = *twists_;
    const std::size_t blocks = e.size_.size();
    for (std::size_t b = 0; b < blocks; ++b)
        for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) {
            const std::size_t f = static_cast<std::size_t>(i);
            const int up = e.nodeUp_[f], column = e.nodeColumn_[f];
            if (up >= 0) motion_[f] = motion_[static_cast<std::size_t>(up)];
            else motion_[f].setZero();
            if (!held(column)) motion_[f] += rw.twist(e.nodeId_[f]) * v[column];
            force_[f].setZero();
        }
    for (std::size_t b = blocks; b-- > 0;) {
        for (int i = e.nodeBegin_[b + 1]; i-- > e.nodeBegin_[b];) {
            const std::size_t f = static_cast<std::size_t>(i);
            const int up = e.nodeUp_[f], column = e.nodeColumn_[f];
            if (!held(column)) out[column] += rw.twist(e.nodeId_[f]).dot(force_[f]);
            if (up >= 0) force_[static_cast<std::size_t>(up)] += force_[f];
        }
        const int attach = e.attach_[b];
        if (attach < 0) continue;
        const std::size_t a = static_cast<std::size_t>(attach);
        for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) {
            const std::size_t f = static_cast<std::size_t>(i);
            const int column = e.nodeColumn_[f];
            if (held(column)) continue;
            const Vector6& u = rw.weighted(e.nodeId_[f]);
            out[column] += u.dot(motion_[a]);
            force_[a] += u * v[column];
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
    // S_b^-1 = F^T F with F = L^-1 (S = L L^T), or S^+ = F^T F on the range (rangeFactor). S is symmetric by
    // construction; only its lower triangle is read.
    const Eigen::Index n = e_->size_[b];
    double* l = squares_.data() + e_->square_[b];
    std::copy(s, s + n * n, l);
    double largestDiagonal = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) largestDiagonal = std::max(largestDiagonal, l[i * n + i] += mu);
    // Pivots are judged against the whole system's scale, as the dense factor's are: against the block's own, a
    // redundant foot's null direction (a foot control's rotation against its heel and toe rolls, moved alike by its
    // translation) kept its rounding, 1e-13 of the whole, as a curvature, and Gauss-Newton took half a turn along it.
    const double scale = std::max(largestDiagonal, wholeScale_);
    // Cholesky in place, a column at a time: column j loses its products with the columns before it, then
    // is divided by its pivot's root. A pivot at or below the rank tolerance leaves it to the range. The
    // diagonal keeps 1 / L(j, j): the triangular solves multiply by it.
    bool wellConditioned = largestDiagonal > 0;
    for (Eigen::Index j = 0; wellConditioned && j < n; ++j) {
        double* column = l + j * n;
        subtractMany(l + j, n, l + j, n, j, column + j, n - j);
        if (!(column[j] > rankTolerance * scale)) {
            wellConditioned = false;
            break;
        }
        column[j] = 1.0 / std::sqrt(column[j]);
        for (Eigen::Index i = j + 1; i < n; ++i) column[i] *= column[j];
    }
    triangular_[b] = wellConditioned;
    rank_[b] = n;
    if (wellConditioned) {
        for (Eigen::Index j = 0; j < n; ++j)
            for (Eigen::Index i = j; i < n; ++i)
                if (!std::isfinite(l[j * n + i])) return false;
        return true;
    }
    return rangeFactor(b, s, mu, scale);
}

bool BlockEliminationWorkspace::rangeFactor(std::size_t b, const double* s, double mu, double scale)
{
    // S^+ = F^T F on S's range (range_factor.h): F = G^-1 R, its last n - r rows zero. With L = [L1; L2] (L1 the
    // rank's triangle) and M = L2 L1^-1, G = L1^T (I + M^T M) L1, so G^-1 L^T = L1^-1 (I + M^T M)^-1 [I | M^T], which
    // Woodbury's identity makes L1^-1 [I - M^T Q | Q^T] with Q = (I + M M^T)^-1 M: triangular solves and a factor
    // of the null space's size, not G formed and factored.
    const Eigen::Index n = e_->size_[b];
    auto a = pivoted_.topLeftCorner(n, n);
    a = ConstBlockMap(s, n, n).selfadjointView<Eigen::Lower>();
    a.diagonal().array() += mu;
    const Eigen::Index rank = pivotedCholesky(a, permutation_, rankTolerance * scale);
    rank_[b] = rank;
    Eigen::MatrixXd& f = factor_[b];
    f.setZero();
    if (rank == 0) return true;
    // Plain loops: the blocks are small (a leg's 16 columns, of rank 9 or 10: its pole's and its foot
    // pivots' redundant directions), where Eigen's blocked triangular solves cost more in set-up than in arithmetic.
    // DenseSystem::rangeStep takes the same identity with them, for one large block (C_Robot_Rig's 102 columns).
    const Eigen::Index k = n - rank, ld = pivoted_.outerStride();
    const double* l = pivoted_.data();  // L(i, j) at l[i + j * ld]
    double* m = nullRows_.data();       // M, k x rank, column-major: M(p, j) at m[p + j * k]
    // L1's diagonal inverted once: the solves below multiply by it (a division costs many multiplications).
    double* inverse = pivotInverse_.data();
    for (Eigen::Index j = 0; j < rank; ++j) inverse[j] = 1.0 / l[j + j * ld];
    for (Eigen::Index j = rank; j-- > 0;) {  // M L1 = L2, L1's columns from the last
        double* mj = m + j * k;
        for (Eigen::Index p = 0; p < k; ++p) mj[p] = l[rank + p + j * ld];
        subtractMany(l + j + 1 + j * ld, 1, m + (j + 1) * k, k, rank - j - 1, mj, k);
        for (Eigen::Index p = 0; p < k; ++p) mj[p] *= inverse[j];
    }
    double* q = nullSolved_.data();  // Q, as M
    if (k > 0 && !solveNullSquare(m, k, rank, q)) return false;
    // F's first rank rows before the permutation, X = L1^-1 [I - M^T Q | Q^T], by forward substitution on whole rows:
    // row c loses L1(c, j) times each row j before it, then is scaled by 1 / L1(c, c). Passes n wide, four rows at a
    // time, where a column at a time took a short axpy per pivot (callgrind: the leg blocks' range factors were 15% of
    // the random characters' IK clip solves).
    double* x = rangeRows_.data();  // X(c, i) at x[c * n + i]
    for (Eigen::Index c = 0; c < rank; ++c) {
        double* row = x + c * n;
        for (Eigen::Index i = 0; i < rank; ++i) row[i] = (c == i ? 1.0 : 0.0) - dot(m + c * k, q + i * k, k);
        for (Eigen::Index i = rank; i < n; ++i) row[i] = q[i - rank + c * k];
        subtractMany(l + c, ld, x, n, c, row, n);
        for (Eigen::Index i = 0; i < n; ++i) row[i] *= inverse[c];
    }
    bool finite = true;
    for (Eigen::Index i = 0; i < n; ++i) {
        double* column = f.col(permutation_[static_cast<std::size_t>(i)]).data();
        for (Eigen::Index c = 0; c < rank; ++c) {
            column[c] = x[c * n + i];
            finite = finite && std::isfinite(column[c]);
        }
    }
    return finite;
}

bool BlockEliminationWorkspace::solveNullSquare(const double* m, Eigen::Index k, Eigen::Index r, double* q)
{
    // Q = C^-1 M with C = I + M M^T (k x k, k the nullity), by its Cholesky factor; M and Q k x r, column-major.
    double* c = nullSquare_.data();  // C(i, j) at c[i + j * k], lower triangle
    for (Eigen::Index j = 0; j < k; ++j)
        for (Eigen::Index i = j; i < k; ++i) c[i + j * k] = i == j ? 1.0 : 0.0;
    for (Eigen::Index col = 0; col < r; ++col) {
        const double* mc = m + col * k;
        for (Eigen::Index j = 0; j < k; ++j) axpy(mc[j], mc + j, c + j + j * k, k - j);
    }
    double* inverse = nullInverse_.data();  // 1 / N(j, j): the solves multiply by it
    for (Eigen::Index j = 0; j < k; ++j) {
        double* cj = c + j * k;
        for (Eigen::Index l = 0; l < j; ++l) axpy(-c[j + l * k], c + j + l * k, cj + j, k - j);
        if (!(cj[j] > 0.0)) return false;
        cj[j] = std::sqrt(cj[j]);
        inverse[j] = 1.0 / cj[j];
        for (Eigen::Index i = j + 1; i < k; ++i) cj[i] *= inverse[j];
    }
    for (Eigen::Index col = 0; col < r; ++col) {
        double* x = q + col * k;
        std::copy(m + col * k, m + (col + 1) * k, x);
        for (Eigen::Index i = 0; i < k; ++i) {  // C = N N^T: N^-1, then N^-T
            x[i] *= inverse[i];
            axpy(-x[i], c + i + 1 + i * k, x + i + 1, k - i - 1);
        }
        for (Eigen::Index i = k; i-- > 0;) x[i] = (x[i] - dot(c + i + 1 + i * k, x + i + 1, k - i - 1)) * inverse[i];
    }
    return true;
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
    // F's rows past its rank are zero.
    const Eigen::Index rank = rank_[b];
    double* product = scratch_.data();
    std::fill(product, product + n, 0.0);
    for (Eigen::Index k = 0; k < n; ++k) axpy(x[k], factor_[b].data() + k * n, product, rank);
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
    for (Eigen::Index k = 0; k < n; ++k) product[k] = dot(factor_[b].data() + k * n, x, rank_[b]);
    std::copy(product, product + n, x);
}

void BlockEliminationWorkspace::couplingRows(std::size_t b, const double* w, Eigen::Index m, double* rows)
{
    const Eigen::Index n = e_->size_[b];
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
    // F's rows past its rank are zero, and so are T's.
    const Eigen::Index rank = rank_[b];
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> t(rows, n, m);
    t.topRows(rank).noalias() = factor_[b].topRows(rank).lazyProduct(ConstBlockMap(w, n, m));
    t.bottomRows(n - rank).setZero();
}

void BlockEliminationWorkspace::prefetch() const
{
    rig::prefetch(entries_);
    rig::prefetch(work_);
    for (const Eigen::VectorXd& v : rhs_) prefetchBytes(v.data(), static_cast<std::size_t>(v.size()) * sizeof(double));
    rig::prefetch(squares_);
    rig::prefetch(couplings_);
    rig::prefetch(foldLoad_);
    rig::prefetch(foldProduct_);
    rig::prefetch(motion_);
    rig::prefetch(blockWeight_);
    rig::prefetch(blockLoad_);
    rig::prefetch(folded_);
    rig::prefetch(foldWeightOf_);
    rig::prefetch(foldLoadOf_);
    rig::prefetch(foldCoupling_);
    rig::prefetch(e_->nodeBegin_);
    rig::prefetch(e_->attach_);
    rig::prefetch(e_->localOfColumn_);
    rig::prefetch(e_->diagonal_);
    for (const auto& columns : e_->columns_) rig::prefetch(columns);
    for (const auto& base : e_->base_) rig::prefetch(base);
    for (const auto& children : e_->children_) rig::prefetch(children);
    rig::prefetch(e_->nodeId_);
    rig::prefetch(e_->nodeColumn_);
    rig::prefetch(e_->nodeUp_);
    rig::prefetch(e_->pairOther_);
    rig::prefetch(e_->pairEntry_);
    rig::prefetch(e_->pairFactor_);
}

bool BlockEliminationWorkspace::solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                      Eigen::Ref<Eigen::VectorXd> delta, std::span<const char> fixed)
{
    wholeScale_ = 0.0;
    for (std::size_t c = 0; c < e_->diagonal_.size(); ++c) {
        const bool free = !(c < fixed.size() && fixed[c]) && !held(static_cast<int>(c));
        if (free) wholeScale_ = std::max(wholeScale_, diagonal(static_cast<int>(c)));
    }
    wholeScale_ += mu;
    if (e_->folded_) return solveFolded(gradient, mu, delta);
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
        couplingRows(b, panel + nb * nb, m, rows);
        const auto& chain = e.chain_[b];
        const Eigen::Index rank = rank_[b];  // T's and y's rows past it are zero
        Eigen::Index offset = 0;             // the ancestor's first column in T
        for (std::size_t i = 1; i < chain.size(); ++i) {
            const std::size_t a = static_cast<std::size_t>(chain[i]);
            const Eigen::Index na = e.size_[a];
            subtractMany(y, 1, rows + offset, m, rank, rhs_[a].data(), na);
            // Column q loses sum_k T(k, q) T(k, its rows); the ancestor's own block keeps its lower triangle.
            double* target = work_.data() + e.base_[a][0];
            for (Eigen::Index q = 0; q < m - offset; ++q) {
                const Eigen::Index from = q < na ? q : 0;
                subtractMany(rows + offset + q, m, rows + offset + from, m, rank, target + q * na + from, na - from);
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
                for (Eigen::Index k = 0; k < rank_[b]; ++k) z[k] -= above[c] * rows[k * m + offset + c];
            offset += above.size();
        }
        applyFTransposed(b, z);
        for (Eigen::Index l = 0; l < nb; ++l) delta[e.columns_[b][static_cast<std::size_t>(l)]] = z[l];
    }
    return delta.allFinite();
}

bool BlockEliminationWorkspace::solveFolded(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                            Eigen::Ref<Eigen::VectorXd> delta)
{
    const BlockElimination& e = *e_;
    const std::size_t blocks = e.size_.size();
    for (std::size_t b = 0; b < blocks; ++b)
        for (Eigen::Index l = 0; l < e.size_[b]; ++l)
            rhs_[b][l] = -gradient[e.columns_[b][static_cast<std::size_t>(l)]];
    // Leaves first. A block's children have left, at their attach nodes (its nodes), what eliminating them
    // takes off J^T J and the right-hand side in twist space: K = W^T S^-1 W (6x6) and W^T S^-1 rhs (W: the
    // child's couplings with the attach node's motion), and theirs below. Summed up its nodes (Fold), they
    // change its own pairs by t_i^T Fold_j t_j, its right-hand side by t^T (Fold's load) and its couplings
    // with its own attach node by Fold t. Its S_b^-1 = F^T F, T = F W^T and y = F rhs then leave
    // T^T T and T^T y (plus its children's) at its attach node.
    for (std::size_t b = blocks; b-- > 0;) {
        const int group = e.groupOf_.empty() ? -1 : e.groupOf_[b];
        // A split block's pivot left out: its matrix is singular here, and its step is the minimum-norm one.
        if (group >= 0) {
            // Its pivots judged against the whole system's scale, as every block's and the dense factor's are.
            if (!eliminateNode(b, mu, wholeScale_)) return solveWhole(gradient, mu, delta);
            continue;
        }
        double* y = rhs_[b].data();
        for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) folded_[static_cast<std::size_t>(i)] = 0;
        const double* panel = entries_.data() + e.base_[b][0];
        if (!e.children_[b].empty()) {
            gatherFolds(b);
            panel = foldedPanel(b, y);
        }
        if (!factor(b, panel, mu)) return false;
        applyF(b, y);
        if (e.attach_[b] >= 0) foldIntoAttach(b, y);
    }
    // Roots first: each block's step F^T (y - T V), V its attach node's motion (the steps above it), and
    // its nodes' motions for its children.
    for (std::size_t b = 0; b < blocks; ++b) substituteFolded(b, delta);
    return delta.allFinite();
}

bool BlockEliminationWorkspace::eliminateNode(std::size_t b, double mu, double scale)
{
    // foldedPanel, factor, applyF and foldIntoAttach for a block of one column on one node, in their order of
    // operations (the same numbers), without their loops over a block's columns, pairs and chain.
    const BlockElimination& e = *e_;
    const ResidualWorkspace& rw = *twists_;
    const std::size_t f = static_cast<std::size_t>(e.nodeBegin_[b]);
    const int node = e.nodeId_[f];
    double& y = rhs_[b][0];
    double s = entries_[static_cast<std::size_t>(e.base_[b][0])];
    folded_[f] = 0;
    if (!e.children_[b].empty()) gatherFolds(b);
    const Vector6& t = rw.twist(node);
    Vector6 c = rw.weighted(node);
    const bool still = held(e.columns_[b][0]);
    if (still) {  // an identity row and column, no right-hand side, no coupling
        s = 1.0;
        y = 0.0;
        c.setZero();
    } else if (folded_[f]) {
        foldProduct_[f].noalias() = *foldWeightOf_[f] * t;
        y -= t.dot(*foldLoadOf_[f]);
        s -= t.dot(foldProduct_[f]);
        c -= foldProduct_[f];
    }
    s += mu;
    const bool regular = s > rankTolerance * std::max(s, scale);
    if (!regular && !still) return false;
    const double inverse = regular ? 1.0 / std::sqrt(s) : 0.0;  // F, L^-1 of the 1x1
    squares_[static_cast<std::size_t>(e.square_[b])] = inverse;
    triangular_[b] = 1;
    rank_[b] = 1;
    y *= inverse;
    if (e.attach_[b] < 0) return true;
    Eigen::Map<Vector6> row(couplings_.data() + e.coupling_[b]);
    row = c * inverse;
    Matrix6& k = blockWeight_[b];
    k.noalias() = row * row.transpose();
    blockLoad_[b] = y * row;
    for (const int child : e.children_[b]) {
        k += blockWeight_[static_cast<std::size_t>(child)];
        blockLoad_[b] += blockLoad_[static_cast<std::size_t>(child)];
    }
    return true;
}

bool BlockEliminationWorkspace::solveWhole(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu,
                                           Eigen::Ref<Eigen::VectorXd> delta)
{
    // The blocks as the partition gave them, J^T J within each from the twists as the normal equations form it,
    // the held columns held again. Made on the first such step: a chain's targets that determine it never need it.
    const BlockElimination& whole = *e_->whole_;
    if (!whole_) whole_ = std::make_unique<BlockEliminationWorkspace>(whole, twists_);
    const ResidualWorkspace& rw = *twists_;
    std::vector<double>& entries = whole_->entries_;
    std::fill(entries.begin(), entries.end(), 0.0);
    for (std::size_t f = 0; f < whole.nodeId_.size(); ++f) {
        const auto& u = rw.weighted(whole.nodeId_[f]);
        for (int p = whole.pairBegin_[f]; p < whole.pairBegin_[f + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            entries[static_cast<std::size_t>(whole.pairEntry_[q])] +=
                whole.pairFactor_[q] * rw.twist(whole.nodeId_[static_cast<std::size_t>(whole.pairOther_[q])]).dot(u);
        }
    }
    for (int c = 0; c < static_cast<int>(e_->blockOfColumn_.size()); ++c)
        if (held(c)) whole_->hold(c);
    return whole_->solve(gradient, mu, delta);
}

void BlockEliminationWorkspace::addFold(std::size_t i, const Matrix6* weight, const Vector6* load)
{
    // A node's fold is its one source's (a child's, or the node's below) until a second one adds to it: along a
    // chain the 6x6 is pointed at, not copied node after node.
    if (!folded_[i]) {
        foldWeightOf_[i] = weight;
        foldLoadOf_[i] = load;
        folded_[i] = 1;
    } else if (foldWeightOf_[i] == &foldWeight_[i]) {
        foldWeight_[i] += *weight;
        foldLoad_[i] += *load;
    } else {
        foldWeight_[i] = *foldWeightOf_[i] + *weight;
        foldLoad_[i] = *foldLoadOf_[i] + *load;
        foldWeightOf_[i] = &foldWeight_[i];
        foldLoadOf_[i] = &foldLoad_[i];
    }
}

void BlockEliminationWorkspace::gatherFolds(std::size_t b)
{
    const BlockElimination& e = *e_;
    const int begin = e.nodeBegin_[b], end = e.nodeBegin_[b + 1];
    for (const int c : e.children_[b]) {
        const std::size_t i = static_cast<std::size_t>(e.attach_[static_cast<std::size_t>(c)]);
        addFold(i, &blockWeight_[static_cast<std::size_t>(c)], &blockLoad_[static_cast<std::size_t>(c)]);
    }
    for (int i = end; i-- > begin;) {
        const std::size_t f = static_cast<std::size_t>(i);
        const int up = e.nodeUp_[f];
        if (!folded_[f] || up < begin) continue;  // up < begin: none, or the attach node
        addFold(static_cast<std::size_t>(up), foldWeightOf_[f], foldLoadOf_[f]);
    }
}

const double* BlockEliminationWorkspace::foldedPanel(std::size_t b, double* y)
{
    const BlockElimination& e = *e_;
    const ResidualWorkspace& rw = *twists_;
    const Eigen::Index nb = e.size_[b];
    const int base = e.base_[b][0];
    double* s = work_.data() + base;
    std::copy(entries_.data() + base, entries_.data() + base + nb * nb, s);
    for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) {
        const std::size_t f = static_cast<std::size_t>(i);
        if (!folded_[f]) continue;
        const Vector6& t = rw.twist(e.nodeId_[f]);
        foldProduct_[f].noalias() = *foldWeightOf_[f] * t;
        y[e.localOfColumn_[static_cast<std::size_t>(e.nodeColumn_[f])]] -= t.dot(*foldLoadOf_[f]);
        for (int p = e.pairBegin_[f]; p < e.pairBegin_[f + 1]; ++p) {
            const std::size_t q = static_cast<std::size_t>(p);
            s[e.pairEntry_[q] - base] -=
                e.pairFactor_[q] * rw.twist(e.nodeId_[static_cast<std::size_t>(e.pairOther_[q])]).dot(foldProduct_[f]);
        }
    }
    // Held columns stay identity rows and columns with no right-hand side.
    for (Eigen::Index l = 0; l < nb; ++l) {
        if (!held(e.columns_[b][static_cast<std::size_t>(l)])) continue;
        for (Eigen::Index j = 0; j < l; ++j) s[j * nb + l] = 0.0;
        for (Eigen::Index i = l + 1; i < nb; ++i) s[l * nb + i] = 0.0;
        s[l * nb + l] = 1.0;
        y[l] = 0.0;
    }
    return s;
}

void BlockEliminationWorkspace::foldIntoAttach(std::size_t b, const double* y)
{
    const BlockElimination& e = *e_;
    const ResidualWorkspace& rw = *twists_;
    const Eigen::Index nb = e.size_[b];
    // W^T: a row per block column, a column per component of the attach node's motion.
    double* w = foldCoupling_.data();
    std::fill(w, w + 6 * nb, 0.0);
    for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) {
        const std::size_t f = static_cast<std::size_t>(i);
        const int column = e.nodeColumn_[f];
        if (held(column)) continue;
        Vector6 c = rw.weighted(e.nodeId_[f]);
        if (folded_[f]) c -= foldProduct_[f];
        const Eigen::Index l = e.localOfColumn_[static_cast<std::size_t>(column)];
        for (Eigen::Index q = 0; q < 6; ++q) w[q * nb + l] += c[q];
    }
    double* rows = couplings_.data() + e.coupling_[b];
    couplingRows(b, w, 6, rows);
    Matrix6& k = blockWeight_[b];
    Vector6& load = blockLoad_[b];
    k.setZero();
    load.setZero();
    for (Eigen::Index r = 0; r < nb; ++r) {  // whole outer products: they vectorize, a triangle would not
        const Eigen::Map<const Vector6> row(rows + 6 * r);
        k.noalias() += row * row.transpose();
        load += y[r] * row;
    }
    for (const int c : e.children_[b]) {
        k += blockWeight_[static_cast<std::size_t>(c)];
        load += blockLoad_[static_cast<std::size_t>(c)];
    }
}

void BlockEliminationWorkspace::substituteFolded(std::size_t b, Eigen::Ref<Eigen::VectorXd>& delta)
{
    const BlockElimination& e = *e_;
    const Eigen::Index nb = e.size_[b];
    double* z = rhs_[b].data();
    const int attach = e.attach_[b];
    if (attach >= 0) {
        const Vector6& v = motion_[static_cast<std::size_t>(attach)];
        const double* rows = couplings_.data() + e.coupling_[b];
        for (Eigen::Index k = 0; k < nb; ++k) z[k] -= Eigen::Map<const Vector6>(rows + 6 * k).dot(v);
    }
    applyFTransposed(b, z);
    for (Eigen::Index l = 0; l < nb; ++l) delta[e.columns_[b][static_cast<std::size_t>(l)]] = z[l];
    if (e.children_[b].empty()) return;
    const ResidualWorkspace& rw = *twists_;
    for (int i = e.nodeBegin_[b]; i < e.nodeBegin_[b + 1]; ++i) {
        const std::size_t f = static_cast<std::size_t>(i);
        const int up = e.nodeUp_[f], column = e.nodeColumn_[f];
        if (up >= 0) motion_[f] = motion_[static_cast<std::size_t>(up)];
        else motion_[f].setZero();
        if (!held(column)) motion_[f] += rw.twist(e.nodeId_[f]) * z[e.localOfColumn_[static_cast<std::size_t>(column)]];
    }
}

}  // namespace rig

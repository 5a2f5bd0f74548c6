#pragma once
// The coupled step of a partitioned problem (DESIGN: inversion): the Gauss-Newton / Levenberg-Marquardt
// system (J^T J + mu I) d = -g of every block at once, solved by eliminating the blocks of the partition
// tree from the leaves up.
//
// The partition (inversion/solve/partition.h) gives each counted output to one block, and the only
// parameters that move it are that block's and its ancestors'. J^T J then couples a block only with
// its ancestors: a block-arrowhead matrix (a tree of them), whose Schur complements onto the parents
// fill nothing outside the ancestor chains. Eliminating a leaf b costs its size cubed plus products
// with its ancestors' blocks, so the coupled step costs about what the blocks' own steps cost, and the
// solve reaches the whole problem's optimum where the block-by-block order (an outer block fitted first,
// then held) stops at a worse one on unreachable targets.
//
// Folded (the twist form, analytic): where every block hangs below one node of its parent's (its attach
// node: each of its unknown nodes' first unknown ancestor outside the block is that node; a root's are none),
// the couplings between a block and its ancestors are t_a^T (W_m t_m) (t: twists, W: the sums of B^T B below
// a node m of the block), of rank 6 at most through the attach node's motion. Eliminating a block then
// takes a 6x6 (and a 6-vector of the right-hand side) folded into the W (and loads) of its attach node,
// as the articulated-body algorithm does, and J^T J is kept only within the blocks. Elsewhere (a parameter
// of a block below a node of a block under it) the couplings are kept and eliminated as above.
//
// A block's own matrix that is singular (redundant controls, a straight limb, a pole's free directions) is
// inverted on its range only (the pivots of a Cholesky factor with diagonal pivoting above 1e-12 of its largest
// diagonal): the minimum-norm step within the block, as the one-block solve takes, at a fraction of an
// eigendecomposition's cost.
//
// Node by node (long blocks: a tail, a rope, a spine of many joints): folded, a block of more than
// recursiveAbove columns, each of one unknown node, is split into a block per column below the block of its
// node's unknown parent, so the fold runs recursively through it (the articulated-body algorithm: a 1x1 pivot,
// a 6x6 and a 6-vector per node) and its cost grows linearly instead of as its size cubed. Where every pivot
// of a split block is above 1e-12 of its largest diagonal, the step is its inverse's, as the dense Cholesky
// factor's; where one is not (singular there: targets that do not determine the block, a straight limb), that
// step is taken by the blocks unsplit, J^T J within them formed from the twists: the minimum-norm step, at the
// dense cost.

#include <memory>
#include <span>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "inversion/solve/jacobian.h"
#include "inversion/solve/partition.h"

namespace rig {

// Built once per partition; shared read-only by the solves that use it.
class BlockElimination {
public:
    // `structure`: the whole problem (every block's parameters as columns, every block's outputs as rows).
    // `twists`: the normal equations come from twists (analytic, structure.twistForm()): the fold is taken
    // where the blocks hang as it needs.
    BlockElimination(const Partition& partition, const ResidualStructure& structure, bool twists = false);

    // Blocks of more columns than this are eliminated node by node where folded (above). Measured on chains: the
    // dense factor is faster up to about 12 columns, the two even from 18 to 24, the recursion faster beyond.
    static constexpr int recursiveAbove = 24;

    // The blocks eliminated, a long block's columns each one of them.
    int blocks() const { return static_cast<int>(size_.size()); }
    // Whether a block of the partition is eliminated node by node (then blocks() counts its columns).
    bool nodeByNode() const { return !groupOf_.empty(); }
    // Whether the couplings between blocks are folded in twist space (then the workspace reads the twists of
    // a ResidualWorkspace, and layout() holds each block's rows against its own columns only).
    bool folded() const { return folded_; }
    // Where J^T J is kept: entry (i, j), i >= j, of the structure's columns at flat index layout()[j * n + i]
    // of BlockEliminationWorkspace::entries() (ResidualWorkspace::useLayout); -1 where no block holds it.
    const std::vector<int>& layout() const { return layout_; }
    int entryCount() const { return entryCount_; }

private:
    friend class BlockEliminationWorkspace;

    std::vector<int> size_;                  // per block: its columns
    std::vector<std::vector<int>> chain_;    // per block: itself, then its ancestors up to its root
    std::vector<std::vector<int>> columns_;  // per block: its structure columns, in order
    std::vector<int> blockOfColumn_, localOfColumn_;
    std::vector<int> diagonal_;  // per column: where its diagonal entry of J^T J is in the flat entries
    // Per block and chain entry: where that block of J^T J (the block's columns as rows, column-major)
    // starts in the flat entries. A block's entries along its chain are contiguous: its panel, its rows
    // against its own columns and then its ancestors' (ancestors_ of them), column-major.
    std::vector<std::vector<int>> base_;
    // Per block: the (block, chain entry) pairs whose columns are its columns (its descendants' couplings).
    std::vector<std::vector<std::pair<int, int>>> coupledBelow_;
    std::vector<int> ancestors_;  // per block: its ancestors' columns, summed
    std::vector<int> square_;     // per block: where its factor starts in the workspace's factors (size squared)
    std::vector<int> coupling_;   // per block: where its rows of T start in the workspace's couplings
    std::vector<int> layout_;
    int entryCount_ = 0;
    int squareCount_ = 0, couplingCount_ = 0;

    // The fold's plan. Per block, its unknown nodes (parents first) at flat indices [nodeBegin_[b],
    // nodeBegin_[b + 1]); per flat node: its node id, its block column, the flat index of its unknown parent
    // (in its block, or its block's attach node; -1: none) and its pairs with the nodes of its block above
    // it (itself first) in [pairBegin_[i], pairBegin_[i + 1]): the other flat node, the entry, the factor.
    // Held markers: entries from heldBase_, one per column (1: held; the normal equations zero them).
    bool folded_ = false;
    std::vector<int> nodeBegin_, nodeId_, nodeColumn_, nodeUp_, attach_;  // attach_: per block, a flat index or -1
    std::vector<int> pairBegin_, pairOther_, pairEntry_;
    std::vector<double> pairFactor_;
    std::vector<std::vector<int>> children_;
    int heldBase_ = 0;

    // Node by node: per block, the partition block it was split from (its group, numbered from 0), or -1. Empty when
    // no block is split.
    std::vector<int> groupOf_;
    std::unique_ptr<BlockElimination> whole_;  // node by node: the partition's blocks unsplit, for singular steps

    void build(const Partition& partition, const ResidualStructure& structure, bool twists);
    bool planFold(const Partition& partition, const ResidualStructure& structure);
    // The partition with the long blocks split a block per column (above), and each block's group; false
    // when no block is split.
    bool splitLongBlocks(const Partition& partition, const ResidualStructure& structure, Partition& finer,
                         std::vector<int>& group) const;
};

// Per-solve state: the blocks of J^T J along each chain, the right-hand sides and the blocks' factors.
// Sized once; allocates nothing per step.
class BlockEliminationWorkspace {
public:
    // `twists`: for a folded elimination, the workspace whose normal equations fill entries() (read at each
    // solve and multiply for the twists).
    explicit BlockEliminationWorkspace(const BlockElimination& elimination, const ResidualWorkspace* twists = nullptr);

    // J^T J's blocks, in BlockElimination::layout(): what the normal equations fill.
    std::span<double> entries() { return entries_; }
    double diagonal(int column) const;
    // Replaces a column's row and column of J^T J by those of the identity (a parameter held at a limit).
    void hold(int column);
    // out = J^T J v.
    void multiply(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out) const;
    // Solves (J^T J + mu I) delta = -gradient (gradient: zero on held columns; `fixed`, where given, says which
    // are held, as DenseSystem::solve takes it). False when a block's matrix has no finite inverse.
    bool solve(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu, Eigen::Ref<Eigen::VectorXd> delta,
               std::span<const char> fixed = {});
    // Hints the cache to fetch what a solve touches (core/prefetch.h).
    void prefetch() const;

private:
    using BlockMap = Eigen::Map<Eigen::MatrixXd>;
    using ConstBlockMap = Eigen::Map<const Eigen::MatrixXd>;
    using Matrix6 = Eigen::Matrix<double, 6, 6>;
    using Vector6 = Eigen::Matrix<double, 6, 1>;
    BlockMap block(std::size_t b, std::size_t i);
    ConstBlockMap block(std::size_t b, std::size_t i) const;
    // S_b^-1 (or S_b^+) = F^T F for S_b (s: its panel's first columns) plus mu I: S_b = L L^T, F = L^-1 (L in
    // squares_), else F in factor_. False when S_b has no finite inverse.
    bool factor(std::size_t b, const double* s, double mu);
    // factor's F where S_b + mu I is singular (a pivot at or below the rank tolerance of `scale`).
    bool rangeFactor(std::size_t b, const double* s, double mu, double scale);
    // rangeFactor's Q = (I + M M^T)^-1 M (M and Q: k x r, column-major); false when that matrix has no Cholesky
    // factor.
    bool solveNullSquare(const double* m, Eigen::Index k, Eigen::Index r, double* q);
    void applyF(std::size_t b, double* x);            // x <- F x, in place
    void applyFTransposed(std::size_t b, double* x);  // x <- F^T x, in place
    // T = F W into rows, row-major (W: m columns after S_b, column-major; a row of T per block column).
    void couplingRows(std::size_t b, const double* w, Eigen::Index m, double* rows);
    bool held(int column) const
    {
        return e_->folded_ && entries_[static_cast<std::size_t>(e_->heldBase_ + column)] != 0;
    }
    bool solveFolded(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu, Eigen::Ref<Eigen::VectorXd> delta);
    // Node by node: a split block's one column eliminated (its 1x1 S_b factored, T and K folded into its attach
    // node). False when its pivot is at or below 1e-12 of `scale` (wholeScale_): singular there.
    bool eliminateNode(std::size_t b, double mu, double scale);
    // Node by node, where a split block is singular: the step of the blocks unsplit (BlockElimination::whole_).
    bool solveWhole(const Eigen::Ref<const Eigen::VectorXd>& gradient, double mu, Eigen::Ref<Eigen::VectorXd> delta);
    // solveFolded's phases. A node's folds (the 6x6 and the load of what is eliminated below it): one more added.
    void addFold(std::size_t i, const Matrix6* weight, const Vector6* load);
    // Block b's children's folds, at their attach nodes and summed up b's nodes towards its attach node.
    void gatherFolds(std::size_t b);
    // S_b with the folds taken off its pairs (in work_) and off y; held columns made identity.
    const double* foldedPanel(std::size_t b, double* y);
    // What eliminating block b (factored, y = F rhs) leaves at its attach node: its T and K, load (children's too).
    void foldIntoAttach(std::size_t b, const double* y);
    // Block b's step into delta, and its nodes' motions for its children.
    void substituteFolded(std::size_t b, Eigen::Ref<Eigen::VectorXd>& delta);
    void multiplyFolded(const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> out) const;

    const BlockElimination* e_;
    std::vector<double> entries_;
    std::vector<double> work_;       // the panels of blocks with children, copied from entries_ and damped: the
                                     // elimination's Schur complements land there (same layout); leaves read entries_
    std::vector<double> squares_;    // per block: L of the damped S_b, column-major, 1 / L(j, j) on its diagonal
    std::vector<double> couplings_;  // per block: T = F (its coupling columns), row-major, a row per block column
    std::vector<Eigen::MatrixXd> factor_;  // per block: F where S_b is singular
    std::vector<char> triangular_;         // per block: F = L^-1 (L in squares_)
    std::vector<Eigen::Index> rank_;       // per block: F's rows that are not zero
    // rangeFactor's (the largest block's size): the pivoted factor L, M, Q and the factor of I + M M^T; 1 / L(j, j)
    // of L and of that factor.
    Eigen::MatrixXd pivoted_, nullRows_, nullSolved_, nullSquare_;
    std::vector<double> pivotInverse_, nullInverse_;
    std::vector<double> rangeRows_;     // rangeFactor's rows of F, row-major, before the permutation
    std::vector<int> permutation_;      // rangeFactor's P
    std::vector<Eigen::VectorXd> rhs_;  // per block: its right-hand side, then y, then its step
    std::vector<double> scratch_;
    // The fold's: per flat node, the folds below it (6x6 and load) and F t-products; per block, what its
    // elimination folds into its attach node; per flat node, the motion of the step (or of multiply's v).
    const ResidualWorkspace* twists_ = nullptr;
    std::vector<Matrix6> foldWeight_, blockWeight_;
    std::vector<Vector6> foldLoad_, foldProduct_, blockLoad_;
    std::vector<const Matrix6*> foldWeightOf_;  // per flat node: its fold (its own foldWeight_ or its one source's)
    std::vector<const Vector6*> foldLoadOf_;
    mutable std::vector<Vector6> motion_, force_;
    std::vector<char> folded_;
    std::vector<double> foldCoupling_;  // a block's W^T: its columns against the attach node's motion
    // The largest free diagonal of J^T J plus mu, this step's: what every block's pivots are judged against.
    double wholeScale_ = 0.0;
    std::unique_ptr<BlockEliminationWorkspace> whole_;  // solveWhole's, made on its first step
};

}  // namespace rig

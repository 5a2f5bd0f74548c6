#pragma once
// Residuals of targets on the approximation, and their Jacobian (docs/solver.md).
//
// Each counted output's rows come from its residual term (inversion/solve/residual_term.h), at an offset of the
// structure's table (ResidualStructure::rowOffset). The joint target, the default term, has six rows in this order:
//   position  w_p * (t_k(beta) - t_target)                                     cm
//   rotation  w_r * s * 2 vec(q),  q = quaternion of Q_target^T Q_k(beta), w_q >= 0   |.| = s * 2 sin(theta / 2)
// (cost per joint s^2 (1 - cos theta): smooth, stationary only at the target and half a turn away, unlike
// the logarithm's), where Q is the orthonormal (polar) part of a world matrix's 3x3 block, so scale and
// shear in a target or in the approximation's output (a stretch operator) never count as rotation. The Jacobian is
// analytic, from the operator product F~_k = P_s1 ... P_sm F_k(0) (dF~_k/da_j = prefix_j * P_j'(a_j) *
// suffix_j: the outputs' products share their prefixes as a tree, and prefix/suffix products are kept
// as the fallback for singular operators; ResidualWorkspace says how), or central finite differences on the
// approximation with its columns in parallel (oneTBB, in the caller's task arena).

#include <array>
#include <map>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "inversion/model/approximation.h"
#include "inversion/solve/residual_term.h"
#include "inversion/solve/solver_options.h"

namespace rig {

// What a solve should reach for one output of the approximation (one entry per Approximation::outputs).
struct JointTarget {
    bool active = false;  // outputs without a target do not count
    // Target world matrix, cm. Only the orthonormal (polar) part of the 3x3 block is used as the
    // target rotation: scale and shear are ignored. A singular 3x3 block makes the target invalid.
    Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
    double positionWeight = 1.0;  // per cm of position error; 0 ignores the position
    double rotationWeight = 1.0;  // multiplies the rotation residual (radians x rotationScaleCm); 0 ignores it
    // Its residual term (residualTerm(name) finds one by name); null: the joint target's six rows. A term reads
    // the weights of the halves it measures (the position term: positionWeight alone).
    const ResidualTerm* term = nullptr;
};

inline constexpr int jointTargetRows = 6;  // the joint target's rows: position x, y, z, then rotation x, y, z

// A target ready for the residual: orthonormal rotation, rotation scale folded into its weight.
struct PreparedTarget {
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    double positionWeight = 0.0;
    double rotationWeight = 0.0;  // JointTarget::rotationWeight * rotationScaleCm
};

// False when the target cannot be used: a non-finite entry or weight, a negative weight, or a 3x3
// block too close to singular to have an orientation (smallest singular value below 1e-9 of the largest).
bool prepareTarget(const JointTarget& target, double rotationScaleCm, PreparedTarget& prepared);

// The six weighted residual rows of one target (the file's comment says which) for a world matrix: what a
// black-box problem on the real rig measures, so that its cost is the solver's.
Eigen::Matrix<double, 6, 1> targetResidual(const Eigen::Matrix4d& world, const PreparedTarget& target);

// Position error (cm) and rotation error (radians) of a world matrix against a prepared target, unweighted.
struct TargetError {
    double positionCm = 0.0;
    double rotationRad = 0.0;
};
TargetError targetError(const Eigen::Matrix4d& world, const PreparedTarget& target);

// The structure of a sub-problem: some parameters are unknowns (the columns), the residuals of some
// outputs are the rows, every other parameter is held at a given value. Built once, shared read-only
// (solves on many threads use one structure, each with its own ResidualWorkspace).
//
// Outputs' operator products share their beginnings (a hand's product starts as the wrist's), so they
// are kept as a tree of prefixes: each node multiplies its parent's product by one operator, every
// product is computed once per evaluation, and those of held operators alone once per holdParameters. The analytic
// Jacobian then needs one world-space velocity per unknown node, Xi = P dM M^-1 P^-1 (P its parent's product), and
// dW/da = Xi W for every output below it.
class ResidualStructure {
public:
    // `columns`: indices into approximation.parameters; `outputs`: indices into approximation.outputs.
    // Both increasing. `terms`: one per Approximation::outputs entry (null: the joint target), or empty: every
    // output a joint target. Keeps a reference to the approximation and to the terms.
    ResidualStructure(const Approximation& approximation, std::vector<int> columns, std::vector<int> outputs,
                      std::span<const ResidualTerm* const> terms = {});

    const Approximation& approximation() const { return *approximation_; }
    const std::vector<int>& columns() const { return columns_; }
    const std::vector<int>& outputs() const { return outputs_; }
    int rows() const { return rowOffset_.back(); }
    // Where output position o's rows begin (its term's rows() of them): a table, terms of several sizes meet.
    int rowOffset(int o) const { return rowOffset_[static_cast<std::size_t>(o)]; }
    const ResidualTerm& term(int o) const { return *terms_[static_cast<std::size_t>(o)]; }
    // Every output's term is the joint target: its own fast paths throughout.
    bool jointTargetsOnly() const { return jointTargetsOnly_; }
    int columnCount() const { return static_cast<int>(columns_.size()); }
    // Positions in outputs() of the outputs column c moves.
    const std::vector<int>& outputsOfColumn(int c) const { return outputsOfColumn_[static_cast<std::size_t>(c)]; }
    // Whether the analytic normal equations come from twists, without the Jacobian
    // (ResidualWorkspace::normalEquations).
    bool twistForm() const { return twistForm_; }
    // Whether the analytic normal equations come from twists and bases' velocities, without the Jacobian: twist
    // form, or its products begin with planar chains' bases. No fold of a BlockElimination through the bases.
    bool twistNormals() const { return twistNormals_; }
    // Whether some output's product begins with a constraint's base (inversion/model/constraint.h).
    bool hasBases() const { return !bases_.empty(); }

private:
    friend class ResidualWorkspace;
    friend class BlockElimination;  // its plan of the twist-space fold reads the unknown nodes and their pairs

    struct Link {  // one operator in an output's product
        int parameter = 0;
        int op = 0;       // index into the parameter's operators
        int column = -1;  // unknown: its column; -1: held fixed
        int slot = -1;    // unknown: index into slots_
        int held = -1;    // held: index into heldParameters_
    };
    struct Slot {  // a distinct (column, operator) pair: evaluated once per evaluation
        int column = 0;
        int parameter = 0;
        int op = 0;
        bool rigid = false;  // its matrix is a rotation and a translation
        // The operator and its parameter's default, read at every evaluation without the parameter's record.
        const Operator* operation = nullptr;
        double defaultValue = 0.0;
    };
    struct Node {            // product = parent's product * one operator's matrix
        int parent = -1;     // -1: the identity
        int slot = -1;       // an unknown's operator; -1: a held one
        int parameter = -1;  // the held operator
        int op = -1;
        int base = -1;          // a constraint's base B (index into bases_): the root of the products below it
        bool rigid = false;     // the whole product from the root is rigid
        bool constant = false;  // only held operators from the root: computed once per holdParameters
    };
    // A constraint output's base, B(inputs): a root node of the tree, evaluated from its inputs' products (nodes
    // made before it). Its velocity per column is its inputs' velocities through baseVelocity().
    struct Base {
        int constraint = -1;  // index into approximation.constraints
        int node = -1;
        int anchorNode = -1, goalNode = -1, poleNode = -1;  // the inputs' product nodes (-1: the identity)
        int orientNode = -1;                                // a chain's orient output's (ConstraintBase::orient)
        Eigen::Vector3d goalRest, poleRest;                 // the goal's and pole's rest origins
        // A twist share's second and third inputs' rest worlds (the driver and its parent; identity for the world).
        Eigen::Matrix4d secondRest = Eigen::Matrix4d::Identity(), thirdRest = Eigen::Matrix4d::Identity();
        // A blend's frame inputs (ConstraintBase::frameInputs: anchor, ik, fk, ikParent, fkParent): their product
        // nodes (-1: the identity) and rest worlds (the identity for no output), the output's rest inverse, and its
        // weight's column (-1: held).
        std::array<int, 5> frameNodes{-1, -1, -1, -1, -1};
        std::array<Eigen::Matrix4d, 5> frameRest;
        Eigen::Matrix4d restInverse = Eigen::Matrix4d::Identity();
        int weightColumn = -1;
        std::vector<int> columns;  // the columns that move it, increasing
        // Per column, [termBegin[j], termBegin[j + 1]) of terms_: what moves its inputs.
        std::vector<int> termBegin;
        int velocityOffset = 0;  // its columns' velocities in ResidualWorkspace::baseVelocity_
    };
    // InputTerm::input of a blend's weight column: the weight itself moves (dw = 1), no node.
    static constexpr int blendWeightInput = 5;
    struct InputTerm {  // one velocity moving an input: an unknown node's, or an upstream base's for a column
        // ConstraintBase::frameInputs' index: 0 anchor, 1 goal or driver or ik, 2 pole or its parent or fk, 3 and 4
        // a blend's branch parents, 3 a chain's orient output; or blendWeightInput.
        int input = 0;
        int node = -1;          // an unknown node on the input's path, or -1
        int baseVelocity = -1;  // else an index into ResidualWorkspace::baseVelocity_
    };
    // Output k's product: the base it begins with (a constraint output, or -1) and its operators after it.
    struct Path {
        int base = -1;
        std::vector<Link> links;
    };
    struct Chain {                            // output k: C_0 V_0 C_1 V_1 ... V_{v-1} C_v, C_v ending with F_k(0)
        std::vector<int> varSlots;            // slot of V_j
        std::vector<int> varColumns;          // column of V_j
        std::vector<std::vector<Link>> gaps;  // fixed links of C_0 .. C_v
    };

    // The constructor's phases, in order.
    std::vector<int> checkIndices() const;                                      // per parameter: its column, or -1
    std::vector<std::vector<Link>> ownLinks(const std::vector<int>& columnOf);  // per output; makes the slots
    Path pathOf(int k, const std::vector<std::vector<Link>>& own) const;        // approximation output k's
    void makeChains(const std::vector<Path>& paths);
    void makeTree(const std::vector<Path>& paths, const std::vector<std::vector<Link>>& own);
    Base makeBase(int constraint, const std::array<int, 5>& inputNodes) const;  // its inputs, before its node
    void baseTerms(Base& base, const std::array<int, 5>& inputNodes);           // its columns and what moves its inputs
    void addBaseColumns();
    void makePairs();
    void basePairs();  // baseUnknownBegin_, baseUnknown_
    void attachTerms(std::span<const ResidualTerm* const> terms);

    const Approximation* approximation_;
    std::vector<int> columns_;
    std::vector<int> outputs_;
    std::vector<const ResidualTerm*> terms_;  // per output position
    std::vector<int> rowOffset_;              // per output position, and the row count last
    std::vector<char> jointTarget_;           // per output position: its term is the joint target
    bool jointTargetsOnly_ = true;
    // Whether output position o takes the joint target's own paths (else its term's virtual ones).
    bool jointTarget(std::size_t o) const { return jointTargetsOnly_ || jointTarget_[o]; }
    std::vector<Slot> slots_;
    std::vector<Node> nodes_;  // parents before children, a base's inputs before it
    std::vector<Base> bases_;
    std::vector<InputTerm> inputTerms_;
    std::map<int, int> baseOfOutput_;  // constraint output -> index into bases_
    std::vector<int> outputBase_;      // per output position: the base its product begins with (-1: none)
    int baseVelocities_ = 0;
    std::vector<int> outputNode_;               // per output: the node whose product it ends with (-1: none)
    std::vector<char> outputRigid_;             // per output: product and rest rigid (no polar decomposition)
    std::vector<std::vector<int>> outputVars_;  // per output: the unknown nodes on its path
    std::vector<Chain> chains_;                 // per output, flat: finite differences and the fallback
    std::vector<int> heldParameters_;           // the parameters of the chains' held links
    std::vector<std::vector<int>> outputsOfColumn_;
    std::vector<std::vector<int>> columnsOfOutput_;  // per output: the columns that move it, increasing
    // The normal equations up the tree (ResidualWorkspace::normalEquations): the unknown nodes parents
    // first, each one's nearest unknown ancestor, and each output's deepest unknown node (-1: none).
    std::vector<int> unknownNodes_;
    std::vector<int> unknownUp_;  // per node
    std::vector<int> outputDeepest_;
    // Per unknown node (in unknownNodes_ order): its column, and its pairs with itself and every unknown
    // node above it, [pairBegin_[i], pairBegin_[i + 1]): the other node, where the pair's entry is in the
    // lower triangle of H (column-major offset) and its multiplicity (2 for two nodes of one column).
    std::vector<int> unknownColumn_;
    std::vector<int> pairBegin_, pairNode_, pairOffset_;
    std::vector<double> pairFactor_;
    bool twistForm_ = false;     // every unknown node and every output with one is rigid, and no base
    bool twistNormals_ = false;  // the same, bases of planar chains allowed
    // Per base, [baseUnknownBegin_[b], baseUnknownBegin_[b + 1]) of baseUnknown_: the unknown nodes below it.
    std::vector<int> baseUnknownBegin_, baseUnknown_;
    int maxVars_ = 0;
    int constantCount_ = 0;  // sum over chains of (vars + 1)
};

// Per-solve state of one ResidualStructure: the held parameters' products, the prepared targets and
// scratch. Sized once; evaluating allocates nothing.
class ResidualWorkspace {
public:
    // `jacobian` is the owner's own J, sized once and written only through this workspace (BlockWorkspace::J): where
    // the analytic tree forms it again, only the entries it adds into are zeroed first (clearTreeEntries).
    void formsInPlace(const Eigen::MatrixXd& jacobian) { inPlace_ = &jacobian; }
    explicit ResidualWorkspace(const ResidualStructure& structure);

    const ResidualStructure& structure() const { return *structure_; }

    // Values of every approximation parameter (absolute): the held ones are read here once.
    void holdParameters(std::span<const double> values);
    // One target per Approximation::outputs entry; those of structure().outputs() must be prepared.
    void setTargets(std::span<const PreparedTarget> targets);
    void setTarget(int position, const PreparedTarget& target);

    // Residuals at the column values x (size columnCount()); r has rows() entries.
    void residuals(std::span<const double> x, Eigen::Ref<Eigen::VectorXd> r);
    // Residuals and Jacobian (rows() x columnCount()). Finite differences are central with the given
    // step; their columns run in parallel (tbb::parallel_for in the current arena) when `parallel`.
    void jacobian(std::span<const double> x, JacobianMethod method, double finiteDifferenceStep, bool parallel,
                  Eigen::Ref<Eigen::VectorXd> r, Eigen::Ref<Eigen::MatrixXd> jacobian);
    // Residuals r, gradient g = J^T r and the lower triangle of H = J^T J at x (g: columnCount(); h: in
    // useLayout()'s layout, zeroed here; dense: columnCount() square, its strict upper triangle left zero).
    // With the analytic method on rigid operators and outputs, each unknown's world-space velocity is a
    // twist (omega, v), the output's rows are a map B_k of it (its term's rows x 6; B_k^T B_k is 6x6 for any
    // term), and H_ij = twist_i^T (sum of B_k^T B_k below j) twist_j for i above j: the sums are accumulated up
    // the prefix tree once, and J is never formed. A planar chain's base (a root of the tree) moves by a twist per
    // column too, from its inputs' twists: its columns meet each other through the sum of B_k^T B_k over the
    // outputs that begin with it, and the unknowns below it through theirs (twistNormals()). Otherwise J is
    // formed in `jacobian` (rows() x columnCount()) and multiplied output by output over the columns that
    // move it. Either way only pairs of columns that share an output cost anything.
    void normalEquations(std::span<const double> x, JacobianMethod method, double finiteDifferenceStep, bool parallel,
                         Eigen::Ref<Eigen::VectorXd> r, Eigen::Ref<Eigen::VectorXd> g, std::span<double> h,
                         Eigen::Ref<Eigen::MatrixXd> jacobian);
    // The same normal equations at the point of the last residuals() call, whose rows `r` gave: a step's
    // trial point, once accepted, is not evaluated again. Only for structures with twistNormals() (analytic).
    void normalEquationsAtLast(const Eigen::Ref<const Eigen::VectorXd>& r, Eigen::Ref<Eigen::VectorXd> g,
                               std::span<double> h);
    // Where H goes: entry (i, j), i >= j, at h[layout[j * columnCount() + i]] (BlockElimination::layout()),
    // or, with an empty layout (the default), h is the dense column-major matrix. A layout may leave out
    // each unknown node's pairs with the nodes above some point (-1 from there up; twist form only): the
    // couplings a folded BlockElimination forms itself from twist() and weighted().
    void useLayout(std::span<const int> layout);
    // Hints the cache to fetch what an evaluation and the twists' normal equations touch (core/prefetch.h).
    void prefetch() const;
    // The analytic Jacobian from prefix and suffix products along each output's own product
    // (dW/da_j = prefix_j dM_j suffix_j): what jacobian() falls back to when an operator or a product
    // is singular (no inverse for the velocity form). For tests and benchmarks.
    void jacobianFromSuffixes(std::span<const double> x, Eigen::Ref<Eigen::VectorXd> r,
                              Eigen::Ref<Eigen::MatrixXd> jacobian);
    // Per unknown node (a node id of the structure's tree) at the last normal equations from twists: its twist
    // (omega, v), and W t with W the sum of B_k^T B_k over the outputs below it. What a folded
    // BlockEliminationWorkspace reads.
    const Eigen::Matrix<double, 6, 1>& twist(int node) const { return twist_[static_cast<std::size_t>(node)]; }
    const Eigen::Matrix<double, 6, 1>& weighted(int node) const { return weighted_[static_cast<std::size_t>(node)]; }
    // World matrix of output position o (in structure().outputs()) at the last evaluation.
    const Eigen::Matrix4d& world(int o) const { return worlds_[static_cast<std::size_t>(o)]; }
    // targetError of output position o at the last evaluation (a rigid output's from its residual's quaternion).
    TargetError error(int o) const;

private:
    using Affine =
        Eigen::Matrix<double, 3, 4>;  // the top rows of a 4x4 whose last row is 0 0 0 1 (or 0 for a derivative)

    void evaluateSlots(std::span<const double> x, bool derivatives);
    void evaluateTree();                     // node products and worlds from the slot matrices
    Affine evaluateBase(std::size_t b);      // base b's product, from its inputs' (basePoints_ too)
    Affine evaluateBlend(std::size_t b);     // a blend's base, from its inputs' products and its weight (blends_ too)
    Affine evaluateOriented(std::size_t b);  // an oriented base, from its anchor's and orient output's products
    // A blend's dB B^-1 for its inputs moving at x (ConstraintBase::frameInputs' order) and its weight at dw.
    Affine blendVelocity(std::size_t b, const std::array<Affine, 5>& x, double dw) const;
    void baseVelocities();  // baseVelocity_ from velocity_, bases in order
    // Bases' velocities from their inputs' (an affine rate per node, Affine, or the twist form's twists, Vector6d).
    template <class Velocity>
    void baseVelocities(const std::vector<Velocity>& nodeVelocity, std::vector<Velocity>& baseVelocity);
    // Central differences of every column through whole evaluations (products that begin with a base).
    void wholeDifferences(std::span<const double> x, double step, Eigen::Ref<Eigen::VectorXd> r,
                          Eigen::Ref<Eigen::MatrixXd> jacobian);
    void residualRows(Eigen::Ref<Eigen::VectorXd> r);  // also the rigid outputs' quaternions
    bool velocities();                                 // Xi per unknown node; false: an operator or product is singular
    void treeJacobian(Eigen::Ref<Eigen::MatrixXd> jacobian);  // from velocities()
    // The entries treeJacobian adds into zeroed: only those where the matrix is the one formsInPlace named and the tree
    // formed it last, the rest being zero since (a block's J: zeroing it whole took 7% of a spider scene's solve),
    // else the whole matrix.
    void clearTreeEntries(Eigen::Ref<Eigen::MatrixXd> jacobian);
    void termTreeJacobian(std::size_t o, Eigen::Ref<Eigen::MatrixXd> jacobian);  // an output of another term
    // body(velocity, column) for every velocity that moves output position o: its unknown nodes' and its base's.
    template <class Body>
    void forEachVelocity(std::size_t o, const Body& body) const;
    void twists();  // twist_ per unknown node, straight from the operators (twistForm_ only)
    void twistNormalEquations(const Eigen::Ref<const Eigen::VectorXd>& r, Eigen::Ref<Eigen::VectorXd> g,
                              std::span<double> h);  // from twists(); twistForm_ only
    // Its sums up the tree, g and h, from each output's B^T B and B^T r (`contribution`) and a sum's product
    // with a twist (`times`): the joint targets' 13 numbers, or any term's full 6x6.
    template <class Weight, class Contribution, class Times>
    void foldTwists(std::vector<Weight>& weights, std::vector<Weight>& baseWeights, const Contribution& contribution,
                    const Times& times, Eigen::Ref<Eigen::VectorXd> g, std::span<double> h);
    // The bases' columns in foldTwists: against each other through the sums below each base, against its unknown
    // nodes through theirs.
    template <class Weight, class Times>
    void foldBases(const std::vector<Weight>& baseWeights, const Times& times, Eigen::Ref<Eigen::VectorXd> g,
                   double* entries);
    void baseTwistVelocities();  // baseTwist_ from twist_: the bases' velocities as twists
    void useBaseLayout();        // the bases' entries in h (twist normals through bases)
    void holdChains();           // the flat chains' held products, computed when first needed after holdParameters
    // World of output o from the slot matrices, with column `perturbed` (if >= 0) at value `value`.
    Eigen::Matrix4d chainWorld(int o, int perturbed, double value) const;
    void outputJacobian(int o, Eigen::Ref<Eigen::MatrixXd> jacobian);

    const ResidualStructure* structure_;
    std::vector<double> held_;  // per heldParameters_ entry: its value given to holdParameters
    bool chainsHeld_ = false;
    std::vector<Affine> heldMatrix_;              // per held node: its operator's matrix
    std::vector<double> heldValue_;               // per held node: the value heldMatrix_ was made at
    std::vector<char> heldMoved_;                 // per held node: made again (or a held ancestor) at the last hold
    std::vector<Affine> nodeMatrix_;              // per node: its product from the root
    std::vector<Affine> velocity_;                // per unknown node: Xi
    std::vector<Affine> baseVelocity_;            // per base and column: dB/da B^-1
    std::vector<ChainPoints> basePoints_;         // per base: its chain's points at the last evaluation
    std::vector<Eigen::Vector3d> baseCentres_;    // per base with an orient output: c = B p0 (orientedBase)
    std::vector<TwistLinearization> baseTwists_;  // per base: a twist share's at the last evaluation
    struct BlendState {                           // a blend's at the last evaluation: what its velocity needs
        double weight = 0.0;
        std::array<Eigen::Matrix4d, 5> worlds;  // its frame inputs' worlds
        Eigen::Matrix4d ik, fk, moved;          // the branches' locals, and W_a L
    };
    std::vector<BlendState> blends_;                         // per base (a blend's only used)
    std::vector<double> trial_;                              // wholeDifferences' shifted values
    const Eigen::MatrixXd* inPlace_ = nullptr;               // formsInPlace's matrix
    bool treeFormed_ = false;                                // the tree formed it last, and nothing has written J since
    std::vector<Eigen::Matrix<double, 6, 1>> twist_, load_;  // per unknown node: (omega, v); sum of B_k^T r_k below
    // Sum of B_k^T B_k over outputs: [[A, [m]x], [-[m]x, s I]], as each output's is (twistNormalEquations),
    // kept in its 13 numbers rather than 36: the sums up the tree move a third of the memory.
    struct TwistWeight {
        Eigen::Matrix3d a;
        Eigen::Vector3d m;
        double s;
        TwistWeight& operator+=(const TwistWeight& other)
        {
            a += other.a;
            m += other.m;
            s += other.s;
            return *this;
        }
    };
    using Matrix6 = Eigen::Matrix<double, 6, 6>;
    std::vector<TwistWeight> weight_;                    // per unknown node: sum of B_k^T B_k below
    std::vector<Matrix6> fullWeight_;                    // the same where some term is not a joint target
    std::vector<Eigen::Matrix<double, 6, 1>> weighted_;  // per unknown node: weight_ times twist_
    std::vector<char> fresh_;                            // per unknown node: its sums not yet begun
    // Twist normals through bases: per base velocity its twist and W_b times it; per base the sums of B_k^T B_k
    // and B_k^T r_k over the outputs that begin with it.
    std::vector<Eigen::Matrix<double, 6, 1>> baseTwist_, baseWeighted_, baseLoad_;
    std::vector<TwistWeight> baseWeight_;
    std::vector<Matrix6> baseFullWeight_;
    std::vector<char> baseFresh_;
    // Their entries in h: per base, [basePairBegin_[b], basePairBegin_[b + 1]) the entries of its columns' pairs (i <=
    // j, j outer); [baseNodeBegin_[b], baseNodeBegin_[b + 1]) of a base velocity, an unknown node below, the entry, the
    // factor.
    std::vector<int> basePairBegin_, basePairTarget_;
    std::vector<int> baseNodeBegin_, baseNodeVelocity_, baseNodeNode_, baseNodeTarget_;
    std::vector<double> baseNodeFactor_;
    std::vector<Eigen::Matrix4d> constants_;  // per chain, C_0 .. C_v
    std::vector<char> identity_;              // per constant: it is I (skip the product)
    std::vector<int> constantOffset_;         // per chain
    std::vector<PreparedTarget> targets_;     // per output position
    std::vector<Eigen::Matrix4d> slotMatrix_;
    std::vector<Eigen::Matrix4d> slotDerivative_;
    std::vector<int> layout_;  // useLayout's; empty: dense
    // The structure's pairs that have an entry in h, contiguous (a folded layout leaves most out: a
    // crowd's tree reads only these from memory): per unknown node k, [pairBegin_[k], pairBegin_[k + 1]) of
    // the other node, the factor and the entry.
    std::vector<int> pairBegin_, pairNode_, pairTarget_;
    std::vector<double> pairFactor_;
    std::vector<double> slotOffset_;              // per slot: its parameter's offset a at the last evaluation
    std::vector<Eigen::Quaterniond> quaternion_;  // per rigid output: Q_target^T Q with w >= 0 (residualRows)
    std::vector<Eigen::Matrix4d> worlds_;         // per output position
    std::vector<Eigen::Matrix4d> prefix_;
    std::vector<Eigen::Matrix4d> suffix_;
};

// The whole problem for tests and benchmarks: every approximation parameter a column (those reaching
// no active target give zero columns), each active target's term's rows in output order. Throws an internal
// rig::Error for a wrong number of targets or values, a rig::Error for an active target prepareTarget refuses.
class JacobianEvaluator {
public:
    JacobianEvaluator(const Approximation& approximation, std::span<const JointTarget> targets, double rotationScaleCm);
    JacobianEvaluator(const JacobianEvaluator&) = delete;  // the workspace points at the structure
    JacobianEvaluator& operator=(const JacobianEvaluator&) = delete;

    int rows() const { return structure_.rows(); }
    int columns() const { return structure_.columnCount(); }
    void residuals(std::span<const double> values, Eigen::VectorXd& r);
    // Finite-difference columns run in parallel in the current task arena.
    void jacobian(std::span<const double> values, JacobianMethod method, double finiteDifferenceStep,
                  Eigen::MatrixXd& jacobian, Eigen::VectorXd& r);
    // ResidualWorkspace::normalEquations on the whole problem (h: its lower triangle).
    void normalEquations(std::span<const double> values, JacobianMethod method, double finiteDifferenceStep,
                         Eigen::VectorXd& g, Eigen::MatrixXd& h, Eigen::VectorXd& r);
    const ResidualStructure& structure() const { return structure_; }
    // ResidualWorkspace::jacobianFromSuffixes on the whole problem.
    void jacobianFromSuffixes(std::span<const double> values, Eigen::MatrixXd& jacobian, Eigen::VectorXd& r);

private:
    ResidualStructure structure_;
    ResidualWorkspace workspace_;
};

}  // namespace rig

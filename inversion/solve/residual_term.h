#pragma once
// Residual terms: what a solve minimizes on one output, as momentum's error functions (docs/solver.md).
//
// A term kind is attached to an output (JointTarget::term) and, from the output's world matrix W and its
// prepared target, gives a fixed number of weighted residual rows and their Jacobian with respect to the
// world-space twist (omega, v) of that output: W -> (I + [omega, v]^) W, so that a point p of the output moves
// by omega x p + v and its rotation by [omega]x Q. The solver's analytic normal equations only need, per output,
// B^T B (6x6) and B^T r with B that rows x 6 map: a term of any row count folds into the same 6x6 sums of the
// block elimination. Today's joint target (six rows) is one kind and keeps its own fast path in
// ResidualWorkspace; a new kind is one class and a registerResidualTerm call.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace rig {

struct JointTarget;
struct PreparedTarget;
struct TargetError;

// The most rows one term may have: the residual workspaces keep a term's rows in fixed-size scratch.
inline constexpr int maxTermRows = 6;

using TermRows = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, maxTermRows, 1>;
using TermTwistRows = Eigen::Matrix<double, Eigen::Dynamic, 6, 0, maxTermRows, 6>;

class ResidualTerm {
public:
    virtual ~ResidualTerm() = default;

    // Its name in the registry (residualTerm), as targets give it.
    virtual std::string_view name() const = 0;
    // Its row count, fixed per kind: 1 to maxTermRows.
    virtual int rows() const = 0;
    // Which halves of a joint's motion its weights count for this target (TargetRows flags of partition.h):
    // what a parameter must move for the solver to solve it.
    virtual unsigned char counted(const JointTarget& target) const = 0;
    // The weight of row `row`: the row is this times its unweighted error (0: the row is always 0).
    virtual double weight(const PreparedTarget& target, int row) const = 0;
    // Its weighted rows for world matrix `world` (rows() entries).
    virtual void residual(const Eigen::Matrix4d& world, const PreparedTarget& target, TermRows& rows) const = 0;
    // d rows / d(omega, v) at `world` for a world-space twist of the output (rows() x 6).
    virtual void twistJacobian(const Eigen::Matrix4d& world, const PreparedTarget& target,
                               TermTwistRows& jacobian) const = 0;
    // The rows' first-order change for any change `dWorld` of the world's top three rows: the Jacobian where
    // an operator is not rigid (a stretch), whose velocity is no twist.
    virtual void change(const Eigen::Matrix4d& world, const PreparedTarget& target,
                        const Eigen::Matrix<double, 3, 4>& dWorld, TermRows& rows) const = 0;
    // The unweighted errors a solve reports: the position (cm) and rotation (radians) it measures, 0 for a
    // half it does not.
    virtual TargetError error(const Eigen::Matrix4d& world, const PreparedTarget& target) const = 0;

    // Its index in the registry, in registration order (the solver keys its plans by it).
    int index() const { return index_; }

private:
    friend void registerResidualTerm(std::unique_ptr<ResidualTerm> term);
    friend struct ResidualTermRegistry;
    int index_ = -1;
};

// The built-in kinds. "jointTarget": six rows, position (cm) then rotation (2 vec(q), docs/solver.md); what a
// target without a term is. "position": three rows, the weighted position error alone, rotation not counted.
const ResidualTerm& jointTargetTerm();
const ResidualTerm& positionTerm();

// Registers a kind under its name; kinds live as long as the process. Throws an internal rig::Error for a name
// already taken, a kind with more than maxTermRows rows, or more than maxResidualTerms kinds.
void registerResidualTerm(std::unique_ptr<ResidualTerm> term);
inline constexpr int maxResidualTerms = 63;  // the kind's index fits the solver's plan key (termRowsKey)
// The kind of that name. Throws a userInput rig::Error naming the known kinds.
const ResidualTerm& residualTerm(std::string_view name);
// The registered kinds' names, in registration order.
std::vector<std::string> residualTermNames();

// A target's term: its own, or the joint target when it names none.
const ResidualTerm& termOf(const JointTarget& target);
// Gives `target` the kind `term`. A kind that counts no rotation gets the target's rotation weight 0 too, so that
// what measures by weights (frame judging, polish, the hybrid stage) counts what the term counts.
void setTerm(JointTarget& target, const ResidualTerm& term);
// The rows a target counts (ResidualTerm::counted) with its kind's index above them (bits 2 to 7): one byte
// per output that says both which rows count and how many there are.
unsigned char termRowsKey(const JointTarget& target);
// The kind a termRowsKey names.
const ResidualTerm& termOfKey(unsigned char key);

}  // namespace rig

#pragma once
// Values that give the same pose, and curves kept continuous across a chain's restarts (docs/solver.md,
// Curves without flips).
//
// An unlimited rotate channel repeats every whole turn, and three rotate channels of one joint (Euler
// angles) reach each rotation twice: R1(x) R2(y) R3(z) = R1(x + pi) R2(pi - y) R3(z + pi). Inside a
// warm-start chain the solver keeps the equivalent nearest the warm start. A restart frame starts again
// from its targets alone, so its values may be another equivalent than the frame before it: a jump in
// the curve, with the same pose. Each chunk of a chain (a restart frame up to the next) is therefore
// shifted as a whole, by equivalences only, to meet the frame before it. The chain that was solved is
// unchanged, so a run that continues another chunk's output reproduces one run over both.

#include <array>
#include <span>
#include <vector>

#include "inversion/model/approximation.h"

namespace rig {

class RigBinding;

// The period of a control whose every operator is a rotation with a linear magnitude of the same size
// (a rotate channel, possibly read with another sign): 2 pi / |slope|. 0 when it has none (a curve
// magnitude, a translation, a sampled operator).
double rotationPeriod(const ModelledParameter& m);

// Three periodic controls that may be Euler angles of one rotation: on the same outputs, rotations
// through one pivot about mutually orthogonal axes. Whether they compose in a row (and which one is in
// the middle) is for the caller to check on the pose.
bool eulerTriple(const ModelledParameter& a, const ModelledParameter& b, const ModelledParameter& c);

// Which values of an approximation's parameters give the same pose. Built once per approximation (a few
// evaluations of it per candidate triple).
struct Equivalences {
    explicit Equivalences(const Approximation& approximation);

    // Per parameter: x and x + period give the same pose (rotationPeriod); 0 for none and for limited
    // controls (a limit is not periodic).
    std::vector<double> period;
    // Parameters that are Euler angles of one rotation, in composition order, checked on the pose: the
    // other solution of (a, b, c) is (a + period_a / 2, 2 default_b + period_b / 2 - b, c + period_c / 2).
    std::vector<std::array<int, 3>> triples;
    std::vector<double> defaults;
};

// How one chunk is carried to meet the frame before it; the same for every frame of the chunk.
struct ChunkShift {
    std::vector<char> otherSolution;  // per Equivalences::triples entry
    std::vector<double> turns;        // per parameter: whole periods added (0 where none)
};

// The identity shift, sized for `equivalences`.
ChunkShift noShift(const Equivalences& equivalences);

// The shift that brings `first` (a restart frame's values as solved) nearest `previous` (the values
// reported for the frame before it): per triple the Euler solution, then per periodic parameter the
// whole periods, that make the sum of squared differences smallest (ties: no change).
ChunkShift continuityShift(const Equivalences& equivalences, std::span<const double> previous,
                           std::span<const double> first);

// out = the shifted values of `in` (same size; may be the same span).
void applyShift(const Equivalences& equivalences, const ChunkShift& shift, std::span<const double> in,
                std::span<double> out);

// Whether two sets of values give one pose: every modelled output's matrix on the approximation equal to 1e-9 of
// its size, and every output's on the real rig too when one is given. Without a real rig, values that differ in
// a parameter moving an output the approximation does not model are not vouched for (false). A continuity shift
// is kept only where this holds at the chain's restart frame (docs/solver.md, Curves without flips).
class PoseCheck {
public:
    // Keeps references to both (they must outlive it); `rig` may be null.
    explicit PoseCheck(const Approximation& approximation, RigBinding* rig = nullptr);
    bool operator()(std::span<const double> a, std::span<const double> b);
    // Real-rig evaluations made so far (two per check that reached the real rig).
    int realRigEvaluations() const { return realRigEvaluations_; }

private:
    const Approximation& approximation_;
    RigBinding* rig_;
    int realRigEvaluations_ = 0;
    std::vector<Eigen::Matrix4d> first_, second_;
};

// continuityShift, kept only where `check` (may be null: no check) finds the shifted values the same pose as
// `first`: else the shift in whole turns alone, if that holds, else none (a jump in the curve, never in the pose).
ChunkShift checkedContinuityShift(const Equivalences& equivalences, std::span<const double> previous,
                                  std::span<const double> first, PoseCheck* check);

// The values reported along a clip's warm-start chains: each chain, from its restart frame on, shifted as a
// whole to meet the values reported for the frame before it. invertClip reports through it, and rig-batch
// replays it over the chains its shards solved apart, which is why its curves equal one run's.
class ChainContinuity {
public:
    // `before`: the values reported for the frame before the first one given (the chunk before); empty:
    // none, the first chain is reported as solved. Throws rig::Error when its size is not the
    // parameters'. `equivalences` and `check` (may be null) must outlive this object; each chain's shift is
    // checkedContinuityShift's.
    ChainContinuity(const Equivalences& equivalences, std::span<const double> before, PoseCheck* check = nullptr);

    // The values to report for the next frame of the clip, from its values as solved; `restart`: that frame
    // starts a chain. Valid until the next call.
    std::span<const double> next(std::span<const double> solved, bool restart);
    // Whether the chain of the last frame given is shifted (its reported values are not its solved ones).
    bool shifted() const;

private:
    const Equivalences& equivalences_;
    PoseCheck* check_;
    ChunkShift shift_;
    std::vector<double> reported_;
    bool continuing_ = false;
};

}  // namespace rig

#pragma once
// Curves kept continuous across a clip's restarts (docs/solver.md, Curves without flips).
//
// Inside a warm-start chain the solver keeps the equivalent values (inversion/solve/equivalences.h) nearest the warm
// start. A restart frame starts again from its targets alone, so its values may be another equivalent than the frame
// before it: a jump in the curve, with the same pose. Each chunk of a chain (a restart frame up to the next) is
// therefore shifted as a whole, by equivalences only, to meet the frame before it. The chain that was solved is
// unchanged, so a run that continues another chunk's output reproduces one run over both.

#include <array>
#include <span>
#include <vector>

#include "inversion/model/approximation.h"
#include "inversion/solve/equivalences.h"

namespace rig {

class RigBinding;

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
    ApproximationEvaluator evaluator_;
    RigBinding* rig_;
    int realRigEvaluations_ = 0;
    std::vector<Eigen::Matrix4d> first_, second_;
};

// continuityShift, kept only where `check` (may be null: no check) finds the shifted values the same pose as
// `first`: else the shift in whole turns alone, if that holds, else none (a jump in the curve, never in the pose).
ChunkShift checkedContinuityShift(const Equivalences& equivalences, std::span<const double> previous,
                                  std::span<const double> first, PoseCheck* check);

// The values reported along a clip's warm-start chains: each chain, from its restart frame on, shifted as a
// whole to meet the values reported for the frame before it where that frame was a warm one (a chain's
// continuation, so that the curve goes on through the restart); a chain after another restart frame, or after none,
// is reported as solved, as a clip of its own would report it (with a restart every frame, every frame as it is
// alone, never wound by the poses before it). invertClip reports through it, and rig-batch replays it over the
// chains its shards solved apart, which is why its curves equal one run's.
class ChainContinuity {
public:
    // `before`: the values reported for the frame before the first one given (the chunk before); empty:
    // none. `beforeWarm`: that frame was a warm one (not a restart frame); where it was not, or there is none,
    // the first chain is reported as solved. Throws rig::Error when its size is not the parameters'. `equivalences`
    // and `check` (may be null) must outlive this object; each chain's shift is checkedContinuityShift's.
    ChainContinuity(const Equivalences& equivalences, std::span<const double> before, bool beforeWarm,
                    PoseCheck* check = nullptr);

    // The values to report for the next frame of the clip, from its values as solved; `restart`: that frame
    // starts a chain. Valid until the next call.
    std::span<const double> next(std::span<const double> solved, bool restart);
    // The values to report for the frame last given, solved again near where it was (a polish): shifted as it was.
    std::span<const double> again(std::span<const double> solved);
    // Whether the chain of the last frame given is shifted (its reported values are not its solved ones).
    bool shifted() const;

private:
    const Equivalences& equivalences_;
    PoseCheck* check_;
    ChunkShift shift_;
    std::vector<double> reported_;
    bool afterWarm_ = false;  // reported_ holds a warm frame's values: a chain starting next meets them
};

}  // namespace rig

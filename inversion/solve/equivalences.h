#pragma once
// Values that give the same pose (docs/solver.md, Curves without flips): an unlimited rotate channel repeats every
// whole turn, and three rotate channels of one joint (Euler angles) reach each rotation twice:
// R1(x) R2(y) R3(z) = R1(x + pi) R2(pi - y) R3(z + pi). Inside a warm-start chain the solver keeps the equivalent
// nearest the warm start (minimizer.h); a clip's chains are carried to meet each other by the same equivalences
// (inversion/clip/continuity.h).

#include <array>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "inversion/model/approximation.h"

namespace rig {

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

    // `values` moved to the other solution of `triple` (one of `triples`).
    void otherSolution(const std::array<int, 3>& triple, std::span<double> values) const;
};

// Whether two sets of world matrices are one pose: every matrix equal to 1e-9 of its size.
bool sameWorlds(const std::vector<Eigen::Matrix4d>& a, const std::vector<Eigen::Matrix4d>& b);

}  // namespace rig

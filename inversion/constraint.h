#pragma once
// Constraint operators (docs/rig-learn.md, Constraint operators): what an output that no product of operators
// reproduces is a function of. An output learned with a constraint has a base B instead of a parent's motion,
//
//   F~_k(beta) = B_k(inputs) * M_k(beta) * F_k(0),      B_k = I at rest,
//
// where the inputs are other outputs of the approximation (joints or helper frames, learned before it) and
// M_k is its own operators, as for any output. Outputs below it stay relative to it.
//
// The one family so far is the planar chain: two-bone IK and its production variants. The chain's plane
// is spanned by its root r (a point carried by the anchor output), its goal g (a helper's origin) and its
// pole q (another helper's origin, or a point carried by the anchor: the rotate-plane default):
//
//   C(r, g, q) = [x y z | r],  x = (g - r) / |g - r|,  y = the unit part of q - r across x,  z = x × y
//
// or, for a chain without a pole (the rotate-plane default: the rest plane kept), y = x × N / |x × N| with N the
// rest plane's normal carried by the anchor, so that the plane's normal is the nearest to N across x
//   B = C G(d - d0) C0^-1,     d = |g - r|
//
// with G a rigid motion sampled over the reach d (a spline of a rotation vector and a translation: the
// sampledRigid operator), so that the chain's shape in its plane (its bend, a sliding knee, stretch, soft IK)
// is learned from the rig without knowing which of them it uses.

#include <string_view>

#include <Eigen/Core>

#include "inversion/operators.h"

namespace rig {

enum class ConstraintKind { planarChain };

std::string_view constraintKindName(ConstraintKind kind);

struct ConstraintBase {
    ConstraintKind kind = ConstraintKind::planarChain;
    // Inputs, indices into Approximation::outputs (rig outputs while learning).
    int anchor = -1;  // carries the root (and a fixed pole): its motion F~_a F_a(0)^-1; -1: the world
    int goal = -1;    // the goal is its origin
    int pole = -1;    // the pole is its origin; -1: `restPole` carried by the anchor, or the rest plane (restPlane)
    Eigen::Vector3d root = Eigen::Vector3d::Zero();      // the chain root at rest, world
    Eigen::Vector3d restPole = Eigen::Vector3d::Zero();  // the pole at rest, world
    // No pole: the plane through the chain's line nearest the rest plane, whose normal at rest is restNormal (unit).
    bool restPlane = false;
    Eigen::Vector3d restNormal = Eigen::Vector3d::Zero();
    double restReach = 0.0;  // d0 = |g - r| at rest
    Operator shape;          // sampledRigid in d - d0: the output's motion within the chain's frame
    // C0, the chain frame at rest (chainFrame of the rest points): derived, set by `prepare`.
    Eigen::Matrix4d restFrame = Eigen::Matrix4d::Identity();
    Eigen::Matrix4d restFrameInverse = Eigen::Matrix4d::Identity();

    // Sets the derived fields from the others and the goal's rest position. False when the rest points do not
    // span a plane (the goal on the root, or the pole on the root-goal line).
    bool prepare(const Eigen::Vector3d& restGoal);
};

// The three points of a chain and the rest plane's normal as the anchor carries it, and their rates of change.
struct ChainPoints {
    Eigen::Vector3d root, goal, pole, normal = Eigen::Vector3d::Zero();
};

// The chain frame of three points (or of the root, the goal and the normal, `restPlane`); false when they do not
// span a plane (`frame` is then untouched).
bool chainFrame(const ChainPoints& points, bool restPlane, Eigen::Matrix4d& frame);

// The points from the inputs' matrices: the anchor's motion (identity for the world), the goal's world, and the
// pole's world (ignored when the base has no pole output).
ChainPoints chainPoints(const ConstraintBase& base, const Eigen::Matrix4d& anchorMotion,
                        const Eigen::Matrix4d& goalWorld, const Eigen::Matrix4d& poleWorld);

// B for these points. Non-finite when the points span no plane.
Eigen::Matrix4d constraintBase(const ConstraintBase& base, const ChainPoints& points);

// What a base's velocity needs at one set of points, made once for every rate of them (a solve's columns): the
// chain frame, and the shape's own velocity per unit of reach, in world space.
struct BaseLinearization {
    bool restPlane = false;
    Eigen::Vector3d root, x, y, pole, normal;  // pole: q - r
    double reach = 0.0, across = 0.0;          // |g - r|, and the pole's distance from the chain's line (or |x × N|)
    Eigen::Matrix3d frame;                     // [x y z]
    Eigen::Matrix<double, 3, 4> shape;         // C (dG/dd G^-1) C^-1
};
BaseLinearization linearizeBase(const ConstraintBase& base, const ChainPoints& points);

// dB B^-1 (its top three rows; B is rigid, so this is a twist [[omega]x, v]) for points moving at `rate`.
Eigen::Matrix<double, 3, 4> baseVelocity(const BaseLinearization& at, const ChainPoints& rate);

}  // namespace rig

#pragma once
// Random forward-kinematics hierarchies for property tests: random trees, pivots (the origin included),
// rotate orders, joint orients, translation controls on the root and on inner joints, parameters in
// random order; evaluated independently of the graph engine.
#include <algorithm>
#include <array>
#include <random>
#include <span>
#include <vector>

#include <fmt/format.h>
#include <Eigen/Geometry>

#include "test_rigs.h"

namespace rig::test {

struct Channel {
    int joint = 0;
    bool translate = false;
    int axis = 0;  // 0 x, 1 y, 2 z
};

// World matrices `w` of an FK tree whose joint j hangs from parent[j] (-1: none; parents first) at offset[j] plus
// its translate channels t[j], turned by its joint orient after its rotate channels r[j] in its rotate order
// (order[j]: the axes in the order applied, first innermost).
inline void fkWorlds(const std::vector<int>& parent, const std::vector<Eigen::Vector3d>& offset,
                     const std::vector<Eigen::Matrix3d>& orient, const std::vector<std::array<int, 3>>& order,
                     const std::vector<Eigen::Vector3d>& t, const std::vector<Eigen::Vector3d>& r,
                     std::vector<Eigen::Matrix4d>& w)
{
    for (std::size_t j = 0; j < parent.size(); ++j) {
        Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
        for (const int axis : order[j])
            rotation = Eigen::AngleAxisd(r[j][axis], Eigen::Vector3d::Unit(axis)).toRotationMatrix() * rotation;
        Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
        local.block<3, 3>(0, 0) = orient[j] * rotation;
        local.block<3, 1>(0, 3) = offset[j] + t[j];
        w[j] = parent[j] < 0 ? local : w[static_cast<std::size_t>(parent[j])] * local;
    }
}

// A random FK rig: joint j hangs from parent[j] (j > 0) at offset[j], with a joint orient, a rotate
// order and some of its channels as parameters.
struct RandomFk {
    std::vector<int> parent;
    std::vector<Eigen::Vector3d> offset;
    std::vector<Eigen::Matrix3d> orient;
    std::vector<std::array<int, 3>> order;  // the axes in the order applied (first innermost)
    std::vector<Channel> channels;          // in parameter order

    void evaluate(std::span<const double> v, std::vector<Eigen::Matrix4d>& w) const
    {
        std::vector<Eigen::Vector3d> t(parent.size(), Eigen::Vector3d::Zero()),
            r(parent.size(), Eigen::Vector3d::Zero());
        for (std::size_t c = 0; c < channels.size(); ++c)
            (channels[c].translate ? t : r)[static_cast<std::size_t>(channels[c].joint)][channels[c].axis] = v[c];
        fkWorlds(parent, offset, orient, order, t, r, w);
    }
};

inline RandomFk randomFk(std::mt19937& rng)
{
    RandomFk fk;
    const int joints = std::uniform_int_distribution<int>(2, 9)(rng);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const bool rootAtOrigin = std::bernoulli_distribution(0.5)(rng);
    const std::array<std::array<int, 3>, 6> orders{{{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {1, 0, 2}, {2, 1, 0}}};
    for (int j = 0; j < joints; ++j) {
        fk.parent.push_back(j == 0 ? -1 : std::uniform_int_distribution<int>(0, j - 1)(rng));
        const Eigen::Vector3d offset = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 20.0;
        fk.offset.push_back(j == 0 && rootAtOrigin ? Eigen::Vector3d::Zero() : offset);
        const Eigen::Vector3d o(unit(rng), unit(rng), unit(rng));
        fk.orient.push_back(std::bernoulli_distribution(0.5)(rng)
                                ? Eigen::Matrix3d::Identity()
                                : Eigen::AngleAxisd(o.norm(), o.normalized()).toRotationMatrix());
        fk.order.push_back(orders[static_cast<std::size_t>(std::uniform_int_distribution<int>(0, 5)(rng))]);
        // The root always translates and rotates (a motion-capture root); inner joints sometimes translate.
        for (int axis = 0; axis < 3; ++axis) {
            if (j == 0 || std::bernoulli_distribution(0.75)(rng)) fk.channels.push_back({j, false, axis});
            if (j == 0 || std::bernoulli_distribution(0.15)(rng)) fk.channels.push_back({j, true, axis});
        }
    }
    std::shuffle(fk.channels.begin(), fk.channels.end(), rng);  // the parameters in any order
    return fk;
}

inline LambdaRig lambdaRig(const RandomFk& fk, bool parents)
{
    std::vector<RigParameter> parameters;
    for (const Channel& c : fk.channels) {
        const std::string name = fmt::format("j{}.{}{}", c.joint, c.translate ? "translate" : "rotate", "XYZ"[c.axis]);
        parameters.push_back(c.translate ? distance(name) : angle(name));
    }
    std::vector<std::string> outputs;
    for (std::size_t j = 0; j < fk.parent.size(); ++j) outputs.push_back(fmt::format("j{}", j));
    LambdaRig rig(parameters, outputs,
                  [fk](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) { fk.evaluate(v, w); });
    if (parents) rig.setParents(fk.parent);
    return rig;
}

}  // namespace rig::test

#include "inversion/learn/learn_options.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "core/error.h"

namespace rig {

std::string_view ordererName(Orderer orderer) { return orderer == Orderer::talk ? "talk" : "structured"; }

void LearnOptions::validate() const
{
    auto fail = [](std::string_view field, auto value, std::string_view rule) {
        throw Error(fmt::format("LearnOptions::{} = {}: {}", field, value, rule));
    };
    if (!(epsilon > 0) || !std::isfinite(epsilon)) fail("epsilon", epsilon, "must be a positive number");
    if (!(frameRadius > 0) || !std::isfinite(frameRadius))
        fail("frameRadius", frameRadius, "must be a positive number");
    if (samples < 2) fail("samples", samples, "must be at least 2");
    if (maxSamples < samples) fail("maxSamples", maxSamples, "must be at least `samples`");
    if (!(absoluteTolerance > 0) || !std::isfinite(absoluteTolerance))
        fail("absoluteTolerance", absoluteTolerance, "must be a positive number");
    if (!(effectTolerance > 0) || !std::isfinite(effectTolerance))
        fail("effectTolerance", effectTolerance, "must be a positive number");
    if (validationPoses < 0) fail("validationPoses", validationPoses, "must not be negative");
    if (limitPoses < 0) fail("limitPoses", limitPoses, "must not be negative");
    if (threads < 0 || threads > 1024) fail("threads", threads, "must be 0 (all cores) to 1024");
}

double matrixError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double frameRadius)
{
    const Eigen::Matrix4d d = a - b;
    const Eigen::Vector3d origin = d.block<3, 1>(0, 3);
    double worst = origin.norm();
    for (int c = 0; c < 3; ++c) worst = std::max(worst, (origin + frameRadius * d.block<3, 1>(0, c)).norm());
    return worst;
}

}  // namespace rig

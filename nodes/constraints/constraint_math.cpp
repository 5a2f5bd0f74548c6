#include "nodes/constraints/constraint_math.h"

#include <cmath>
#include <map>

namespace rig::constraint {

std::vector<Target> gatherTargets(const ComputeContext& c, AttrId matrices, AttrId weights)
{
    std::map<int, double> weightOf;
    c.forEachElement(weights, [&](int i, const Value& v) { weightOf[i] = std::get<double>(v); });
    std::vector<Target> targets;
    c.forEachElement(matrices, [&](int i, const Value& v) {
        const auto w = weightOf.find(i);
        targets.push_back(Target{i, std::get<Eigen::Matrix4d>(v), w == weightOf.end() ? 1.0 : w->second});
    });
    return targets;
}

Eigen::Matrix4d matrixElement(const ComputeContext& c, AttrId matrices, int index)
{
    Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
    c.forEachElement(matrices, [&](int i, const Value& v) {
        if (i == index) result = std::get<Eigen::Matrix4d>(v);
    });
    return result;
}

double totalWeight(const std::vector<Target>& targets)
{
    double total = 0.0;
    for (const Target& t : targets) total += t.weight;
    return total;
}

std::optional<Eigen::Vector3d> weightedPosition(const std::vector<Target>& targets)
{
    const double total = totalWeight(targets);
    if (!(total > minTotalWeight)) return std::nullopt;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Target& t : targets) sum += t.weight * t.matrix.topRightCorner<3, 1>();
    return Eigen::Vector3d(sum / total);
}

Eigen::Quaterniond rotationOf(const Eigen::Matrix4d& matrix) { return decomposeMatrix(matrix, RotateOrder::xyz).quat; }

std::optional<Eigen::Quaterniond> averageRotation(const std::vector<std::pair<Eigen::Quaterniond, double>>& rotations)
{
    double total = 0.0;
    for (const auto& r : rotations) total += r.second;
    if (!(total > minTotalWeight)) return std::nullopt;
    const Eigen::Quaterniond* reference = nullptr;
    Eigen::Vector4d sum = Eigen::Vector4d::Zero();
    for (const auto& [q, w] : rotations) {
        if (w == 0.0) continue;
        if (!reference) reference = &q;
        const double sign = reference->coeffs().dot(q.coeffs()) < 0.0 ? -1.0 : 1.0;
        sum += (sign * w) * q.coeffs();
    }
    const double norm = sum.norm();
    if (!(norm > 1e-9 * total)) return std::nullopt;
    Eigen::Quaterniond result;
    result.coeffs() = sum / norm;
    return result;
}

Eigen::Matrix4d safeInverse(const Eigen::Matrix4d& matrix)
{
    if (!(std::abs(matrix.determinant()) > 1e-300)) return Eigen::Matrix4d::Identity();
    const Eigen::Matrix4d inverse = matrix.inverse();
    return inverse.allFinite() ? inverse : Eigen::Matrix4d::Identity();
}

Eigen::Vector3d toParentSpace(const Eigen::Matrix4d& parentInverse, const Eigen::Vector3d& worldPoint)
{
    return parentInverse.topLeftCorner<3, 3>() * worldPoint + parentInverse.topRightCorner<3, 1>();
}

Eigen::Matrix3d parentRotation(const Eigen::Matrix4d& parentInverse)
{
    return rotationOf(safeInverse(parentInverse)).toRotationMatrix();
}

Eigen::Vector3d rotateFromWorld(const Eigen::Matrix4d& parentInverse, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order)
{
    const Eigen::Matrix3d local = restFrame(parentInverse, jointOrient).transpose() * world;
    return closestEuler(matrixToEuler(local, order), Eigen::Vector3d::Zero(), order);
}

Eigen::Matrix3d restFrame(const Eigen::Matrix4d& parentInverse, const Eigen::Vector3d& jointOrient)
{
    return parentRotation(parentInverse) * eulerToMatrix(jointOrient, RotateOrder::xyz);
}

}  // namespace rig::constraint

#include "nodes/constraints/constraint_math.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace rig::constraint {

namespace {

// The existing elements of an array input, by logical index.
std::map<int, const Value*> elementsOf(const ComputeContext& c, AttrId a)
{
    std::map<int, const Value*> elements;
    if (a >= 0) c.forEachElement(a, [&](int i, const Value& v) { elements[i] = &v; });
    return elements;
}

template <class T>
T elementOr(const std::map<int, const Value*>& elements, int index, T fallback)
{
    const auto it = elements.find(index);
    return it == elements.end() ? fallback : std::get<T>(*it->second);
}

Eigen::Matrix4d translation(const Eigen::Vector3d& t)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRightCorner<3, 1>() = t;
    return m;
}

Eigen::Matrix4d linear(const Eigen::Matrix3d& l)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = l;
    return m;
}

// Maya's per-target arrays read at one index, with the defaults of absent elements.
struct MayaTargetValues {
    std::map<int, const Value*> translate, rotate, rotateOrder, rotatePivot, rotateTranslate, scale, parentMatrix,
        jointOrient, scaleCompensate, inverseScale;

    MayaTargetValues(const ComputeContext& c, const MayaTargetIds& ids)
        : translate(elementsOf(c, ids.translate)),
          rotate(elementsOf(c, ids.rotate)),
          rotateOrder(elementsOf(c, ids.rotateOrder)),
          rotatePivot(elementsOf(c, ids.rotatePivot)),
          rotateTranslate(elementsOf(c, ids.rotateTranslate)),
          scale(elementsOf(c, ids.scale)),
          parentMatrix(elementsOf(c, ids.parentMatrix)),
          jointOrient(elementsOf(c, ids.jointOrient)),
          scaleCompensate(elementsOf(c, ids.scaleCompensate)),
          inverseScale(elementsOf(c, ids.inverseScale))
    {
    }

    void addIndices(std::map<int, bool>& indices) const
    {
        for (const auto* array : {&translate, &rotate, &rotateOrder, &rotatePivot, &rotateTranslate, &scale,
                                  &parentMatrix, &jointOrient, &scaleCompensate, &inverseScale})
            for (const auto& element : *array) indices.emplace(element.first, false);
    }

    TargetFrame frame(int i) const
    {
        const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
        const Eigen::Vector3d t = elementOr(translate, i, zero);
        const Eigen::Vector3d rp = elementOr(rotatePivot, i, zero);
        const Eigen::Vector3d rpt = elementOr(rotateTranslate, i, zero);
        const Eigen::Matrix4d parent = elementOr(parentMatrix, i, Eigen::Matrix4d(Eigen::Matrix4d::Identity()));
        const auto order = rotateOrderFromIndex(elementOr(rotateOrder, i, 0)).value_or(RotateOrder::xyz);
        Eigen::Matrix3d inverseScaling = Eigen::Matrix3d::Identity();
        if (elementOr(scaleCompensate, i, false)) {
            const Eigen::Vector3d is = elementOr(inverseScale, i, Eigen::Vector3d(Eigen::Vector3d::Ones()));
            for (int k = 0; k < 3; ++k)
                if (is[k] != 0.0) inverseScaling(k, k) = 1.0 / is[k];
        }
        const Eigen::Matrix3d rotation = eulerToMatrix(elementOr(jointOrient, i, zero), RotateOrder::xyz) *
                                         eulerToMatrix(elementOr(rotate, i, zero), order);
        const Eigen::Vector3d s = elementOr(scale, i, Eigen::Vector3d(Eigen::Vector3d::Ones()));
        TargetFrame f;
        f.index = i;
        // A transform's matrix with its scale pivot on its rotate pivot and no rotate axis or shear; a joint's
        // (zero pivots) with its inverse scale: Maya's constraints take no other target inputs.
        f.world = parent * translation(t) * linear(inverseScaling) * translation(rpt + rp) *
                  linear(rotation * s.asDiagonal()) * translation(-rp);
        f.pivot = (parent * (t + rp + rpt).homogeneous()).head<3>();
        return f;
    }
};

// Spherical interpolation from a to b along the arc their signs give (Eigen's slerp takes the short one always).
Eigen::Quaterniond slerpAlong(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b, double t)
{
    const double d = std::clamp(a.coeffs().dot(b.coeffs()), -1.0, 1.0);
    const double theta = std::acos(d);
    Eigen::Quaterniond result;
    if (std::sin(theta) < 1e-12) {
        result.coeffs() = ((1.0 - t) * a.coeffs() + t * b.coeffs()).normalized();
        return result;
    }
    result.coeffs() = (std::sin((1.0 - t) * theta) * a.coeffs() + std::sin(t * theta) * b.coeffs()) / std::sin(theta);
    return result;
}

}  // namespace

std::vector<TargetFrame> gatherFrames(const ComputeContext& c, AttrId matrices, AttrId weights,
                                      const MayaTargetIds& ids)
{
    const auto matrixOf = elementsOf(c, matrices);
    const auto weightOf = elementsOf(c, weights);
    const MayaTargetValues maya(c, ids);
    std::map<int, bool> indices;  // index -> given by targetMatrix
    for (const auto& element : matrixOf) indices[element.first] = true;
    maya.addIndices(indices);
    std::vector<TargetFrame> frames;
    for (const auto& [i, fromMatrix] : indices) {
        TargetFrame f;
        if (fromMatrix) {
            f.index = i;
            f.world = std::get<Eigen::Matrix4d>(*matrixOf.at(i));
            f.pivot = f.world.topRightCorner<3, 1>();
            f.fromMatrix = true;
        } else {
            f = maya.frame(i);
        }
        f.weight = elementOr(weightOf, i, 1.0);
        frames.push_back(f);
    }
    return frames;
}

std::optional<Eigen::Vector3d> weightedPivot(const std::vector<TargetFrame>& frames)
{
    double total = 0.0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const TargetFrame& f : frames) {
        total += f.weight;
        sum += f.weight * f.pivot;
    }
    if (!(total > minTotalWeight)) return std::nullopt;
    return Eigen::Vector3d(sum / total);
}

std::optional<Eigen::Quaterniond> blendRotations(const std::vector<std::pair<Eigen::Quaterniond, double>>& rotations,
                                                 int interpType)
{
    if (interpType != Shortest && interpType != Longest) return averageRotation(rotations);
    double total = 0.0;
    std::optional<Eigen::Quaterniond> blended;
    for (const auto& [q, w] : rotations) {
        if (!(w > 0.0)) continue;
        total += w;
        if (!blended) {
            blended = q;
            continue;
        }
        // slerp the short way when the quaternions share a hemisphere; flip one for the long way.
        Eigen::Quaterniond next = q;
        const bool sameSide = blended->coeffs().dot(q.coeffs()) >= 0.0;
        if (sameSide == (interpType == Longest)) next.coeffs() = -next.coeffs();
        *blended = slerpAlong(*blended, next, w / total);
    }
    if (!(total > minTotalWeight)) return std::nullopt;
    return blended;
}

Eigen::Matrix4d matrixElement(const ComputeContext& c, AttrId matrices, int index)
{
    Eigen::Matrix4d result = Eigen::Matrix4d::Identity();
    c.forEachElement(matrices, [&](int i, const Value& v) {
        if (i == index) result = std::get<Eigen::Matrix4d>(v);
    });
    return result;
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

Eigen::Vector3d rotateFromWorld(const Eigen::Matrix4d& parentInverse, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order)
{
    return rotateFromFrame(safeInverse(parentInverse), world, jointOrient, order);
}

Eigen::Vector3d rotateFromFrame(const Eigen::Matrix4d& parentFrame, const Eigen::Matrix3d& world,
                                const Eigen::Vector3d& jointOrient, RotateOrder order)
{
    const Eigen::Matrix3d rest =
        rotationOf(parentFrame).toRotationMatrix() * eulerToMatrix(jointOrient, RotateOrder::xyz);
    const Eigen::Matrix3d local = rest.transpose() * world;
    return closestEuler(matrixToEuler(local, order), Eigen::Vector3d::Zero(), order);
}

}  // namespace rig::constraint

#include "nodes/constraints/constraint_math.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace rig::constraint {

namespace {

// An array input's elements; none where the node type has no such attribute (a < 0).
template <class T>
ComputeContext::Elements<T> elementsOf(const ComputeContext& c, AttrId a)
{
    return a >= 0 ? c.elements<T>(a) : ComputeContext::Elements<T>(nullptr);
}

template <class T>
void addIndices(const ComputeContext::Elements<T>& elements, std::map<int, bool>& indices)
{
    for (int i = 0; static_cast<std::size_t>(i) < elements.size(); ++i)
        if (elements.has(i)) indices.emplace(i, false);
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
    ComputeContext::Elements<Eigen::Vector3d> translate, rotate, rotatePivot, rotateTranslate, scale, jointOrient,
        inverseScale;
    ComputeContext::Elements<int> rotateOrder;
    ComputeContext::Elements<Eigen::Matrix4d> parentMatrix;
    ComputeContext::Elements<bool> scaleCompensate;

    MayaTargetValues(const ComputeContext& c, const MayaTargetIds& ids)
        : translate(elementsOf<Eigen::Vector3d>(c, ids.translate)),
          rotate(elementsOf<Eigen::Vector3d>(c, ids.rotate)),
          rotatePivot(elementsOf<Eigen::Vector3d>(c, ids.rotatePivot)),
          rotateTranslate(elementsOf<Eigen::Vector3d>(c, ids.rotateTranslate)),
          scale(elementsOf<Eigen::Vector3d>(c, ids.scale)),
          jointOrient(elementsOf<Eigen::Vector3d>(c, ids.jointOrient)),
          inverseScale(elementsOf<Eigen::Vector3d>(c, ids.inverseScale)),
          rotateOrder(elementsOf<int>(c, ids.rotateOrder)),
          parentMatrix(elementsOf<Eigen::Matrix4d>(c, ids.parentMatrix)),
          scaleCompensate(elementsOf<bool>(c, ids.scaleCompensate))
    {
    }

    void addAllIndices(std::map<int, bool>& indices) const
    {
        for (const auto* array :
             {&translate, &rotate, &rotatePivot, &rotateTranslate, &scale, &jointOrient, &inverseScale})
            addIndices(*array, indices);
        addIndices(rotateOrder, indices);
        addIndices(parentMatrix, indices);
        addIndices(scaleCompensate, indices);
    }

    TargetFrame frame(int i) const
    {
        const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
        const Eigen::Vector3d t = translate.valueOr(i, zero);
        const Eigen::Vector3d rp = rotatePivot.valueOr(i, zero);
        const Eigen::Vector3d rpt = rotateTranslate.valueOr(i, zero);
        const Eigen::Matrix4d parent = parentMatrix.valueOr(i, Eigen::Matrix4d(Eigen::Matrix4d::Identity()));
        const auto order = rotateOrderFromIndex(rotateOrder.valueOr(i, 0)).value_or(RotateOrder::xyz);
        Eigen::Matrix3d inverseScaling = Eigen::Matrix3d::Identity();
        if (scaleCompensate.valueOr(i, false)) {
            const Eigen::Vector3d is = inverseScale.valueOr(i, Eigen::Vector3d(Eigen::Vector3d::Ones()));
            for (int k = 0; k < 3; ++k)
                if (is[k] != 0.0) inverseScaling(k, k) = 1.0 / is[k];
        }
        const Eigen::Matrix3d rotation = eulerToMatrix(jointOrient.valueOr(i, zero), RotateOrder::xyz) *
                                         eulerToMatrix(rotate.valueOr(i, zero), order);
        const Eigen::Vector3d s = scale.valueOr(i, Eigen::Vector3d(Eigen::Vector3d::Ones()));
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
    const auto matrixOf = elementsOf<Eigen::Matrix4d>(c, matrices);
    const auto weightOf = elementsOf<double>(c, weights);
    const MayaTargetValues maya(c, ids);
    std::map<int, bool> indices;  // index -> given by targetMatrix
    for (int i = 0; static_cast<std::size_t>(i) < matrixOf.size(); ++i)
        if (matrixOf.has(i)) indices[i] = true;
    maya.addAllIndices(indices);
    std::vector<TargetFrame> frames;
    for (const auto& [i, fromMatrix] : indices) {
        TargetFrame f;
        if (fromMatrix) {
            f.index = i;
            f.world = matrixOf[i];
            f.pivot = f.world.topRightCorner<3, 1>();
            f.fromMatrix = true;
        } else {
            f = maya.frame(i);
        }
        f.weight = weightOf.valueOr(i, 1.0);
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
    return c.elements<Eigen::Matrix4d>(matrices).valueOr(index, Eigen::Matrix4d::Identity());
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

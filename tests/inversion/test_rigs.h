#pragma once
// Small rigs written directly in C++ as RigFunctions: closed-form expectations for the learner and
// the solver, without the graph.

#include <cmath>
#include <functional>
#include <numbers>

#include <Eigen/Geometry>

#include "inversion/model/rig_function.h"

namespace rig::test {

// A rig from a function of the parameter values; counts evaluations.
class LambdaRig : public RigFunction {
public:
    using Function = std::function<void(std::span<const double>, std::vector<Eigen::Matrix4d>&)>;
    LambdaRig(std::vector<RigParameter> parameters, std::vector<std::string> outputs, Function f)
        : parameters_(std::move(parameters)), outputs_(std::move(outputs)), f_(std::move(f))
    {
    }
    const std::vector<RigParameter>& parameters() const override { return parameters_; }
    const std::vector<std::string>& outputs() const override { return outputs_; }
    void evaluate(std::span<const double> values, std::vector<Eigen::Matrix4d>& worlds) override
    {
        ++count_;
        worlds.resize(outputs_.size());
        f_(values, worlds);
    }
    std::uint64_t evaluationCount() const override { return count_; }
    std::string fingerprint() const override { return "test-rig"; }
    std::vector<int> outputParents() const override
    {
        return parents_.empty() ? RigFunction::outputParents() : parents_;
    }
    // The joint hierarchy among the outputs (RigFunction::outputParents); none by default.
    void setParents(std::vector<int> parents) { parents_ = std::move(parents); }

private:
    std::vector<int> parents_;
    std::vector<RigParameter> parameters_;
    std::vector<std::string> outputs_;
    Function f_;
    std::uint64_t count_ = 0;
};

inline Eigen::Matrix4d translation(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 1>(0, 3) = Eigen::Vector3d(x, y, z);
    return m;
}

inline Eigen::Matrix4d rotation(const Eigen::Vector3d& axis, double angle)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 3>(0, 0) = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    return m;
}

inline RigParameter angle(const std::string& name, double lo = -1.5, double hi = 1.5, double rest = 0.0)
{
    return {name, rest, lo, hi, true};
}

inline RigParameter distance(const std::string& name, double lo = -20, double hi = 20)
{
    return {name, 0.0, lo, hi, false};
}

// An FK arm: root translate X; shoulder rotate X, Y, Z (Z applied first: R = Rx Ry Rz); elbow rotate Z
// (then a fixed 20 degree orient about Y); wrist rotate X. Joints at 10 cm intervals along X.
inline LambdaRig fkArm()
{
    return LambdaRig(
        {distance("root.translateX"), angle("shoulder.rotateX"), angle("shoulder.rotateY"), angle("shoulder.rotateZ"),
         angle("elbow.rotateZ", 0.0, 2.5), angle("wrist.rotateX")},
        {"shoulder", "elbow", "wrist", "hand"}, [](std::span<const double> v, std::vector<Eigen::Matrix4d>& w) {
            const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                                  z = Eigen::Vector3d::UnitZ();
            w[0] = translation(v[0], 100, 0) * rotation(x, v[1]) * rotation(y, v[2]) * rotation(z, v[3]);
            w[1] = w[0] * translation(10, 0, 0) * rotation(y, 20 * std::numbers::pi / 180) * rotation(z, v[4]);
            w[2] = w[1] * translation(10, 0, 0) * rotation(x, v[5]);
            w[3] = w[2] * translation(10, 0, 0);
        });
}

}  // namespace rig::test

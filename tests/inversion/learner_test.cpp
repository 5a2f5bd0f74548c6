// The learner on rigs whose answers are known in closed form.
#include <doctest/doctest.h>

#include <numbers>
#include <random>

#include "inversion/learner.h"
#include "test_rigs.h"

using namespace rig;

namespace {

const ModelledParameter& find(const Approximation& a, const std::string& name)
{
    for (const auto& p : a.parameters)
        if (p.parameter.name == name) return p;
    FAIL("not modelled: " << name);
    return a.parameters.front();
}

int position(const Approximation& a, const std::string& name)
{
    for (std::size_t i = 0; i < a.parameters.size(); ++i)
        if (a.parameters[i].parameter.name == name) return static_cast<int>(i);
    return -1;
}

}  // namespace

TEST_CASE("learner: an FK arm is modelled exactly, axes and pivots to 1e-9, in composition order")
{
    for (Orderer orderer : {Orderer::talk, Orderer::structured}) {
        CAPTURE(ordererName(orderer));
        auto arm = test::fkArm();
        LearnOptions options;
        options.orderer = orderer;
        const Approximation a = learnApproximation(arm, options, "arm");
        REQUIRE(a.parameters.size() == 6);
        CHECK(a.discarded.empty());
        CHECK(find(a, "root.translateX").form == "translation");
        CHECK((find(a, "root.translateX").operators[0].axis - Eigen::Vector3d::UnitX()).norm() < 1e-9);
        CHECK(find(a, "root.translateX").operators[0].slope == doctest::Approx(1.0));
        for (const char* name : {"shoulder.rotateX", "shoulder.rotateY", "shoulder.rotateZ", "elbow.rotateZ", "wrist.rotateX"})
            CHECK(find(a, name).form == "rotation");
        const Operator& elbow = find(a, "elbow.rotateZ").operators[0];
        // The elbow's axis at rest: Z turned 20 degrees about Y; its pivot on that axis through (10, 100, 0).
        const double t = 20 * std::numbers::pi / 180;
        CHECK((elbow.axis - Eigen::Vector3d(std::sin(t), 0, std::cos(t))).norm() < 1e-9);
        CHECK((elbow.pivot - Eigen::Vector3d(10, 100, 0)).cross(elbow.axis).norm() < 1e-9);
        CHECK(elbow.slope == doctest::Approx(1.0));
        // Outer to inner: root, shoulder X, Y, Z, elbow, wrist.
        CHECK(position(a, "root.translateX") < position(a, "shoulder.rotateX"));
        CHECK(position(a, "shoulder.rotateX") < position(a, "shoulder.rotateY"));
        CHECK(position(a, "shoulder.rotateY") < position(a, "shoulder.rotateZ"));
        CHECK(position(a, "shoulder.rotateZ") < position(a, "elbow.rotateZ"));
        CHECK(position(a, "elbow.rotateZ") < position(a, "wrist.rotateX"));
        CHECK(a.validation.maxPositionErrorCm < 1e-6);
        CHECK(a.validation.maxRotationErrorDeg < 1e-6);
        MESSAGE(ordererName(orderer) << ": " << a.training.evaluations << " evaluations, " << a.training.orderEvaluations
                                     << " for the order");
    }
}

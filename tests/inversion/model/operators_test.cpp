// Operators and splines: closed forms, P(0) = I, and analytic derivatives against finite differences.
#include <doctest/doctest.h>

#include <numbers>

#include <Eigen/Geometry>

#include "inversion/model/operators.h"

using namespace rig;

namespace {

CubicSpline<1> curve()
{
    return CubicSpline<1>({-1.0, 0.0, 0.5, 1.5}, {CubicSpline<1>::Vector(-0.8), CubicSpline<1>::Vector(0.0),
                                                  CubicSpline<1>::Vector(0.3), CubicSpline<1>::Vector(1.9)});
}

std::vector<Operator> everyKind()
{
    std::vector<Operator> ops;
    Operator t;
    t.kind = OperatorKind::translation;
    t.axis = Eigen::Vector3d(1, 2, 2).normalized();
    t.slope = 3.0;
    ops.push_back(t);
    Operator r;
    r.kind = OperatorKind::rotation;
    r.axis = Eigen::Vector3d(0, 1, 1).normalized();
    r.pivot = Eigen::Vector3d(5, -2, 7);
    r.curve = curve();
    ops.push_back(r);
    Operator s;
    s.kind = OperatorKind::axisScale;
    s.axis = Eigen::Vector3d(1, 0, 1).normalized();
    s.pivot = Eigen::Vector3d(1, 2, 3);
    s.slope = 0.4;
    ops.push_back(s);
    Operator u = s;
    u.kind = OperatorKind::uniformScale;
    u.curve = curve();
    ops.push_back(u);
    Operator rigid;
    rigid.kind = OperatorKind::sampledRigid;
    std::vector<CubicSpline<6>::Vector> rv;
    for (double a : {-1.0, 0.0, 0.7, 1.4}) {
        CubicSpline<6>::Vector v;
        v << 0.9 * a, 0.2 * a * a, -0.3 * a, 4 * a, a * a, -2 * a;
        rv.push_back(v);
    }
    rigid.rigid = CubicSpline<6>({-1.0, 0.0, 0.7, 1.4}, rv);
    ops.push_back(rigid);
    Operator affine;
    affine.kind = OperatorKind::sampledAffine;
    std::vector<CubicSpline<12>::Vector> av;
    for (double a : {-1.0, 0.0, 1.0}) {
        CubicSpline<12>::Vector v;
        for (int i = 0; i < 12; ++i) v[i] = a * (0.1 * i - 0.5) + a * a * 0.05 * i;
        av.push_back(v);
    }
    affine.affine = CubicSpline<12>({-1.0, 0.0, 1.0}, av);
    ops.push_back(affine);
    return ops;
}

}  // namespace

TEST_CASE("cubic spline: through the knots, natural ends, linear beyond, derivative by finite differences")
{
    const auto s = curve();
    CHECK(s.value(-1.0)[0] == doctest::Approx(-0.8));
    CHECK(s.value(0.5)[0] == doctest::Approx(0.3));
    CHECK(s.value(1.5)[0] == doctest::Approx(1.9));
    // Beyond the ends: the end slope continues.
    CHECK(s.value(2.5)[0] == doctest::Approx(1.9 + s.derivative(1.5)[0]));
    for (double x = -1.4; x <= 1.9; x += 0.1) {
        const double h = 1e-6;
        CHECK(s.derivative(x)[0] == doctest::Approx((s.value(x + h)[0] - s.value(x - h)[0]) / (2 * h)).epsilon(1e-6));
    }
    // Two knots: a straight line.
    const CubicSpline<1> line({0.0, 2.0}, {CubicSpline<1>::Vector(1.0), CubicSpline<1>::Vector(5.0)});
    CHECK(line.value(0.5)[0] == doctest::Approx(2.0));
    CHECK_THROWS_AS(CubicSpline<1>({0.0, 0.0}, {CubicSpline<1>::Vector(0.0), CubicSpline<1>::Vector(0.0)}), Error);
}

TEST_CASE("operators: P(0) = I, closed forms, and dP/da against central differences for every kind")
{
    for (const Operator& op : everyKind()) {
        CAPTURE(operatorKindName(op.kind));
        CHECK((op.matrix(0.0) - Eigen::Matrix4d::Identity()).norm() < 1e-12);
        for (double a = -1.3; a <= 1.6; a += 0.13) {
            const double h = 1e-6;
            const Eigen::Matrix4d fd = (op.matrix(a + h) - op.matrix(a - h)) / (2 * h);
            CHECK((op.derivative(a) - fd).norm() < 1e-6 * (1 + fd.norm()));
        }
    }
    const auto ops = everyKind();
    // Rotation: the pivot is fixed, points turn about the axis by m(a).
    const Operator& r = ops[1];
    CHECK((r.matrix(0.9) * Eigen::Vector4d(5, -2, 7, 1) - Eigen::Vector4d(5, -2, 7, 1)).norm() < 1e-12);
    const Eigen::Vector3d p(6, -2, 7);
    const Eigen::Vector3d moved = (r.matrix(0.5) * p.homogeneous()).head<3>();
    CHECK((moved - (r.pivot + Eigen::AngleAxisd(0.3, r.axis) * (p - r.pivot))).norm() < 1e-12);
    // Translation: slope * a along the axis.
    CHECK((ops[0].matrix(2.0).block<3, 1>(0, 3) - 6.0 * ops[0].axis).norm() < 1e-12);
    // Axis scale: 1 + m along the axis, 1 across, about the pivot.
    const Eigen::Vector3d q = ops[2].pivot + 2.0 * ops[2].axis + Eigen::Vector3d(0, 1, 0);
    const Eigen::Vector3d scaled = (ops[2].matrix(1.0) * q.homogeneous()).head<3>();
    CHECK((scaled - (ops[2].pivot + 2.8 * ops[2].axis + Eigen::Vector3d(0, 1, 0))).norm() < 1e-12);
    CHECK(operatorKindFromName("sampledRigid") == OperatorKind::sampledRigid);
    CHECK(!operatorKindFromName("twirl"));
}

namespace {

bool rigidMotion(const Eigen::Matrix4d& m)
{
    const Eigen::Matrix3d l = m.block<3, 3>(0, 0);
    return (l.transpose() * l - Eigen::Matrix3d::Identity()).norm() < 1e-9 && l.determinant() > 0;
}

// Whether P differs anywhere on a few offsets between two operators.
bool differs(const Operator& a, const Operator& b)
{
    for (double x : {-1.1, -0.4, 0.3, 0.9, 1.3})
        if ((a.matrix(x) - b.matrix(x)).norm() > 1e-9) return true;
    return false;
}

}  // namespace

TEST_CASE("operator kind traits: one row per kind, in enum order, each flag true to the kind's matrices")
{
    const auto ops = everyKind();
    REQUIRE(ops.size() == operatorKindTraits.size());
    for (std::size_t k = 0; k < ops.size(); ++k) {
        const Operator& op = ops[k];
        const OperatorKindTraits& t = op.traits();
        CAPTURE(t.name);
        CHECK(static_cast<std::size_t>(op.kind) == k);
        CHECK(t.kind == op.kind);
        CHECK(operatorKindName(op.kind) == t.name);
        CHECK(operatorKindFromName(t.name) == op.kind);
        CHECK(t.valuesPerKnot == (t.sampled ? (t.rigid ? 6 : 12) : 1));
        bool rigid = true;
        for (double a = -1.3; a <= 1.6; a += 0.13) rigid = rigid && rigidMotion(op.matrix(a));
        CHECK(rigid == t.rigid);
        Operator turned = op;
        turned.axis = Eigen::Vector3d(0.6, 0.0, -0.8);
        CHECK(differs(op, turned) == t.hasAxis);
        Operator moved = op;
        moved.pivot += Eigen::Vector3d(3, -1, 2);
        CHECK(differs(op, moved) == t.hasPivot);
        // A sampled kind has no magnitude: neither slope nor curve changes it.
        Operator sloped = op;
        sloped.curve = CubicSpline<1>();
        sloped.slope = 0.7;
        CHECK(differs(op, sloped) == !t.sampled);
        // Angular: a whole turn of a linear magnitude gives P again.
        const double turn = 2.0 * std::numbers::pi / sloped.slope;
        CHECK(((sloped.matrix(0.4 + turn) - sloped.matrix(0.4)).norm() < 1e-9) == t.angular);
    }
}

TEST_CASE("rotation vectors: exp, log and the left Jacobian")
{
    const Eigen::Vector3d r(0.3, -1.1, 0.7);
    CHECK((rotationVector(rotationFromVector(r)) - r).norm() < 1e-12);
    // d exp(r + t v)/dt at 0 = [J(r) v]x exp(r).
    const Eigen::Vector3d v(0.2, 0.5, -0.4);
    const double h = 1e-6;
    const Eigen::Matrix3d fd = (rotationFromVector(r + h * v) - rotationFromVector(r - h * v)) / (2 * h);
    const Eigen::Vector3d w = leftJacobian(r) * v;
    Eigen::Matrix3d k;
    k << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
    CHECK((k * rotationFromVector(r) - fd).norm() < 1e-8);
}

// The SO(3) and matrix helpers: closed-form expectations.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>

#include <Eigen/Geometry>
#include <Eigen/SVD>

#include "core/rotation_math.h"

using namespace rig;

TEST_CASE("rotation math: skew is the cross product")
{
    const Eigen::Vector3d v(0.3, -1.2, 2.5), w(-0.7, 0.4, 1.1);
    CHECK((skew(v) * w - v.cross(w)).norm() < 1e-15);
    CHECK((skew(v) + skew(v).transpose()).norm() == 0.0);
}

TEST_CASE("rotation math: the polar decomposition gives the rotation and the symmetric stretch back")
{
    const Eigen::Matrix3d q = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
    Eigen::Matrix3d s;
    s << 2.0, 0.3, -0.1, 0.3, 1.5, 0.2, -0.1, 0.2, 0.7;  // symmetric positive definite
    Eigen::Matrix3d symmetric;
    const Eigen::Matrix3d found = polarRotation(q * s, &symmetric);
    CHECK((found - q).norm() < 1e-12);
    CHECK((symmetric - s).norm() < 1e-12);
    // A reflection is removed: the nearest proper rotation, determinant +1.
    const Eigen::Matrix3d mirrored = q * Eigen::Vector3d(1, 1, -1).asDiagonal();
    CHECK(polarRotation(mirrored).determinant() == doctest::Approx(1.0));
}

TEST_CASE("rotation math: the polar rotation by Newton's iteration is the SVD's, scaled, sheared, mirrored or singular")
{
    // The oracle: Q = U V^T of the SVD of A (of -A for a reflection), as polarRotation took it before Newton's steps.
    const auto bySvd = [](const Eigen::Matrix3d& a) {
        const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a.determinant() < 0 ? Eigen::Matrix3d(-a) : a,
                                                    Eigen::ComputeFullU | Eigen::ComputeFullV);
        Eigen::Matrix3d u = svd.matrixU();
        if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
        return Eigen::Matrix3d(u * svd.matrixV().transpose());
    };
    std::mt19937 rng(7301);
    std::normal_distribution<double> normal;
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
        const Eigen::Matrix3d r =
            Eigen::Quaterniond(Eigen::Vector4d(normal(rng), normal(rng), normal(rng), normal(rng)).normalized())
                .toRotationMatrix();
        // A uniform scale from 1e-3 to 1e3 (negative: a mirror), a stretch from none to strong.
        const double scale = std::pow(10.0, 3.0 * std::uniform_real_distribution<double>(-1, 1)(rng));
        const double stretch = std::array{0.0, 1e-7, 1e-3, 0.3}[static_cast<std::size_t>(i % 4)];
        Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
        for (int k = 0; k < 3; ++k)
            for (int l = 0; l < 3; ++l) s(k, l) += stretch * normal(rng);
        s = 0.5 * (s + s.transpose());
        const Eigen::Matrix3d a = (i % 3 == 0 ? -scale : scale) * r * s;
        Eigen::Matrix3d symmetric;
        const Eigen::Matrix3d q = polarRotation(a, &symmetric);
        worst = std::max(worst, (q - bySvd(a)).cwiseAbs().maxCoeff());
        CHECK((q * symmetric - a).cwiseAbs().maxCoeff() <= 1e-12 * a.cwiseAbs().maxCoeff());
    }
    CHECK(worst < 1e-13);
    // A singular block (a joint scaled to zero on one axis): the SVD's answer, a proper rotation.
    const Eigen::Matrix3d flat = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, 1, -0.2).normalized()).toRotationMatrix() *
                                 Eigen::Vector3d(2, 1, 0).asDiagonal();
    CHECK(polarRotation(flat) == bySvd(flat));
    CHECK(polarRotation(flat).determinant() == doctest::Approx(1.0));
}

TEST_CASE("rotation math: a reflection's orientation is the negated block's, continuous where its scales cross")
{
    const Eigen::Matrix3d q = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, 2, -1).normalized()).toRotationMatrix();
    // A scale of -1 drifting by 1e-7 between the axes, its smallest magnitude on z, then on x: removing the reflection
    // along the smallest singular value's axis gave orientations a half turn apart.
    const Eigen::Matrix3d zSmallest = -q * Eigen::Vector3d(1 + 8e-8, 1, 1 - 4e-8).asDiagonal();
    const Eigen::Matrix3d xSmallest = -q * Eigen::Vector3d(1 - 4e-8, 1, 1 + 8e-8).asDiagonal();
    Eigen::Matrix3d symmetric;
    CHECK((polarRotation(zSmallest, &symmetric) - q).norm() < 1e-6);
    CHECK((polarRotation(xSmallest) - q).norm() < 1e-6);
    CHECK((q * symmetric - zSmallest).norm() < 1e-12);  // negative definite
    CHECK(orientationAngle(zSmallest, xSmallest) < 1e-6);
    CHECK((orthonormalOrientation(-q) - q).norm() == 0.0);
}

TEST_CASE("rotation math: the angle between orientations ignores scale and is accurate near zero")
{
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, -1, 0.5).normalized();
    const Eigen::Matrix3d a = Eigen::AngleAxisd(0.4, axis).toRotationMatrix();
    const Eigen::Matrix3d b = Eigen::AngleAxisd(0.4 + 0.3, axis).toRotationMatrix() * 3.0;
    CHECK(orientationAngle(a, b) == doctest::Approx(0.3).epsilon(1e-12));
    const Eigen::Matrix3d tiny = Eigen::AngleAxisd(1e-9, axis).toRotationMatrix();
    CHECK(orientationAngle(Eigen::Matrix3d::Identity(), tiny) == doctest::Approx(1e-9).epsilon(1e-6));
    CHECK(orientationAngle(a, a) == 0.0);
}

TEST_CASE("rotation math: a rotation up to rounding is taken as it is, a mirrored one still loses its mirror")
{
    const Eigen::Vector3d axis = Eigen::Vector3d(0.7, 0.1, -0.3).normalized();
    const Eigen::Matrix3d a = Eigen::AngleAxisd(1.1, axis).toRotationMatrix();
    Eigen::Matrix3d drifted = Eigen::AngleAxisd(1.1 + 0.25, axis).toRotationMatrix();
    drifted(0, 1) += 2e-11;  // a product of rigid operators' rounding
    CHECK(nearlyOrthonormal(drifted));
    CHECK_FALSE(nearlyOrthonormal(1.001 * drifted));
    CHECK(orientationAngle(a, drifted) == doctest::Approx(0.25).epsilon(1e-9));
    // A reflection is orthonormal too: its orientation (the negated block, without an SVD) is its polar rotation's,
    // as for any other block.
    const Eigen::Matrix3d mirror = Eigen::Vector3d(1, 1, -1).asDiagonal();
    CHECK(nearlyOrthonormal(a * mirror));
    CHECK((orthonormalOrientation(a * mirror) - polarRotation(a * mirror)).norm() < 1e-12);
    CHECK(orientationAngle(a * mirror, polarRotation(a * mirror)) < 1e-12);
}

TEST_CASE("rotation math: an angle moved by whole turns to the one nearest a reference")
{
    constexpr double pi = std::numbers::pi;
    CHECK(nearestTurn(0.1, 4 * pi) == doctest::Approx(0.1 + 4 * pi));
    CHECK(nearestTurn(-3.0, 3.0) == doctest::Approx(-3.0 + 2 * pi));
    CHECK(nearestTurn(250.0, 0.0, 360.0) == doctest::Approx(-110.0));
    CHECK(nearestTurn(1.0, 1.2) == 1.0);
}

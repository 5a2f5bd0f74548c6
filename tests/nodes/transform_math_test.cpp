#include "nodes/transform_math.h"

#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <random>

using rig::RotateOrder;

namespace {

constexpr double pi = std::numbers::pi;
constexpr double tolerance = 1e-9;

constexpr std::array<RotateOrder, 6> allOrders{RotateOrder::xyz, RotateOrder::yzx, RotateOrder::zxy,
                                               RotateOrder::xzy, RotateOrder::yxz, RotateOrder::zyx};

double deg(double degrees) { return degrees * pi / 180.0; }

// Elementary rotations written out by hand, independent of the code under test.
Eigen::Matrix3d rotX(double a)
{
    Eigen::Matrix3d m;
    m << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
    return m;
}

Eigen::Matrix3d rotY(double a)
{
    Eigen::Matrix3d m;
    m << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
    return m;
}

Eigen::Matrix3d rotZ(double a)
{
    Eigen::Matrix3d m;
    m << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
    return m;
}

Eigen::Matrix4d translate(double x, double y, double z)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
    return m;
}

Eigen::Matrix4d linear4(const Eigen::Matrix3d& linear)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = linear;
    return m;
}

Eigen::Vector3d transformPoint(const Eigen::Matrix4d& m, const Eigen::Vector3d& p)
{
    return (m * p.homogeneous()).head<3>();
}

template <typename A, typename B>
bool near(const A& actual, const B& expected, double tol = tolerance)
{
    return (actual - expected).cwiseAbs().maxCoeff() <= tol;
}

Eigen::Vector3d randomAngles(std::mt19937& rng)
{
    std::uniform_real_distribution<double> angle(-pi, pi);
    return {angle(rng), angle(rng), angle(rng)};
}

}  // namespace

TEST_CASE("rotate order names and Maya indices")
{
    CHECK(static_cast<int>(RotateOrder::xyz) == 0);
    CHECK(static_cast<int>(RotateOrder::yzx) == 1);
    CHECK(static_cast<int>(RotateOrder::zxy) == 2);
    CHECK(static_cast<int>(RotateOrder::xzy) == 3);
    CHECK(static_cast<int>(RotateOrder::yxz) == 4);
    CHECK(static_cast<int>(RotateOrder::zyx) == 5);
    for (const RotateOrder order : allOrders) {
        CHECK(rig::rotateOrderFromName(rig::rotateOrderName(order)) == order);
        CHECK(rig::rotateOrderFromIndex(static_cast<int>(order)) == order);
    }
    CHECK(rig::rotateOrderName(RotateOrder::yxz) == "yxz");
    CHECK(rig::rotateOrderFromName("ZXY") == RotateOrder::zxy);
    CHECK_FALSE(rig::rotateOrderFromName("xxy").has_value());
    CHECK_FALSE(rig::rotateOrderFromName("xyzw").has_value());
    CHECK_FALSE(rig::rotateOrderFromIndex(6).has_value());
    CHECK_FALSE(rig::rotateOrderFromIndex(-1).has_value());
}

TEST_CASE("eulerToMatrix matches hand-written products for every order")
{
    const double rx = deg(30);
    const double ry = deg(45);
    const double rz = deg(60);
    const Eigen::Vector3d angles(rx, ry, rz);
    const Eigen::Matrix3d x = rotX(rx);
    const Eigen::Matrix3d y = rotY(ry);
    const Eigen::Matrix3d z = rotZ(rz);

    // First letter acts first, so it is the rightmost factor.
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::xyz), Eigen::Matrix3d(z * y * x)));
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::yzx), Eigen::Matrix3d(x * z * y)));
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::zxy), Eigen::Matrix3d(y * x * z)));
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::xzy), Eigen::Matrix3d(y * z * x)));
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::yxz), Eigen::Matrix3d(z * x * y)));
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::zyx), Eigen::Matrix3d(x * y * z)));

    // Fully numeric values (cos/sin of 30, 45, 60 degrees multiplied out).
    const double r2 = std::sqrt(2.0);
    const double r6 = std::sqrt(6.0);
    Eigen::Matrix3d xyz;
    xyz << r2 / 4, -0.573223304703363, 0.739198919740117, r6 / 4, 0.739198919740117, 0.280330085889911, -r2 / 2, r2 / 4,
        r6 / 4;
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::xyz), xyz, 1e-14));
    Eigen::Matrix3d zyx;
    zyx << r2 / 4, -r6 / 4, r2 / 2, 0.926776695296637, 0.126826484044322, -r2 / 4, 0.126826484044322, 0.780330085889911,
        r6 / 4;
    CHECK(near(rig::eulerToMatrix(angles, RotateOrder::zyx), zyx, 1e-14));
}

TEST_CASE("eulerToMatrix applies the first axis of the order first")
{
    const Eigen::Vector3d unitY = Eigen::Vector3d::UnitY();
    // X by 90 takes +Y to +Z, then Y by 90 takes +Z to +X.
    CHECK(near(rig::eulerToMatrix({deg(90), deg(90), 0}, RotateOrder::xyz) * unitY, Eigen::Vector3d::UnitX()));
    // The other way round: Y leaves +Y alone, then X takes it to +Z.
    CHECK(near(rig::eulerToMatrix({deg(90), deg(90), 0}, RotateOrder::yxz) * unitY, Eigen::Vector3d::UnitZ()));
}

TEST_CASE("90 degrees about Z maps +X to +Y for every order")
{
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        CHECK(near(rig::eulerToMatrix({0, 0, deg(90)}, order) * Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY()));
    }
}

TEST_CASE("matrixToEuler round trips random rotations")
{
    std::mt19937 rng(1234);
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        for (int n = 0; n < 500; ++n) {
            const Eigen::Vector3d angles = randomAngles(rng);
            const Eigen::Matrix3d rotation = rig::eulerToMatrix(angles, order);
            const Eigen::Vector3d back = rig::matrixToEuler(rotation, order);
            CHECK(near(rig::eulerToMatrix(back, order), rotation));
        }
    }
}

TEST_CASE("matrixToEuler returns the principal solution unchanged")
{
    const Eigen::Vector3d angles(deg(-170), deg(80), deg(25));
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        // Reorder so the middle (second applied) angle is the one within +-90.
        Eigen::Vector3d input;
        const std::string_view name = rig::rotateOrderName(order);
        input[name[0] - 'x'] = angles[0];
        input[name[1] - 'x'] = angles[1];
        input[name[2] - 'x'] = angles[2];
        CHECK(near(rig::matrixToEuler(rig::eulerToMatrix(input, order), order), input));
    }
}

TEST_CASE("matrixToEuler at gimbal lock")
{
    std::mt19937 rng(99);
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        const std::string_view name = rig::rotateOrderName(order);
        const int middle = name[1] - 'x';
        for (const double lock : {deg(90), deg(-90)}) {
            for (int n = 0; n < 50; ++n) {
                Eigen::Vector3d angles = randomAngles(rng);
                angles[middle] = lock;
                const Eigen::Matrix3d rotation = rig::eulerToMatrix(angles, order);
                const Eigen::Vector3d back = rig::matrixToEuler(rotation, order);
                CHECK(back.allFinite());
                CHECK(std::abs(back[middle] - lock) < 1e-6);
                CHECK(near(rig::eulerToMatrix(back, order), rotation));
            }
        }
    }
}

TEST_CASE("closestEuler unwraps toward the reference")
{
    const Eigen::Vector3d euler(0.1, 0.2, 0.3);
    const Eigen::Vector3d reference(0.1 + 2 * pi, 0.2 - 2 * pi, 0.3 + 4 * pi);
    CHECK(near(rig::closestEuler(euler, reference, RotateOrder::xyz), reference));
}

TEST_CASE("closestEuler recovers the flipped solution")
{
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        const std::string_view name = rig::rotateOrderName(order);
        // Middle angle beyond 90 degrees: matrixToEuler must return the other solution.
        Eigen::Vector3d original;
        original[name[0] - 'x'] = 0.5;
        original[name[1] - 'x'] = 2.0;
        original[name[2] - 'x'] = -0.4;
        const Eigen::Vector3d principal = rig::matrixToEuler(rig::eulerToMatrix(original, order), order);
        CHECK_FALSE(near(principal, original, 1e-3));
        CHECK(near(rig::closestEuler(principal, original, order), original));
    }
}

TEST_CASE("closestEuler stays within pi of the reference and keeps the rotation")
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> wide(-4 * pi, 4 * pi);
    for (const RotateOrder order : allOrders) {
        CAPTURE(rig::rotateOrderName(order));
        for (int n = 0; n < 200; ++n) {
            const Eigen::Vector3d angles = randomAngles(rng);
            const Eigen::Vector3d reference(wide(rng), wide(rng), wide(rng));
            const Eigen::Matrix3d rotation = rig::eulerToMatrix(angles, order);
            const Eigen::Vector3d result = rig::closestEuler(angles, reference, order);
            CHECK((result - reference).cwiseAbs().maxCoeff() <= pi + 1e-12);
            CHECK(near(rig::eulerToMatrix(result, order), rotation));
        }
    }
}

TEST_CASE("transformMatrix defaults to identity")
{
    CHECK(near(rig::transformMatrix({}), Eigen::Matrix4d::Identity()));
}

TEST_CASE("transformMatrix keeps the rotate pivot fixed")
{
    rig::TransformInputs in;
    in.rotate = {deg(20), deg(-35), deg(70)};
    in.rotateOrder = RotateOrder::zxy;
    in.rotatePivot = {3, -2, 5};
    const Eigen::Matrix4d m = rig::transformMatrix(in);
    CHECK(near(transformPoint(m, in.rotatePivot), in.rotatePivot));
    CHECK(near(m.topLeftCorner<3, 3>(), rig::eulerToMatrix(in.rotate, in.rotateOrder)));
}

TEST_CASE("transformMatrix scales about the scale pivot")
{
    rig::TransformInputs in;
    in.scale = {2, 3, 4};
    in.scalePivot = {1, 1, 1};
    const Eigen::Matrix4d m = rig::transformMatrix(in);
    CHECK(near(transformPoint(m, {1, 1, 1}), Eigen::Vector3d(1, 1, 1)));
    // (2, 2, 2) is (1, 1, 1) away from the pivot, so it lands at pivot + scale.
    CHECK(near(transformPoint(m, {2, 2, 2}), Eigen::Vector3d(3, 4, 5)));
}

TEST_CASE("transformMatrix hand-computed translate, rotate, scale and pivots")
{
    rig::TransformInputs in;
    in.translate = {10, 0, 0};
    in.rotate = {0, 0, deg(90)};
    in.scale = {2, 2, 2};
    in.rotatePivot = {1, 0, 0};
    in.scalePivot = {1, 0, 0};
    // Origin: scaled about (1,0,0) -> (-1,0,0); rotated 90 about (1,0,0) -> (1,-2,0);
    // translated -> (11,-2,0). Linear part is Rz(90) * 2.
    Eigen::Matrix4d expected;
    expected << 0, -2, 0, 11, 2, 0, 0, -2, 0, 0, 2, 0, 0, 0, 0, 1;
    const Eigen::Matrix4d m = rig::transformMatrix(in);
    CHECK(near(m, expected));
    CHECK(near(transformPoint(m, {2, 0, 0}), Eigen::Vector3d(11, 2, 0)));
}

TEST_CASE("transformMatrix pivot translates, rotate axis and shear")
{
    SUBCASE("scale pivot translate is rotated, rotate pivot translate is not")
    {
        rig::TransformInputs in;
        in.rotate = {0, 0, deg(90)};
        in.scalePivotTranslate = {1, 0, 0};
        in.rotatePivotTranslate = {0, 0, 1};
        CHECK(near(transformPoint(rig::transformMatrix(in), Eigen::Vector3d::Zero()), Eigen::Vector3d(0, 1, 1)));
    }
    SUBCASE("rotate axis acts before rotate")
    {
        rig::TransformInputs in;
        in.rotate = {deg(90), 0, 0};
        in.rotateAxis = {0, 0, deg(90)};
        // Rz(90): +X -> +Y, then Rx(90): +Y -> +Z.
        CHECK(near(transformPoint(rig::transformMatrix(in), Eigen::Vector3d::UnitX()), Eigen::Vector3d::UnitZ()));
    }
    SUBCASE("shear follows scale, xy adds y to x")
    {
        rig::TransformInputs in;
        in.scale = {1, 2, 1};
        in.shear = {0.5, 0.25, 0.75};
        // (0,1,0) -> scale (0,2,0) -> shear (0.5*2, 2, 0).
        CHECK(near(transformPoint(rig::transformMatrix(in), {0, 1, 0}), Eigen::Vector3d(1, 2, 0)));
        // (0,0,1) -> (0.25, 0.75, 1).
        CHECK(near(transformPoint(rig::transformMatrix(in), {0, 0, 1}), Eigen::Vector3d(0.25, 0.75, 1)));
    }
}

TEST_CASE("transformMatrix matches the documented composition")
{
    rig::TransformInputs in;
    in.translate = {1, 2, 3};
    in.rotate = {deg(10), deg(20), deg(30)};
    in.rotateOrder = RotateOrder::yxz;
    in.scale = {1.5, 0.5, 2};
    in.shear = {0.1, 0.2, 0.3};
    in.rotatePivot = {-1, 4, 2};
    in.rotatePivotTranslate = {0.5, 0, -0.5};
    in.scalePivot = {2, -3, 1};
    in.scalePivotTranslate = {0, 1, 0};
    in.rotateAxis = {deg(5), deg(-15), deg(25)};

    Eigen::Matrix3d shear;
    shear << 1, 0.1, 0.2, 0, 1, 0.3, 0, 0, 1;
    const Eigen::Matrix3d scale = Eigen::Vector3d(1.5, 0.5, 2).asDiagonal();
    const Eigen::Matrix3d rotate = rotZ(deg(30)) * rotX(deg(10)) * rotY(deg(20));  // yxz
    const Eigen::Matrix3d rotateAxis = rotZ(deg(25)) * rotY(deg(-15)) * rotX(deg(5));
    const Eigen::Matrix4d expected = translate(1, 2, 3) * translate(0.5, 0, -0.5) * translate(-1, 4, 2) *
                                     linear4(rotate * rotateAxis) * translate(1, -4, -2) * translate(0, 1, 0) *
                                     translate(2, -3, 1) * linear4(shear * scale) * translate(-2, 3, -1);
    CHECK(near(rig::transformMatrix(in), expected));
}

TEST_CASE("jointMatrix with joint orient")
{
    SUBCASE("hand example: T * JO * R")
    {
        rig::JointInputs in;
        in.translate = {5, 0, 0};
        in.jointOrient = {0, 0, deg(90)};
        in.rotate = {deg(90), 0, 0};
        // Columns: Rz(90) * Rx(90) sends X -> Y, Y -> Z, Z -> X.
        Eigen::Matrix4d expected;
        expected << 0, 0, 1, 5, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 1;
        CHECK(near(rig::jointMatrix(in), expected));
    }
    SUBCASE("general angles, rotate axis and scale")
    {
        rig::JointInputs in;
        in.translate = {1, -2, 3};
        in.jointOrient = {deg(15), deg(-40), deg(70)};
        in.rotate = {deg(33), deg(12), deg(-48)};
        in.rotateOrder = RotateOrder::zyx;
        in.rotateAxis = {deg(-5), deg(8), deg(11)};
        in.scale = {1, 2, 3};
        const Eigen::Matrix3d jointOrient = rotZ(deg(70)) * rotY(deg(-40)) * rotX(deg(15));
        const Eigen::Matrix3d rotate = rotX(deg(33)) * rotY(deg(12)) * rotZ(deg(-48));  // zyx
        const Eigen::Matrix3d rotateAxis = rotZ(deg(11)) * rotY(deg(8)) * rotX(deg(-5));
        const Eigen::Matrix3d scale = Eigen::Vector3d(1, 2, 3).asDiagonal();
        const Eigen::Matrix4d expected = translate(1, -2, 3) * linear4(jointOrient * rotate * rotateAxis * scale);
        CHECK(near(rig::jointMatrix(in), expected));
    }
}

TEST_CASE("jointMatrix inverse scale compensation")
{
    const Eigen::Matrix4d parent = linear4(Eigen::Vector3d(2, 2, 2).asDiagonal());
    rig::JointInputs in;
    in.translate = {3, 0, 0};
    in.inverseScale = {2, 2, 2};

    // Compensated: the segment length scales with the parent, the child axes do not.
    Eigen::Matrix4d compensated = Eigen::Matrix4d::Identity();
    compensated(0, 3) = 6;
    CHECK(near(parent * rig::jointMatrix(in), compensated));

    in.segmentScaleCompensate = false;
    Eigen::Matrix4d inherited = parent;
    inherited(0, 3) = 6;
    CHECK(near(parent * rig::jointMatrix(in), inherited));
}

TEST_CASE("composeTRS matches T * R * SH * S")
{
    const Eigen::Vector3d rotate(deg(40), deg(-25), deg(100));
    Eigen::Matrix3d shear;
    shear << 1, 0.3, -0.2, 0, 1, 0.6, 0, 0, 1;
    const Eigen::Matrix3d scale = Eigen::Vector3d(2, 0.5, 3).asDiagonal();
    const Eigen::Matrix3d rotation = rotY(deg(-25)) * rotX(deg(40)) * rotZ(deg(100));  // zxy
    const Eigen::Matrix4d expected = translate(4, 5, -6) * linear4(rotation * shear * scale);
    CHECK(near(rig::composeTRS({4, 5, -6}, rotate, RotateOrder::zxy, {2, 0.5, 3}, {0.3, -0.2, 0.6}), expected));
}

TEST_CASE("decomposeMatrix round trips composeTRS")
{
    const Eigen::Vector3d translate(4, -5, 6);
    // Every angle within +-90 so it is the principal solution for all orders.
    const Eigen::Vector3d rotate(deg(40), deg(-25), deg(70));
    const Eigen::Vector3d shear(0.3, -0.2, 0.6);
    SUBCASE("positive and negative-x scale recover the exact inputs")
    {
        for (const RotateOrder order : allOrders) {
            CAPTURE(rig::rotateOrderName(order));
            for (const Eigen::Vector3d& scale : {Eigen::Vector3d(2, 0.5, 3), Eigen::Vector3d(-2, 0.5, 3)}) {
                const Eigen::Matrix4d m = rig::composeTRS(translate, rotate, order, scale, shear);
                const rig::DecomposedMatrix d = rig::decomposeMatrix(m, order);
                CHECK(near(d.translate, translate));
                CHECK(near(d.rotate, rotate));
                CHECK(near(d.scale, scale));
                CHECK(near(d.shear, shear));
                CHECK(near(d.quat.toRotationMatrix(), rig::eulerToMatrix(rotate, order)));
            }
        }
    }
    SUBCASE("reflection on another axis is folded into scale x")
    {
        for (const RotateOrder order : allOrders) {
            CAPTURE(rig::rotateOrderName(order));
            const Eigen::Matrix4d m = rig::composeTRS(translate, rotate, order, {2, -0.5, 3}, shear);
            const rig::DecomposedMatrix d = rig::decomposeMatrix(m, order);
            CHECK(d.scale.x() < 0);
            CHECK(d.scale.y() > 0);
            CHECK(d.scale.z() > 0);
            CHECK(near(d.scale.cwiseAbs(), Eigen::Vector3d(2, 0.5, 3)));
            CHECK(near(rig::composeTRS(d.translate, d.rotate, order, d.scale, d.shear), m));
            CHECK(near(d.quat.toRotationMatrix(), rig::eulerToMatrix(d.rotate, order)));
        }
    }
    SUBCASE("random matrices with shear round trip")
    {
        std::mt19937 rng(5);
        std::uniform_real_distribution<double> range(-2, 2);
        for (const RotateOrder order : allOrders) {
            CAPTURE(rig::rotateOrderName(order));
            for (int n = 0; n < 100; ++n) {
                const Eigen::Vector3d t(range(rng), range(rng), range(rng));
                const Eigen::Vector3d s(range(rng), range(rng), range(rng));
                const Eigen::Vector3d sh(range(rng), range(rng), range(rng));
                const Eigen::Matrix4d m = rig::composeTRS(t, randomAngles(rng), order, s, sh);
                const rig::DecomposedMatrix d = rig::decomposeMatrix(m, order);
                CHECK(near(rig::composeTRS(d.translate, d.rotate, order, d.scale, d.shear), m));
            }
        }
    }
}

TEST_CASE("decomposeMatrix of a hand-built matrix")
{
    // Rz(90) with scale (1, 2, 3) and shear xy = 0.5: columns are
    // Rz * (1,0,0), Rz * (0.5*2, 2, 0), Rz * (0,0,3).
    Eigen::Matrix4d m;
    m << 0, -2, 0, 7, 1, 1, 0, 8, 0, 0, 3, 9, 0, 0, 0, 1;
    const rig::DecomposedMatrix d = rig::decomposeMatrix(m, RotateOrder::xyz);
    CHECK(near(d.translate, Eigen::Vector3d(7, 8, 9)));
    CHECK(near(d.rotate, Eigen::Vector3d(0, 0, deg(90))));
    CHECK(near(d.scale, Eigen::Vector3d(1, 2, 3)));
    CHECK(near(d.shear, Eigen::Vector3d(0.5, 0, 0)));
    CHECK(near(d.quat.coeffs(), Eigen::Vector4d(0, 0, std::sin(deg(45)), std::cos(deg(45)))));
}

TEST_CASE("decomposeMatrix survives a collapsed scale")
{
    const Eigen::Matrix4d m = rig::composeTRS({1, 2, 3}, {deg(30), 0, 0}, RotateOrder::xyz, {2, 0, 1}, {0, 0, 0});
    const rig::DecomposedMatrix d = rig::decomposeMatrix(m, RotateOrder::xyz);
    CHECK(near(d.rotate, Eigen::Vector3d(deg(30), 0, 0)));
    CHECK(near(d.scale, Eigen::Vector3d(2, 0, 1)));
    CHECK(near(d.shear, Eigen::Vector3d::Zero()));
    CHECK(near(rig::composeTRS(d.translate, d.rotate, RotateOrder::xyz, d.scale, d.shear), m));
}

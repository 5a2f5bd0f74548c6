#pragma once
// A natural cubic spline through knots (x_j, y_j), y in R^D, extended linearly beyond the ends.
// Magnitude curves (D = 1) and sampled operators (D = 6 or 12) are made of these.
//
// A knot given twice in a row (x_j == x_j+1) is a break: the curve is made of independent natural cubic
// pieces, each ending at a break with a zero second derivative, so that a kink of the function (a driven key
// whose effect stops in the middle of the control's range) is reproduced instead of rounded. The two values at
// a break are equal (the curve is continuous; only its slope may jump), the first and last knots are never
// repeated, and no knot appears three times. At a break, value and derivative are the right-hand piece's.

#include <span>
#include <vector>

#include <Eigen/Core>

#include "core/error.h"

namespace rig {

template <int D>
class CubicSpline {
public:
    using Vector = Eigen::Matrix<double, D, 1>;

    CubicSpline() = default;

    // x increasing (a break repeated once, as above), at least two knots (two knots: a straight line).
    CubicSpline(std::vector<double> x, std::vector<Vector> y) : x_(std::move(x)), y_(std::move(y))
    {
        const std::size_t n = x_.size();
        if (n < 2 || y_.size() != n) throw internalError("CubicSpline: needs two knots or more, one value each");
        for (std::size_t j = 1; j < n; ++j) {
            if (x_[j] > x_[j - 1]) continue;
            if (!(x_[j] == x_[j - 1]) || j == 1 || j + 1 == n || x_[j - 1] == x_[j - 2])
                throw internalError("CubicSpline: knots must increase (a break: one knot twice, inside)");
            if (y_[j] != y_[j - 1]) throw internalError("CubicSpline: the two values at a break must be equal");
        }
        m_.assign(n, Vector::Zero());
        std::size_t first = 0;
        for (std::size_t j = 1; j < n; ++j)
            if (j + 1 == n || x_[j + 1] == x_[j]) {
                solvePiece(first, j);
                first = j + 1;
            }
    }

    bool empty() const { return x_.empty(); }
    const std::vector<double>& knots() const { return x_; }
    const std::vector<Vector>& values() const { return y_; }

    Vector value(double x) const
    {
        if (x <= x_.front()) return y_.front() + (x - x_.front()) * derivative(x_.front());
        if (x >= x_.back()) return y_.back() + (x - x_.back()) * derivative(x_.back());
        const std::size_t j = segment(x);
        const double h = x_[j + 1] - x_[j];
        const double a = (x_[j + 1] - x) / h;
        const double b = 1.0 - a;
        return a * y_[j] + b * y_[j + 1] + ((a * a * a - a) * m_[j] + (b * b * b - b) * m_[j + 1]) * (h * h / 6.0);
    }

    Vector derivative(double x) const
    {
        const double clamped = x < x_.front() ? x_.front() : x > x_.back() ? x_.back() : x;
        const std::size_t j = segment(clamped);
        const double h = x_[j + 1] - x_[j];
        const double a = (x_[j + 1] - clamped) / h;
        const double b = 1.0 - a;
        return (y_[j + 1] - y_[j]) / h - (3.0 * a * a - 1.0) / 6.0 * h * m_[j] +
               (3.0 * b * b - 1.0) / 6.0 * h * m_[j + 1];
    }

private:
    // Second derivatives of the piece of knots first..last: natural ends (zero), the tridiagonal system
    // solved by the Thomas algorithm. Without breaks the one piece is the whole curve, computed as before.
    void solvePiece(std::size_t first, std::size_t last)
    {
        std::vector<double> c(last + 1, 0.0);
        std::vector<Vector> d(last + 1, Vector::Zero());
        for (std::size_t j = first + 1; j < last; ++j) {
            const double h0 = x_[j] - x_[j - 1];
            const double h1 = x_[j + 1] - x_[j];
            const Vector rhs = 6.0 * ((y_[j + 1] - y_[j]) / h1 - (y_[j] - y_[j - 1]) / h0);
            const double b = 2.0 * (h0 + h1) - h0 * c[j - 1];
            c[j] = h1 / b;
            d[j] = (rhs - h0 * d[j - 1]) / b;
        }
        for (std::size_t j = last - 1; j > first; --j) m_[j] = d[j] - c[j] * m_[j + 1];
    }

    // The segment [x_j, x_j+1] holding x (x within the knots): the last j with x_j <= x, so that at a break
    // it is the right-hand piece's first segment, never the zero-length one between the break's two knots.
    std::size_t segment(double x) const
    {
        std::size_t lo = 0, hi = x_.size() - 1;
        while (hi - lo > 1) {
            const std::size_t mid = (lo + hi) / 2;
            (x < x_[mid] ? hi : lo) = mid;
        }
        return lo;
    }

    std::vector<double> x_;
    std::vector<Vector> y_;
    std::vector<Vector> m_;
};

}  // namespace rig

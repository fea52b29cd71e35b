// SPDX-License-Identifier: MIT
#include "meshmark/watermark/frame.h"

#include <array>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

// Vertices whose second principal extent is below this fraction of the first are collinear:
// the watermark would have no room to move them off their line.
constexpr double kCollinearTolerance = 1e-12;

// One row of the third-moment and extent pass: add() and add_rows() both run exactly this.
inline void add_moments_row(const Eigen::Vector3d& q, const Eigen::Vector3d& e1,
                            const Eigen::Vector3d& e2, const Eigen::Matrix3d& unsigned_axes,
                            double& moment1, double& moment2, Eigen::Vector3d& lo,
                            Eigen::Vector3d& hi)
{
    const double t1 = q.dot(e1);
    const double t2 = q.dot(e2);
    moment1 += t1 * t1 * t1;
    moment2 += t2 * t2 * t2;
    const Eigen::Vector3d r = unsigned_axes * q;
    lo = lo.cwiseMin(r);
    hi = hi.cwiseMax(r);
}

}  // namespace

void CanonicalFrameBuilder::add(const Eigen::Vector3d& p)
{
    switch (pass_)
    {
        case Pass::Centroid:
            sum_ += p;
            ++rows_;
            break;
        case Pass::Covariance:
        {
            const Eigen::Vector3d q = p - frame_.origin;
            covariance_ += q * q.transpose();
            break;
        }
        case Pass::Moments:
            add_moments_row(p - frame_.origin, e1_, e2_, unsigned_axes_, moment1_, moment2_, lo_,
                            hi_);
            break;
        case Pass::Done:
            break;
    }
}

void CanonicalFrameBuilder::add_rows(const Positions& V, std::span<const std::int32_t> rows)
{
    // Each loop body is add()'s expression for its pass, so every sum is the same.
    switch (pass_)
    {
        case Pass::Centroid:
        {
            Eigen::Vector3d sum = sum_;
            for (const std::int32_t i : rows)
            {
                sum += V.row(i).transpose();
            }
            sum_ = sum;
            rows_ += rows.size();
            break;
        }
        case Pass::Covariance:
        {
            // add()'s covariance += q q^T entry by entry (each entry: one product, one sum; the
            // matrix is symmetric and q_a q_b == q_b q_a exactly), without Eigen's temporary.
            std::array<double, 6> c = {covariance_(0, 0), covariance_(1, 0), covariance_(2, 0),
                                       covariance_(1, 1), covariance_(2, 1), covariance_(2, 2)};
            const double ox = frame_.origin.x();
            const double oy = frame_.origin.y();
            const double oz = frame_.origin.z();
            for (const std::int32_t i : rows)
            {
                const double x = V(i, 0) - ox;
                const double y = V(i, 1) - oy;
                const double z = V(i, 2) - oz;
                c[0] += x * x;
                c[1] += y * x;
                c[2] += z * x;
                c[3] += y * y;
                c[4] += z * y;
                c[5] += z * z;
            }
            covariance_ << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
            break;
        }
        case Pass::Moments:
        {
            double moment1 = moment1_;
            double moment2 = moment2_;
            Eigen::Vector3d lo = lo_;
            Eigen::Vector3d hi = hi_;
            for (const std::int32_t i : rows)
            {
                add_moments_row(V.row(i).transpose() - frame_.origin, e1_, e2_, unsigned_axes_,
                                moment1, moment2, lo, hi);
            }
            moment1_ = moment1;
            moment2_ = moment2;
            lo_ = lo;
            hi_ = hi;
            break;
        }
        case Pass::Done:
            break;
    }
}

void CanonicalFrameBuilder::next_pass()
{
    switch (pass_)
    {
        case Pass::Centroid:
            if (rows_ == 0)
            {
                throw NumericalError("the mesh has no vertex to analyse.");
            }
            frame_.origin = sum_ / static_cast<double>(rows_);
            pass_ = Pass::Covariance;
            break;
        case Pass::Covariance:
        {
            covariance_ /= static_cast<double>(rows_);
            const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance_);
            const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
            if (!(eigenvalues(2) > 0.0) || eigenvalues(1) <= kCollinearTolerance * eigenvalues(2))
            {
                throw NumericalError(
                    "the vertices are all collinear or coincident, so the RBF Gram matrix "
                    "is degenerate and no watermark can be embedded.");
            }
            e1_ = solver.eigenvectors().col(2);
            e2_ = solver.eigenvectors().col(1);
            unsigned_axes_.row(0) = e1_.transpose();
            unsigned_axes_.row(1) = e2_.transpose();
            unsigned_axes_.row(2) = e1_.cross(e2_).normalized().transpose();
            lo_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
            hi_ = -lo_;
            pass_ = Pass::Moments;
            break;
        }
        case Pass::Moments:
        {
            // Signs: e -> -e negates e's projections exactly, and the cross product of the
            // signed axes is the unsigned one times both signs, exactly. So the extent along a
            // negated axis is [-hi, -lo] of the unsigned one, bit for bit what a fourth pass
            // over the signed axes would find, and hi - lo is the same difference.
            const std::array<double, 3> sign = {moment1_ < 0.0 ? -1.0 : 1.0,
                                                moment2_ < 0.0 ? -1.0 : 1.0,
                                                (moment1_ < 0.0) != (moment2_ < 0.0) ? -1.0 : 1.0};
            for (Eigen::Index k = 0; k < 3; ++k)
            {
                frame_.axes.row(k) = sign[static_cast<std::size_t>(k)] < 0.0
                                         ? Eigen::RowVector3d(-unsigned_axes_.row(k))
                                         : Eigen::RowVector3d(unsigned_axes_.row(k));
                if (sign[static_cast<std::size_t>(k)] < 0.0)
                {
                    const double lo = lo_(k);
                    lo_(k) = -hi_(k);
                    hi_(k) = -lo;
                }
            }
            frame_.diagonal = (hi_ - lo_).norm();
            pass_ = Pass::Done;
            break;
        }
        case Pass::Done:
            break;
    }
}

CanonicalFrame canonical_frame(const Positions& V, const std::vector<std::int32_t>& rows)
{
    CanonicalFrameBuilder builder;
    while (builder.pass() != CanonicalFrameBuilder::Pass::Done)
    {
        builder.add_rows(V, rows);
        builder.next_pass();
    }
    return builder.frame();
}

}  // namespace meshmark

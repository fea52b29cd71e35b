// SPDX-License-Identifier: MIT
#include "meshmark/registration/point_to_plane.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace meshmark
{

template <int N>
std::optional<PointToPlaneStep<N>> point_to_plane_step(const Positions& Y,
                                                       const std::vector<SurfaceMatch>& matches,
                                                       std::span<const Eigen::Index> kept)
{
    static_assert(N == 6 || N == 7, "6 unknowns (rigid) or 7 (with scale)");
    using VecN = Eigen::Matrix<double, N, 1>;
    using MatN = Eigen::Matrix<double, N, N>;
    if (kept.empty())
    {
        return std::nullopt;
    }
    PointToPlaneStep<N> step;
    for (const Eigen::Index i : kept)
    {
        step.centre += Y.row(i).transpose();
    }
    step.centre /= static_cast<double>(kept.size());
    double r2 = 0.0;
    for (const Eigen::Index i : kept)
    {
        r2 += (Y.row(i).transpose() - step.centre).squaredNorm();
    }
    step.radius = std::max(std::sqrt(r2 / static_cast<double>(kept.size())), 1e-300);
    // Normal equations of r_i + J_i delta, J_i = [(y_i - c)/L x n_i, (n_i.(y_i - c)/L), n_i].
    MatN JtJ = MatN::Zero();
    VecN Jtr = VecN::Zero();
    for (const Eigen::Index i : kept)
    {
        const SurfaceMatch& match = matches[static_cast<std::size_t>(i)];
        const Eigen::Vector3d y = Y.row(i).transpose();
        const Eigen::Vector3d u = (y - step.centre) / step.radius;
        VecN J;
        if constexpr (N == 7)
        {
            J << u.cross(match.normal), match.normal.dot(u), match.normal;
        }
        else
        {
            J << u.cross(match.normal), match.normal;
        }
        const double r = match.normal.dot(y - match.point);
        JtJ.noalias() += J * J.transpose();
        Jtr += r * J;
    }
    // Damping, a share of the mean diagonal: keeps the directions the surface leaves free (a
    // sphere's rotation, a cylinder's slide) where they are, and a well-posed step unchanged.
    constexpr double kDamping = 1e-9;
    const double damping = kDamping * JtJ.trace() / static_cast<double>(N) + 1e-300;
    step.delta = -(JtJ + damping * MatN::Identity()).ldlt().solve(Jtr);
    if (!step.delta.allFinite())
    {
        return std::nullopt;
    }
    return step;
}

template std::optional<PointToPlaneStep<6>> point_to_plane_step<6>(const Positions&,
                                                                   const std::vector<SurfaceMatch>&,
                                                                   std::span<const Eigen::Index>);
template std::optional<PointToPlaneStep<7>> point_to_plane_step<7>(const Positions&,
                                                                   const std::vector<SurfaceMatch>&,
                                                                   std::span<const Eigen::Index>);

}  // namespace meshmark

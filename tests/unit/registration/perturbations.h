// SPDX-License-Identifier: MIT
#pragma once

// Inline perturbations for the registration tests (the attacks module is separate and may
// not exist yet): random similarities, plane crops, noise, triangle soups.

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>

#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark::test
{

/// A random similarity: uniform rotation, log-uniform scale in [0.1, 10], translation of up
/// to a few units, optionally mirrored (x -> -x before the rotation).
inline Eigen::Matrix4d random_similarity(Rng& rng, bool mirrored)
{
    Eigen::Quaterniond q(rng.normal(), rng.normal(), rng.normal(), rng.normal());
    q.normalize();
    const double scale = std::exp(rng.uniform(std::log(0.1), std::log(10.0)));
    Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
    T.block<3, 3>(0, 0) = scale * q.toRotationMatrix();
    if (mirrored)
    {
        T.block<3, 1>(0, 0) = -T.block<3, 1>(0, 0);
    }
    T.block<3, 1>(0, 3) = Eigen::Vector3d(rng.normal(), rng.normal(), rng.normal()) * 3.0;
    return T;
}

inline Positions apply(const Eigen::Matrix4d& T, const Positions& V)
{
    Positions result(V.rows(), 3);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        result.row(i) =
            (T.block<3, 3>(0, 0) * V.row(i).transpose() + T.block<3, 1>(0, 3)).transpose();
    }
    return result;
}

/// Result of a plane crop: the kept mesh and, per original vertex, whether it was removed.
struct Cropped
{
    TriangleMesh mesh;
    std::vector<Eigen::Index> kept;  ///< Original index of each kept vertex.
    std::vector<bool> is_removed;    ///< Per original vertex.
};

/// Keep the vertices on the low side of a plane with normal \p n (the fraction \p keep of
/// them) and the faces whose three corners are kept.
inline Cropped crop_by_plane(const TriangleMesh& mesh, const Eigen::Vector3d& n, double keep)
{
    std::vector<double> height(static_cast<std::size_t>(mesh.V.rows()));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        height[static_cast<std::size_t>(i)] = mesh.V.row(i).dot(n);
    }
    std::vector<double> sorted = height;
    const auto k = static_cast<std::size_t>(keep * static_cast<double>(sorted.size()));
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
    const double limit = sorted[k];
    Cropped result;
    std::vector<std::int32_t> new_index(height.size(), -1);
    result.is_removed.assign(height.size(), true);
    for (std::size_t i = 0; i < height.size(); ++i)
    {
        if (height[i] < limit)
        {
            new_index[i] = static_cast<std::int32_t>(result.kept.size());
            result.kept.push_back(static_cast<Eigen::Index>(i));
            result.is_removed[i] = false;
        }
    }
    result.mesh.V.resize(static_cast<Eigen::Index>(result.kept.size()), 3);
    for (std::size_t i = 0; i < result.kept.size(); ++i)
    {
        result.mesh.V.row(static_cast<Eigen::Index>(i)) = mesh.V.row(result.kept[i]);
    }
    std::vector<Eigen::Vector3i> faces;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Eigen::Vector3i g(new_index[static_cast<std::size_t>(mesh.F(f, 0))],
                                new_index[static_cast<std::size_t>(mesh.F(f, 1))],
                                new_index[static_cast<std::size_t>(mesh.F(f, 2))]);
        if (g.minCoeff() >= 0)
        {
            faces.push_back(g);
        }
    }
    result.mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t f = 0; f < faces.size(); ++f)
    {
        result.mesh.F.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
    }
    return result;
}

/// Uniform noise in a cube whose per-axis half-width makes the displacement length up to
/// about \p amplitude.
inline Positions add_noise(const Positions& V, double amplitude, Rng& rng)
{
    Positions result = V;
    const double half = amplitude / std::sqrt(3.0);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        for (int d = 0; d < 3; ++d)
        {
            result(i, d) += rng.uniform(-half, half);
        }
    }
    return result;
}

/// Every triangle with its own three vertices, as an unwelded STL reader would give.
inline TriangleMesh triangle_soup(const TriangleMesh& mesh)
{
    TriangleMesh soup;
    soup.V.resize(3 * mesh.F.rows(), 3);
    soup.F.resize(mesh.F.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            soup.V.row(3 * f + c) = mesh.V.row(mesh.F(f, c));
            soup.F(f, c) = static_cast<std::int32_t>(3 * f + c);
        }
    }
    return soup;
}

/// RMS distance between corresponding rows.
inline double rms_distance(const Positions& A, const Positions& B)
{
    return std::sqrt((A - B).squaredNorm() / static_cast<double>(A.rows()));
}

}  // namespace meshmark::test

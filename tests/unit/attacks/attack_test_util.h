// SPDX-License-Identifier: MIT
// Small helpers shared by the attack tests.
#pragma once

#include <cmath>
#include <cstring>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::test
{

/// True when \p size bytes at \p a and \p b are equal; an empty range is equal even when its
/// data() is null (memcmp on a null pointer is undefined behaviour, even for 0 bytes).
inline bool same_bytes(const void* a, const void* b, std::size_t size)
{
    return size == 0 || std::memcmp(a, b, size) == 0;
}

/// True when both meshes have the same shape and bit-identical positions and faces.
inline bool bit_identical(const TriangleMesh& a, const TriangleMesh& b)
{
    return a.V.rows() == b.V.rows() && a.F.rows() == b.F.rows() &&
           same_bytes(a.V.data(), b.V.data(),
                      sizeof(double) * static_cast<std::size_t>(a.V.size())) &&
           same_bytes(a.F.data(), b.F.data(),
                      sizeof(std::int32_t) * static_cast<std::size_t>(a.F.size()));
}

/// Mean distance of the vertices to the origin.
inline double mean_radius(const TriangleMesh& mesh)
{
    return mesh.V.rowwise().norm().mean();
}

/// Signed volume enclosed by the faces: positive when they face outwards.
inline double signed_volume(const TriangleMesh& mesh)
{
    double volume = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0));
        const Eigen::Vector3d b = mesh.V.row(mesh.F(f, 1));
        const Eigen::Vector3d c = mesh.V.row(mesh.F(f, 2));
        volume += a.dot(b.cross(c)) / 6.0;
    }
    return volume;
}

/// Relative deviation of \p actual from \p target.
inline double relative_error(double actual, double target)
{
    return std::abs(actual / target - 1.0);
}

/// An icosphere with one extra vertex no face uses, at (3, 3, 3).
inline TriangleMesh with_unreferenced_vertex(TriangleMesh mesh)
{
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 1, 3);
    mesh.V.row(n) << 3.0, 3.0, 3.0;
    return mesh;
}

/// The vertices of \p mesh with no faces.
inline TriangleMesh point_cloud_of(const TriangleMesh& mesh)
{
    TriangleMesh cloud;
    cloud.V = mesh.V;
    return cloud;
}

}  // namespace meshmark::test

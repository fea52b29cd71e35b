// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace meshmark
{

/// #V×3 vertex positions, row-major so that one vertex's x, y, z are contiguous.
using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
/// #F×3 triangle vertex indices (counter-clockwise seen from outside), row-major.
using Faces = Eigen::Matrix<std::int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// \brief An indexed triangle mesh, or a point cloud when it has no faces.
/// \details Vertices that no face uses ("unreferenced") are allowed and kept: file round trips
/// carry them through untouched. Polygons read from files are fan-triangulated and triangle
/// strips decoded by the readers, so every face here is a triangle.
struct TriangleMesh
{
    Positions V;  ///< #V×3 positions in the file's units.
    Faces F;      ///< #F×3 triangles; empty for a point cloud.

    [[nodiscard]] Eigen::Index vertex_count() const noexcept { return V.rows(); }
    [[nodiscard]] Eigen::Index face_count() const noexcept { return F.rows(); }
    [[nodiscard]] bool is_point_cloud() const noexcept { return F.rows() == 0; }
};

/// \brief Throws InvalidMesh unless every coordinate is finite and every index is in range.
/// \param what  Names the mesh in the message (usually its file name).
void validate(const TriangleMesh& mesh, const char* what);

/// \brief Indices of the vertices that take part in the analysis.
/// \details For a mesh with faces: the vertices used by at least one face, in increasing order.
/// For a point cloud: every vertex.
[[nodiscard]] std::vector<std::int32_t> referenced_vertices(const TriangleMesh& mesh);

}  // namespace meshmark

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

/// \brief One triangle of a polygon's fan from its first corner, where a reader laid other
/// triangles (TriangleMesh::fans).
struct FanTriangle
{
    Eigen::Index row = 0;  ///< The row of TriangleMesh::F the polygon's triangle took instead.
    std::int32_t a = 0, b = 0, c = 0;
};

/// \brief One of a file's polygons of 4 or more corners (TriangleMesh::polygons): rows first to
/// first + corners - 3 of TriangleMesh::F are its triangles.
struct PolygonRows
{
    std::uint32_t first = 0;
    std::uint32_t corners = 0;
};

/// \brief An indexed triangle mesh, or a point cloud when it has no faces.
/// \details Vertices that no face uses ("unreferenced") are allowed and kept: file round trips
/// carry them through untouched. The readers decode triangle strips and triangulate polygons
/// (a convex one as its fan from its first corner, another inside its outline), so every face
/// here is a triangle.
struct TriangleMesh
{
    Positions V;  ///< #V×3 positions in the file's units.
    Faces F;      ///< #F×3 triangles; empty for a point cloud.
    /// \brief The fan rows of the file's polygons that were triangulated inside their outline
    /// instead (read from a file; empty otherwise, and for most files).
    /// \details Which triangles a polygon gets depends on where its corners stand, so a copy
    /// whose vertices a tool moved (a smoothing) can get other triangles over the same polygons;
    /// its fans are the same. Detection's correspondence by triangles compares them (with_fans).
    std::vector<FanTriangle> fans = {};
    /// \brief The file's polygons of 4 or more corners (read from a file; empty otherwise).
    /// \details The edges inside a polygon are not edges of the file's mesh: a tool that
    /// smooths polygons (Blender's Smooth) averages over the outlines alone (polygon_adjacency).
    std::vector<PolygonRows> polygons = {};

    [[nodiscard]] Eigen::Index vertex_count() const noexcept { return V.rows(); }
    [[nodiscard]] Eigen::Index face_count() const noexcept { return F.rows(); }
    [[nodiscard]] bool is_point_cloud() const noexcept { return F.rows() == 0; }
};

/// \brief \p mesh's triangles with every polygon as its fan (TriangleMesh::fans in place).
[[nodiscard]] Faces with_fans(const TriangleMesh& mesh);

/// \brief Throws InvalidMesh unless every coordinate is finite and every index is in range.
/// \param what  Names the mesh in the message (usually its file name).
void validate(const TriangleMesh& mesh, const char* what);

/// \brief Indices of the vertices that take part in the analysis.
/// \details For a mesh with faces: the vertices used by at least one face, in increasing order.
/// For a point cloud: every vertex.
[[nodiscard]] std::vector<std::int32_t> referenced_vertices(const TriangleMesh& mesh);

}  // namespace meshmark

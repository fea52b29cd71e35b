// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief Vertex-to-vertex adjacency of a triangle mesh in compressed rows (CSR).
/// \details The neighbours of vertex `v` are `neighbors[offsets[v] .. offsets[v + 1])`, sorted
/// by index and without repetition; two vertices are neighbours when some triangle has an edge
/// between them. Non-manifold edges and vertices are fine: adjacency is purely combinatorial.
/// A vertex used by no face has no neighbours.
struct VertexAdjacency
{
    std::vector<std::size_t> offsets;  ///< #V + 1 row starts; offsets.back() == neighbors.size().
    std::vector<std::int32_t> neighbors;  ///< Concatenated sorted neighbour lists.

    /// Number of vertices the adjacency was built for.
    [[nodiscard]] std::size_t vertex_count() const noexcept
    {
        return offsets.empty() ? 0 : offsets.size() - 1;
    }
    /// Sorted neighbours of vertex \p v. \pre v < vertex_count().
    [[nodiscard]] std::span<const std::int32_t> of(std::size_t v) const noexcept
    {
        return {neighbors.data() + offsets[v], offsets[v + 1] - offsets[v]};
    }
};

/// \brief Build the vertex adjacency of \p mesh: a counting sort of the face edges into rows,
/// O(#V + #F), then each row sorted, O(#F log d) with d the largest vertex degree.
/// \param mesh  Triangle mesh; indices must be in range (see validate()). Faces with a
///              repeated index contribute only their distinct edges.
[[nodiscard]] VertexAdjacency vertex_adjacency(const TriangleMesh& mesh);

/// \brief The vertex adjacency of \p mesh's polygons as its file has them: the edges inside a
/// polygon of TriangleMesh::polygons (those two of its triangles share) are left out, unless
/// another face has them as an edge of its own. vertex_adjacency when there are no polygons.
[[nodiscard]] VertexAdjacency polygon_adjacency(const TriangleMesh& mesh);

/// \brief Vertex-to-face incidence of a triangle mesh in compressed rows (CSR).
/// \details The faces using vertex `v` are `faces[offsets[v] .. offsets[v + 1])`, in face
/// order; a face with a repeated index is listed once per corner.
struct VertexFaces
{
    std::vector<std::size_t> offsets;  ///< #V + 1 row starts; offsets.back() == faces.size().
    std::vector<Eigen::Index> faces;   ///< Concatenated face lists.

    /// Faces using vertex \p v. \pre v < #V.
    [[nodiscard]] std::span<const Eigen::Index> of(std::size_t v) const noexcept
    {
        return {faces.data() + offsets[v], offsets[v + 1] - offsets[v]};
    }
};

/// \brief Build the vertex-to-face incidence of \p mesh: a counting sort of the face corners
/// into rows, O(#V + #F).
/// \param mesh  Triangle mesh; indices must be in range (see validate()).
[[nodiscard]] VertexFaces vertex_faces(const TriangleMesh& mesh);

/// Counts describing how the edges of a triangle mesh are shared by its faces.
struct EdgeStatistics
{
    std::size_t edge_count = 0;               ///< Distinct undirected edges.
    std::size_t boundary_edge_count = 0;      ///< Edges used by exactly one face.
    std::size_t non_manifold_edge_count = 0;  ///< Edges used by three faces or more.
    /// Edges used by exactly two faces that traverse it in the same direction (the two faces
    /// have opposite orientations).
    std::size_t inconsistent_edge_count = 0;

    /// Every edge is shared by exactly two faces.
    [[nodiscard]] bool is_closed() const noexcept
    {
        return boundary_edge_count == 0 && non_manifold_edge_count == 0;
    }
    /// No edge is shared by more than two faces.
    [[nodiscard]] bool is_edge_manifold() const noexcept { return non_manifold_edge_count == 0; }
    /// Edge-manifold and every interior edge is traversed once in each direction.
    [[nodiscard]] bool is_consistently_oriented() const noexcept
    {
        return non_manifold_edge_count == 0 && inconsistent_edge_count == 0;
    }
};

/// \brief Classify every edge of \p mesh by the number of faces using it.
/// \details Faces with a repeated index (degenerate) contribute only their distinct edges.
/// \param mesh  Triangle mesh; indices must be in range (see validate()).
[[nodiscard]] EdgeStatistics edge_statistics(const TriangleMesh& mesh);

/// \brief One id per position of \p V: each vertex gets the lowest index of the vertices at
/// exactly its position (the same coordinates, bit for bit), so a writer's duplicates (seams,
/// split normals, faceted exports) count as one point.
/// \details A sort of the vertices by position, O(#V log #V); deterministic. `id[v] <= v`, and
/// `id[v] == v` for the first vertex at each position.
[[nodiscard]] std::vector<std::int32_t> position_ids(const Positions& V);

}  // namespace meshmark

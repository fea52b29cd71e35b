// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Each original vertex's suspect vertex (match_vertices).
struct VertexMatching
{
    std::vector<std::int32_t> suspect_of;  ///< Per original vertex: its suspect vertex, or -1.
    std::size_t matched = 0;               ///< How many original vertices have one.
    /// Median over the matched vertices of the distance to their suspect vertex over the
    /// distance to the next suspect position (1 when none matched): small when the suspect's
    /// vertices are the original's, near 1 for a surface sampled afresh.
    double ambiguity = 1.0;
};

/// \brief Mutual nearest vertices of the original and a suspect registered onto it.
/// \details Each original vertex takes the suspect vertex nearest to it, when that one lies
/// within \p tolerance and the original vertex nearest to it is at the same position (original
/// vertices at one position count as one). Positions only, never a key. Parallel, the same
/// result for any thread count.
[[nodiscard]] VertexMatching match_vertices(const Positions& original, const Positions& registered,
                                            double tolerance, int threads);

/// \brief Of the suspect's triangles whose three corners stand for original vertices
/// (\p match: VertexMatching::suspect_of), the share that are triangles of the original
/// (corners compared by position); -1 when they are fewer than half of the suspect's triangles.
[[nodiscard]] double original_triangle_share(const TriangleMesh& original,
                                             const TriangleMesh& suspect,
                                             const Positions& registered,
                                             const std::vector<std::int32_t>& match);

/// A registered copy's vertices in the original's order (vertices_in_place).
struct VerticesInPlace
{
    /// #V_original x 3, registered frame: row i the suspect vertex standing for original vertex
    /// i, or the original's own position where none does.
    Positions in_order;
    std::vector<std::uint8_t>
        matched_rows;  ///< Per original vertex: 1 when a suspect vertex stands for it.
    std::size_t matched = 0;
};

/// \brief The suspect's vertices in the original's order, when after registration they are the
/// original's vertices again (reordered, split at seams, welded, with vertices added between
/// them, or cut by deleting faces): a copy read vertex for vertex keeps every component of the
/// change, not only the normal one the resampling keeps.
/// \details Only on a mesh whose mean edge is at least 10 mark amplitudes (on a denser one a
/// marked vertex can come closer to a neighbour's place than to its own), with at least half as
/// many suspect vertices; accepted when 99% of the original's vertices are matched, or 10% and
/// 90% of the triangles between them are the original's, and the matching is unambiguous
/// (VertexMatching::ambiguity <= 0.4). docs/algorithms/detection.md lists the thresholds.
/// \param to_original The registration's suspect -> original transform.
/// \param amplitude   The mark's RMS displacement, original units.
/// \param reach       The farthest a suspect vertex may lie from its original vertex (capped
///                    at half the mean edge).
[[nodiscard]] std::optional<VerticesInPlace> vertices_in_place(const TriangleMesh& original,
                                                               const TriangleMesh& suspect,
                                                               const Eigen::Matrix4d& to_original,
                                                               double amplitude, double reach,
                                                               int threads);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// Internal to the shape signature (shape_signature.cpp): the points it draws on a surface, and
// the pairs and triples of them every view counts (shape_draw.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::shape_detail
{

using Vec3 = Eigen::Vector3d;

// Points drawn per surface, and pairs and triples of them for the distance and angle
// distributions (every view uses those that fall inside it). Chosen on the shape-index study
// (bench/results/2026-11-29-catalogue.md, "The shape index alone"): with 2,048 points drawn in
// the file's face order reordered copies ranked first in 11 of 24; a signature costs about 25 ms.
inline constexpr int kSamples = 4096;
inline constexpr int kPairs = 16384;
inline constexpr int kTriples = 16384;
inline constexpr int kAngleBins = 4;  // bin counts chosen by hand; no study on record
// The angle between the normals of a pair's points, as |cos| in bins of equal width (either
// orientation: artists' models mix them). Six bins: a box's pairs are parallel or at right
// angles, a turned part's spread; chosen by hand, measured on the shape-index study
// (bench/results/2026-11-30-scan-speed.md).
inline constexpr int kNormalBins = 6;
// The draws name points by 16 bits, and count them in 16-bit fields (shape_signature.cpp).
static_assert(kSamples <= 65536 && kPairs < 65536 && kTriples < 65536);

// The triangles of a surface in the draw's order, with their cumulative area: sorted once for
// both draws of a signature (kSamples points, then kShapePoints), each of which starts the
// same stream again. The order does not depend on the file (by their centroid's distance from
// the surface's centroid, each one's corners likewise), so a copy with its vertices or faces
// renumbered draws the same points. Empty for a point cloud or a surface without area.
struct Surface
{
    std::vector<std::array<std::int32_t, 3>> corners;  ///< vertices, in the corners' order
    std::vector<double> cumulative;
};

[[nodiscard]] Surface sorted_surface(const TriangleMesh& mesh);

// The draw: \p count points by area (stratified over the cumulative area, so that every part of
// the surface gets its share), or the vertices of a point cloud or of a surface without area.
// With each point, when \p normals is given, the unit normal of the triangle it lies on (zero
// for a vertex of a point cloud).
[[nodiscard]] std::vector<Vec3> surface_points(const TriangleMesh& mesh, const Surface& surface,
                                               int count, std::vector<Vec3>* normals);

// shape_sample of a sorted surface.
[[nodiscard]] Positions sample_of(const TriangleMesh& mesh, const Surface& surface, int count,
                                  Positions* normals);

// The draws every view shares: pairs of sample points by the bin of the angle between their
// normals, each bin's by distance, and the distances of all ascending; triples by the bin of
// their angle. A view uses those whose points it all holds, so a crop view measures the draws
// of the whole that fall inside it (no draws of its own). Only counts are taken of them, so
// their order within a bin does not matter. (Points by their index in the sample.)
struct Draws
{
    std::vector<std::array<std::uint16_t, 2>> pairs;
    std::array<std::size_t, kNormalBins + 1> normal_from{};  ///< bin b: from [b] to [b + 1]
    std::vector<double> pair_distance;
    /// [r][b]: the pairs of normals' bin b among the r nearest (the first at or past rank r)
    std::vector<std::array<std::uint16_t, kNormalBins>> normal_below;
    std::vector<std::array<std::uint16_t, 3>> triples;
    std::array<std::size_t, kAngleBins + 1> triple_from{};  ///< bin b: from [b] to [b + 1]
};

[[nodiscard]] Draws draw(const std::vector<Vec3>& points, const std::vector<Vec3>& normals);

}  // namespace meshmark::shape_detail

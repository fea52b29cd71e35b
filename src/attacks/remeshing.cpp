// SPDX-License-Identifier: MIT
#include "meshmark/attacks/remeshing.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>

#include "attacks/detail/cgal_mesh.h"
#include "attacks/detail/format.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

namespace pmp = CGAL::Polygon_mesh_processing;

// A pass is accepted when its vertex count is this close to the target (relative); the
// contract is 10%, so 5% leaves room for what the projection and relaxation still move.
constexpr double kCountTolerance = 0.05;
// Passes before giving up on the tolerance and returning the closest result.
constexpr int kMaxPasses = 4;

// CGAL's remeshing keeps edges between 4/5 and 4/3 of the target length, and its vertex count
// came out 1.20-1.29 times the equilateral estimate below on every mesh tried (icospheres,
// dragon_vrip_res4, the full dragon; 25% and 5% targets), so the first guess is lengthened by
// sqrt(1.22) and one pass is usually enough.
constexpr double kFirstGuessFactor = 1.1045;

// CGAL 5.5's tangential relaxation dereferences a null halfedge (SIGSEGV) at a vertex all of
// whose faces have an exactly zero normal (CGAL issue #7345, fixed in later releases): exact
// zeros come from exactly collinear corners, which the flat, axis-aligned polygons of CAD and
// architectural files (round coordinates) give it (assimp's regr01.obj at remesh=0.8). Moving
// every vertex by at most this fraction of the diagonal in a fixed pseudo-random direction
// makes such exact ties vanish; it is far below float32 precision (6e-8) and what the remesher
// itself moves.
constexpr double kTieBreak = 1e-9;

// splitmix64: a fixed pseudo-random number per (vertex, axis), in [-1, 1].
double tie_break_unit(std::uint64_t vertex, std::uint64_t axis)
{
    std::uint64_t z = vertex * 3U + axis + 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30U)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27U)) * 0x94D049BB133111EBULL;
    z ^= z >> 31U;
    return static_cast<double>(z >> 11U) * 0x1.0p-52 - 1.0;
}

// \p surface with each vertex moved by at most kTieBreak of \p diagonal (kTieBreak).
void break_ties(detail::SurfaceMesh& surface, double diagonal)
{
    const double step = kTieBreak * diagonal;
    for (const auto v : surface.vertices())
    {
        const detail::CgalPoint& p = surface.point(v);
        const std::uint64_t i = v.idx();
        surface.point(v) = detail::CgalPoint(p.x() + step * tie_break_unit(i, 0),
                                             p.y() + step * tie_break_unit(i, 1),
                                             p.z() + step * tie_break_unit(i, 2));
    }
}

// Edge length whose equilateral triangles tile `area` with `vertices` vertices: a closed
// triangle mesh has F ≈ 2V faces of area sqrt(3)/4 L^2 each.
double edge_length_for(double area, double vertices)
{
    return std::sqrt(2.0 * area / (std::sqrt(3.0) * vertices));
}

detail::SurfaceMesh remesh_pass(const detail::SurfaceMesh& input, double edge_length,
                                int iterations)
{
    detail::SurfaceMesh surface = input;
    pmp::isotropic_remeshing(
        faces(surface), edge_length, surface,
        CGAL::parameters::number_of_iterations(static_cast<unsigned int>(iterations)));
    surface.collect_garbage();
    return surface;
}

// The referenced vertices of \p mesh counted once per position: the surface's vertices, however
// a file split them (at seams, or into a soup of separate triangles).
double distinct_positions(const TriangleMesh& mesh)
{
    std::vector<std::array<double, 3>> points;
    for (const auto i : referenced_vertices(mesh))
    {
        points.push_back({mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2)});
    }
    std::sort(points.begin(), points.end());
    return static_cast<double>(std::unique(points.begin(), points.end()) - points.begin());
}

}  // namespace

void RemeshingOptions::validate() const
{
    if (!std::isfinite(vertex_fraction) || vertex_fraction <= 0.0 || vertex_fraction > 1.0)
    {
        throw InvalidOption("remesh: fraction " + detail::format_number(vertex_fraction) +
                            " is outside (0, 1].");
    }
    if (iterations < 1 || iterations > 20)
    {
        throw InvalidOption("remesh: iter " + std::to_string(iterations) + " is outside 1..20.");
    }
}

TriangleMesh remesh(const TriangleMesh& mesh, const RemeshingOptions& options)
{
    options.validate();
    const double target =
        std::max(4.0, std::round(options.vertex_fraction * distinct_positions(mesh)));
    // Welded: isotropic remeshing rebuilds the surface, wherever a file split its vertices (a
    // soup of separate triangles cannot be remeshed at all: its vertex count would not change).
    detail::SurfaceMesh input = detail::to_surface_mesh(mesh, "remesh", /*weld=*/true);
    break_ties(input, bounding_box(mesh.V).diagonal());

    // First guess from the area, then correct the length by the square root of the count ratio
    // (the vertex density goes as 1 / L^2) and remesh the input again.
    double edge_length = kFirstGuessFactor * edge_length_for(pmp::area(input), target);
    detail::SurfaceMesh best;
    double best_error = std::numeric_limits<double>::infinity();
    for (int pass = 0; pass < kMaxPasses; ++pass)
    {
        detail::SurfaceMesh surface = remesh_pass(input, edge_length, options.iterations);
        const auto count = static_cast<double>(surface.number_of_vertices());
        const double error = std::abs(count / target - 1.0);
        if (error < best_error)
        {
            best = std::move(surface);
            best_error = error;
        }
        if (error <= kCountTolerance)
        {
            break;
        }
        edge_length *= std::sqrt(count / target);
    }
    return detail::to_triangle_mesh(best);
}

}  // namespace meshmark

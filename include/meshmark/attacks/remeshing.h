// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the remeshing attack.
struct RemeshingOptions
{
    /// Target vertex count as a fraction of the referenced vertices, counted once per position
    /// (a vertex a file split at a seam, or a triangle soup's corners, once); the levels used in
    /// the benchmarks are 0.25 and 0.05. Range (0, 1] (remeshing a uniform mesh finer goes by whole
    /// edge splits, so a refinement target cannot be met within 10%).
    double vertex_fraction = 0.25;
    /// Iterations of each isotropic remeshing pass (split, collapse, flip, relax, project).
    /// Range 1..20.
    int iterations = 3;

    /// \throws InvalidOption naming the field when a value is out of range.
    void validate() const;
    bool operator==(const RemeshingOptions&) const = default;
};

/// \brief Isotropic remeshing to about a target vertex count, with
/// CGAL::Polygon_mesh_processing::isotropic_remeshing [Botsch & Kobbelt 2004].
/// \details The target edge length comes from the surface area and the target count (for a
/// mesh of equilateral triangles with V vertices, F ≈ 2V and A = F * sqrt(3) / 4 * L^2, with
/// an empirical correction for how CGAL spreads edge lengths). When a pass misses the count
/// by more than 5%, the length is corrected by the square root of the obtained-to-target
/// count ratio and the input is remeshed again (at most four passes, keeping the closest), so
/// the result is within 10% of the target on ordinary meshes. Each pass splits, collapses and
/// flips edges, relaxes vertices tangentially and projects them back onto the input surface.
/// Messy input is repaired first as for simplify(), and vertices at one position are merged
/// (welded), so that a surface a file split into pieces is remeshed as one surface. No
/// correspondence with the input vertices.
/// \throws InvalidOption from options.validate(); InvalidMesh for a mesh with no faces, or
/// with none left once degenerate and duplicate faces are dropped.
[[nodiscard]] TriangleMesh remesh(const TriangleMesh& mesh, const RemeshingOptions& options);

}  // namespace meshmark

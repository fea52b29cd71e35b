// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark {

/// Parameters of the remeshing attack.
struct RemeshingOptions
{
    /// Target vertex count as a fraction of the referenced vertices; the levels used in the
    /// benchmarks are 0.25 and 0.05. Values above 1 refine. Range (0, 10].
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
/// mesh of equilateral triangles with V vertices, F ≈ 2V and A = F * sqrt(3) / 4 * L^2). After
/// each pass the length is corrected by the square root of the obtained-to-target count ratio
/// and the surface is remeshed again, until the count is within 5% of the target (at most
/// four passes), so the result is within 10% of the target on ordinary meshes. Large
/// reductions start from a quadric simplification to about twice the target, which gives
/// the same kind of output (uniform triangles on the input surface) many times faster. Messy
/// input is repaired first as for simplify(). No correspondence with the input vertices.
/// \throws InvalidOption from options.validate(); InvalidMesh for a mesh with no faces.
[[nodiscard]] TriangleMesh remesh(const TriangleMesh& mesh, const RemeshingOptions& options);

}  // namespace meshmark

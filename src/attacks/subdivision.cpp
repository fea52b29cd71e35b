// SPDX-License-Identifier: MIT
#include "meshmark/attacks/subdivision.h"

#include <string>

#include <CGAL/Subdivision_method_3/subdivision_hosts_3.h>
#include <CGAL/Subdivision_method_3/subdivision_masks_3.h>
#include <CGAL/Subdivision_method_3/subdivision_methods_3.h>

#include "attacks/detail/cgal_mesh.h"
#include "meshmark/core/error.h"

namespace meshmark
{

void SubdivisionOptions::validate() const
{
    if (steps < 1 || steps > 4)
    {
        throw InvalidOption("subdivide: steps " + std::to_string(steps) + " is outside 1..4.");
    }
}

TriangleMesh subdivide(const TriangleMesh& mesh, const SubdivisionOptions& options)
{
    options.validate();
    namespace sub = CGAL::Subdivision_method_3;
    detail::SurfaceMesh surface = detail::to_surface_mesh(mesh, "subdivide");
    const auto steps = CGAL::parameters::number_of_iterations(options.steps);
    switch (options.scheme)
    {
        case SubdivisionScheme::Loop:
            sub::Loop_subdivision(surface, steps);
            break;
        case SubdivisionScheme::Midpoint:
            // Primal triangle quadrisection with the linear mask: new points at edge midpoints,
            // old points unchanged (CGAL has no named function for it).
            sub::PTQ(surface,
                     CGAL::Linear_mask_3<detail::SurfaceMesh>(&surface,
                                                              get(CGAL::vertex_point, surface)),
                     steps);
            break;
        case SubdivisionScheme::Sqrt3:
            sub::Sqrt3_subdivision(surface, steps);
            break;
    }
    return detail::to_triangle_mesh(surface);
}

}  // namespace meshmark

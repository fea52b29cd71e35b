// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Subdivision rule.
enum class SubdivisionScheme
{
    Loop,      ///< 1-to-4 split, Loop's smoothing masks [Loop 1987].
    Midpoint,  ///< 1-to-4 split at edge midpoints; old vertices stay (the surface is unchanged).
    Sqrt3,     ///< Face-centre insertion and edge flips [Kobbelt 2000].
};

/// Parameters of the subdivision attack.
struct SubdivisionOptions
{
    SubdivisionScheme scheme = SubdivisionScheme::Loop;
    int steps = 1;  ///< Number of subdivision steps (each multiplies #F by 4, or 3). Range 1..4.

    /// \throws InvalidOption when steps is outside 1..4.
    void validate() const;
    bool operator==(const SubdivisionOptions&) const = default;
};

/// \brief Subdivide with CGAL's Subdivision_method_3.
/// \details One Loop or midpoint step turns V vertices, E edges and F faces into V + E vertices
/// and 4F faces; one sqrt(3) step gives V + F vertices and 3F faces (CGAL refines a boundary
/// only every second sqrt(3) step). A closed manifold stays closed and manifold. Messy input is
/// repaired first as for simplify(). No correspondence is reported (Loop and sqrt(3) move the
/// old vertices too).
/// \throws InvalidOption from options.validate(); InvalidMesh for a mesh with no faces, or
/// with none left once degenerate and duplicate faces are dropped.
[[nodiscard]] TriangleMesh subdivide(const TriangleMesh& mesh, const SubdivisionOptions& options);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <span>
#include <vector>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/shape_fit.h"

namespace meshmark
{

/// \brief How far a suspect's points lie from each of several meshes (variants of one mesh:
/// stretched, bent, rescanned), over the suspect's RMS radius in its own units (as shape_fit's),
/// each after its own trimmed point-to-plane ICP [Chen and Medioni 1992] onto the mesh's
/// surface from \p start.
/// \details shape_fit cannot tell a copy of one variant from another: it fits a few hundred
/// points drawn on each, whose spacing is about what tells them apart. Here each variant's own
/// triangles are matched (exact closest points, the registration's matcher), so what is left
/// is the copy's own damage and the variant's difference. \p start (shape_fit's pose on one of
/// them) places the suspect on each: variants lie in nearly the same frame. \p rounds ICP
/// rounds each (5 settle; bench/results/2026-12-01-variants-by-their-surfaces.md); the closest
/// nine tenths of the points are measured. Parallel over the meshes on \p threads threads;
/// deterministic.
/// \param suspect points drawn on the suspect (shape_sample).
/// \return one score per mesh, lower is closer; infinity for a mesh without faces or a fit that
/// fails.
[[nodiscard]] std::vector<double> surface_fits(const Positions& suspect,
                                               std::span<const TriangleMesh> meshes,
                                               const ShapeFitPose& start, int rounds, int threads);

}  // namespace meshmark

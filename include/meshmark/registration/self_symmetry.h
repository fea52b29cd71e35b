// SPDX-License-Identifier: MIT
#pragma once

#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/surface_matcher.h"

namespace meshmark
{

/// \brief The rotations and mirror images S about the original's centroid that map its surface
/// onto itself (detection reads a copy of a symmetric original in each pose they relate:
/// docs/algorithms/detection.md, "Other poses").
/// \details Among the 23 other coordinate-axis rotations and the 24 coordinate-axis mirror maps
/// of its principal frame and of the file's axes, and the turns by 2 pi j / k about each axis,
/// those that keep its second and third moments (a cheap test that rejects an asymmetric mesh
/// at once) and lay a sample of its vertices on its own surface within 2 mark amplitudes RMS
/// (turns: on its vertices, within 0.25), or, for a plane's mirror image, nearly (the mirror
/// refitted by rigid point-to-plane steps: a part on one side only). At most 47 maps, the
/// rotations first. Distances on the original only: the result is the same for every key.
/// \param amplitude The mark's RMS displacement in the original's units (the unit of the
///                  tolerances above).
/// \param surface   The original's surface, when the caller has one (the registration's
///                  `RegistrationResult::reference_surface`); null: built here.
/// \return 4x4 transforms in the original's frame (original -> original).
[[nodiscard]] std::vector<Eigen::Matrix4d> self_symmetries(const TriangleMesh& original,
                                                           double amplitude, int threads,
                                                           const SurfaceMatcher* surface = nullptr);

/// \brief Whether two suspect -> original maps are one pose found twice (a symmetry's twin pose
/// that the registration's other handedness already is): within 0.1 (about 4 degrees) in their
/// linear parts (over the scale) and in where they take the suspect's bounding-box centre
/// \p centre (over the original's \p diagonal).
[[nodiscard]] bool same_pose(const Eigen::Matrix4d& A, const Eigen::Matrix4d& B,
                             const Eigen::Vector3d& centre, double diagonal);

}  // namespace meshmark

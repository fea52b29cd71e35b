// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// A similarity transform split into its parts: x -> scale * rotation * x + translation.
struct SimilarityTransform
{
    double scale = 1.0;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< Proper (det = +1).
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

/// \brief The least-squares similarity (rotation, uniform scale, translation) taking each
/// column of \p from onto the same column of \p to [Umeyama 1991; Horn 1987], as a 4×4 matrix
/// whose upper 3×3 block is `scale * R`.
/// \details The one closed-form similarity fit of the project (ICP's point-to-point step,
/// point pairs, the same-order readings of detection). Never a reflection: when the best
/// orthogonal map is one, R is the closest proper rotation (Umeyama's sign correction). A
/// caller that accepts mirror images mirrors \p from itself and tries both (similarity_from_pairs,
/// the coarse stage's mirrored candidates). Unweighted: no caller weights its pairs. Computed by
/// Eigen::umeyama, in one fixed order of operations: the same points give the same bits.
/// \pre from.cols() == to.cols() >= 1; three points not on a line for a unique rotation.
[[nodiscard]] Eigen::Matrix4d fit_similarity(const Eigen::Matrix3Xd& from,
                                             const Eigen::Matrix3Xd& to);

/// \brief The same fit for points given as rows (#P×3), such as the positions of two meshes
/// with the same vertex order. Fits the transposed rows as they are, without a copy: the
/// result may differ in the last bits from fit_similarity on copied columns.
[[nodiscard]] Eigen::Matrix4d fit_similarity_rows(const Positions& from, const Positions& to);

/// \brief The parts of a similarity given as a 4×4 matrix: scale = the length of the first
/// column of the linear block, rotation = that block over the scale, translation = the last
/// column. \p A with a zero or non-finite scale gives that scale (and a meaningless rotation):
/// a caller that can meet a degenerate fit checks the scale.
[[nodiscard]] SimilarityTransform similarity_parts(const Eigen::Matrix4d& A);

}  // namespace meshmark

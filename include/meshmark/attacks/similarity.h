// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/attacks/attack_result.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the similarity-transform attack.
struct SimilarityOptions
{
    /// Draw a random similarity (the default) instead of the explicit one below.
    bool is_random = true;

    // Explicit transform `p -> scale * R(axis, angle) * M * p + translation`, about the origin,
    // M the mirror image in the coordinate plane normal to `mirror` (identity when none).
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();        ///< Rotation axis (any length > 0).
    double angle_deg = 0.0;                                 ///< Rotation angle, degrees.
    double scale = 1.0;                                     ///< Uniform scale, > 0.
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< In the mesh's units.
    /// Mirror first in the plane x = 0 (0), y = 0 (1) or z = 0 (2); -1: no mirror. A mirrored
    /// copy keeps its faces facing out (their corners are taken in the other order).
    int mirror = -1;

    // Random transform, about the centre of the bounding box.
    double max_scale = 10.0;  ///< Scale is log-uniform in [1 / max_scale, max_scale]; >= 1.
    /// The bbox centre moves by a uniformly random direction times a length uniform in
    /// [0, max_translation_radii] bbox radii (half diagonals); >= 0.
    double max_translation_radii = 3.0;

    /// \throws InvalidOption naming the field when a value is out of range or not finite.
    void validate() const;
    bool operator==(const SimilarityOptions&) const = default;
};

/// \brief The similarity transform the attack applies to \p mesh: the explicit one, or a random
/// one drawn from \p rng.
/// \details Random: a rotation uniform over SO(3) (a uniformly random unit quaternion
/// [Shoemake 1992]), a log-uniform scale and a translation, applied about the bbox centre of
/// the referenced vertices so that the model stays near where it was relative to its size.
/// \throws InvalidOption from options.validate().
[[nodiscard]] AppliedSimilarity similarity_transform(const TriangleMesh& mesh,
                                                     const SimilarityOptions& options, Rng& rng);

/// \brief Apply \p transform to every vertex; the faces unchanged, or, when \p transform
/// mirrors (det < 0), with their corners in the other order so that they keep facing out.
[[nodiscard]] TriangleMesh transformed(const TriangleMesh& mesh,
                                       const AppliedSimilarity& transform);

/// \brief Similarity attack: similarity_transform() then transformed().
/// \return The moved mesh, the transform applied and the identity correspondence.
[[nodiscard]] AttackResult apply_similarity(const TriangleMesh& mesh,
                                            const SimilarityOptions& options, Rng& rng);

}  // namespace meshmark

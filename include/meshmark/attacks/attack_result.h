// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief A similarity transform `p -> scale * rotation * p + translation`, as applied by the
/// similarity attack.
/// \details Named apart from registration's transform type because `attacks` does not depend on
/// `registration`; matrix() gives the 4×4 homogeneous form both sides understand.
struct AppliedSimilarity
{
    Eigen::Matrix3d rotation =
        Eigen::Matrix3d::Identity();                        ///< Orthogonal: det +1, or -1 mirrored.
    double scale = 1.0;                                     ///< Uniform scale factor, > 0.
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< Applied after rotation and scale.

    /// Image of point \p p.
    [[nodiscard]] Eigen::Vector3d apply(const Eigen::Vector3d& p) const
    {
        return scale * (rotation * p) + translation;
    }
    /// 4×4 homogeneous matrix `[scale * rotation, translation; 0 0 0 1]`.
    [[nodiscard]] Eigen::Matrix4d matrix() const;
    /// The transform that applies `*this` first and then \p next.
    [[nodiscard]] AppliedSimilarity then(const AppliedSimilarity& next) const;
    /// The transform that undoes `*this`.
    [[nodiscard]] AppliedSimilarity inverse() const;
};

/// \brief What an attack (or a chain of attacks) produced.
struct AttackResult
{
    TriangleMesh mesh;  ///< The attacked mesh.
    /// The similarity transform applied, in input-to-output coordinates: set by the similarity
    /// attack; for a chain, the composition of its similarity steps (the other steps are not
    /// similarities and are not part of it). Empty when no step was a similarity.
    std::optional<AppliedSimilarity> similarity;
    /// Vertex correspondence: output vertex i is input vertex `(*source_vertex)[i]`. Given when
    /// every output vertex is an input vertex, moved or not (similarity, noise, smoothing,
    /// quantization, reordering, cropping); empty when the attack creates new vertices
    /// (simplification, remeshing, subdivision).
    std::optional<std::vector<std::int32_t>> source_vertex;
};

/// \brief The identity correspondence 0, 1, ..., n - 1.
[[nodiscard]] std::vector<std::int32_t> identity_correspondence(Eigen::Index n);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/attacks/similarity.h"

#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Geometry>

#include "attacks/detail/format.h"
#include "attacks/detail/sampling.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

bool is_finite(const Eigen::Vector3d& v)
{
    return v.allFinite();
}

// Rotation uniform over SO(3): a uniformly random unit quaternion [Shoemake, Graphics Gems III].
Eigen::Matrix3d random_rotation(Rng& rng)
{
    const double u1 = rng.uniform();
    const double u2 = 2.0 * std::numbers::pi * rng.uniform();
    const double u3 = 2.0 * std::numbers::pi * rng.uniform();
    const double a = std::sqrt(1.0 - u1);
    const double b = std::sqrt(u1);
    const Eigen::Quaterniond q(b * std::cos(u3), a * std::sin(u2), a * std::cos(u2),
                               b * std::sin(u3));
    return q.normalized().toRotationMatrix();
}

AppliedSimilarity explicit_transform(const SimilarityOptions& options)
{
    AppliedSimilarity transform;
    const double angle_rad = options.angle_deg * std::numbers::pi / 180.0;
    transform.rotation = Eigen::AngleAxisd(angle_rad, options.axis.normalized()).toRotationMatrix();
    if (options.mirror >= 0)
    {
        transform.rotation.col(options.mirror) *= -1.0;  // R * M: the mirror first
    }
    transform.scale = options.scale;
    transform.translation = options.translation;
    return transform;
}

AppliedSimilarity random_transform(const TriangleMesh& mesh, const SimilarityOptions& options,
                                   Rng& rng)
{
    // Rotate and scale about the bbox centre c, then move c: p -> s R (p - c) + c + t.
    const BoundingBox box = bounding_box(mesh.V, referenced_vertices(mesh));
    const Eigen::Vector3d c = box.center();
    AppliedSimilarity transform;
    transform.rotation = random_rotation(rng);
    transform.scale = std::exp(rng.uniform(-1.0, 1.0) * std::log(options.max_scale));
    const double length = rng.uniform() * options.max_translation_radii * 0.5 * box.diagonal();
    const Eigen::Vector3d t = length * detail::random_unit_vector(rng);
    transform.translation = c + t - transform.scale * (transform.rotation * c);
    return transform;
}

}  // namespace

void SimilarityOptions::validate() const
{
    if (!is_finite(axis) || axis.norm() == 0.0)
    {
        throw InvalidOption("similarity: the rotation axis must be a finite non-zero vector.");
    }
    if (!std::isfinite(angle_deg))
    {
        throw InvalidOption("similarity: the angle must be a finite number of degrees.");
    }
    if (!std::isfinite(scale) || scale <= 0.0)
    {
        throw InvalidOption("similarity: scale " + detail::format_number(scale) +
                            " must be a finite number > 0.");
    }
    if (mirror < -1 || mirror > 2)
    {
        throw InvalidOption("similarity: mirror " + std::to_string(mirror) +
                            " is not -1 (none), 0 (x), 1 (y) or 2 (z).");
    }
    if (!is_finite(translation))
    {
        throw InvalidOption("similarity: the translation must be finite.");
    }
    if (!std::isfinite(max_scale) || max_scale < 1.0 || max_scale > 1e6)
    {
        throw InvalidOption("similarity: smax " + detail::format_number(max_scale) +
                            " is outside [1, 1e6].");
    }
    if (!std::isfinite(max_translation_radii) || max_translation_radii < 0.0 ||
        max_translation_radii > 1e6)
    {
        throw InvalidOption("similarity: tmax " + detail::format_number(max_translation_radii) +
                            " is outside [0, 1e6].");
    }
}

AppliedSimilarity similarity_transform(const TriangleMesh& mesh, const SimilarityOptions& options,
                                       Rng& rng)
{
    options.validate();
    return options.is_random ? random_transform(mesh, options, rng) : explicit_transform(options);
}

TriangleMesh transformed(const TriangleMesh& mesh, const AppliedSimilarity& transform)
{
    TriangleMesh result;
    result.F = mesh.F;
    if (transform.rotation.determinant() < 0.0)
    {
        result.F.col(1).swap(result.F.col(2));
    }
    // Row-vector form of s R p + t for all rows at once.
    result.V = (mesh.V * (transform.scale * transform.rotation).transpose()).rowwise() +
               transform.translation.transpose();
    return result;
}

AttackResult apply_similarity(const TriangleMesh& mesh, const SimilarityOptions& options, Rng& rng)
{
    const AppliedSimilarity transform = similarity_transform(mesh, options, rng);
    return {transformed(mesh, transform), transform, identity_correspondence(mesh.V.rows())};
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/similarity_fit.h"
#include "registration/detail/surface_matcher.h"

namespace meshmark::detail
{

/// x -> scale * rotation * x + translation, with a proper rotation (det = +1). Mirrored
/// candidates mirror their source points once instead (registration_problem.h).
using Similarity = SimilarityTransform;

/// Rows of \p X mapped by \p T (parallel, disjoint writes).
[[nodiscard]] Positions apply(const Similarity& T, const Positions& X, int threads);

/// Settings shared by both ICP variants.
struct IcpSettings
{
    double trim_keep = 0.9;  ///< Fraction of closest pairs kept per iteration.
    int max_iterations = 20;
    double tolerance = 1e-6;      ///< Stop when one update is smaller (relative, see icp.cpp).
    double min_scale = 0.0;       ///< Scale clamp (point-to-point only): guards against
    double max_scale = 1e300;     ///< collapse onto a small part of the target.
    double distance_floor = 0.0;  ///< Absolute floor of the overlap threshold.
    int threads = 1;
};

/// State after an ICP run or an evaluation.
struct IcpOutcome
{
    Similarity transform;
    double trimmed_rms = 0.0;       ///< RMS distance of the kept pairs, target units.
    double overlap_fraction = 0.0;  ///< Samples closer than 3 * trimmed_rms (or the floor).
    int iterations = 0;
    bool reached_tolerance = false;
};

/// \brief Trimmed point-to-point ICP with uniform scale: each iteration matches, keeps the
/// closest `trim_keep` of the pairs and solves the similarity in closed form (fit_similarity).
/// The returned statistics are those of the last matching (before the last update).
[[nodiscard]] IcpOutcome icp_point_to_point(const Positions& X, const SurfaceMatcher& target,
                                            const Similarity& start, const IcpSettings& settings);

/// \brief Trimmed point-to-plane ICP with uniform scale: one damped Gauss-Newton step of the
/// linearized similarity per iteration [Chen & Medioni 1992; Low 2004 for the linearization].
/// \pre target.has_normals().
[[nodiscard]] IcpOutcome icp_point_to_plane(const Positions& X, const SurfaceMatcher& target,
                                            const Similarity& start, const IcpSettings& settings);

/// \brief SurfaceMatch once and report trimmed RMS and overlap of \p T, without updating it.
[[nodiscard]] IcpOutcome evaluate(const Positions& X, const SurfaceMatcher& target,
                                  const Similarity& T, const IcpSettings& settings);

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <span>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/geometry/point_kd_tree.h"

namespace meshmark
{

/// How much work shape_fit does; the defaults are those of `catalog scan`.
struct ShapeFitOptions
{
    int start_stride = 8;      ///< start poses scored on every n-th of the suspect's points
    double start_bound = 0.2;  ///< starts: a point farther than this share of the asset's RMS
                               ///< radius from its points counts as that far (0: none)
    int coarse_poses = 8;      ///< the best start poses refined by ICP
    int coarse_stride = 4;     ///< on every n-th point
    int coarse_rounds = 5;     ///< ICP rounds of those
    int fine_stride = 1;       ///< the best of those refined again on every n-th point
    int fine_poses = 2;        ///< how many
    int fine_rounds = 10;      ///< ICP rounds of those
    double settled = 1e-3;     ///< a round that improves the fit by less than this share ends it
    double kept = 0.9;         ///< share of the suspect's points measured: the closest
    bool to_plane = true;      ///< measure the distance along the asset's normal
    bool across = true;        ///< refine by the distances to the asset's tangent planes
};

/// The similarity shape_fit found: a suspect point x (its first coordinate negated first when
/// \p mirrored) lies at scale * rotation * x + translation in the asset's frame.
struct ShapeFitPose
{
    bool mirrored = false;
    double scale = 1.0;
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

/// \brief How far a suspect's surface lies from an asset's after the best similarity (mirror
/// images included) taking the suspect onto the asset or onto one of its crop views: the RMS of
/// the distances from the suspect's points to the asset's nearest points along the asset's
/// normals (and 1% of the rest; the closest nine tenths of the points), over the suspect's RMS
/// radius, in the suspect's own units (so shrinking a suspect into a corner of the asset does
/// not help).
/// \details A quick geometric check of the shape index's candidates: the index's features
/// cannot tell near-duplicates apart (variants of one object) nor rank a crop's asset well, a
/// fit of the points can (bench/results/2026-11-30-shape-fit.md). Start poses: the principal
/// axes of the suspect's points, as given and mirrored, set on those of the asset's whole and of
/// each crop view given (the points above the view's plane) in the 24 turns of a cube, each
/// scored as it stands; the best refined by point-to-point ICP [Besl and McKay 1992] on a part
/// of the points, the best of those by rounds to the asset's tangent planes [Chen and Medioni
/// 1992] on all of them. Deterministic: the same points give the same value.
/// \param suspect points drawn on the suspect's surface (shape_sample; a few hundred).
/// \param asset the asset's points (shape_sample of the original, in the original's frame), and
/// \p tree over them.
/// \param views crop views of the asset's signature to start from too (1 to kShapeViews - 1).
/// \param pose when given, receives the best fit's similarity (unchanged when none was found).
/// \return the fit's relative RMS; infinity when either has fewer than 8 points.
[[nodiscard]] double shape_fit(const Positions& suspect, const Positions& asset,
                               const Positions& asset_normals, const PointKdTree& tree,
                               std::span<const int> views, const ShapeFitOptions& options = {},
                               ShapeFitPose* pose = nullptr);

}  // namespace meshmark

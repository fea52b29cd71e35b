// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Number of features that describe one view of a shape (shape_features).
inline constexpr int kShapeFeatures = 30;
/// The first features of a view, those of the surface's positions: catalogues written before
/// the normals' features were added hold these alone (kShapePositionFeatures bytes a view).
inline constexpr int kShapePositionFeatures = 24;

/// \brief A view's features, each in [0, 1]: the cumulative distributions of the distance to
/// the centroid (6 values), of the distance between two surface points (12) and of the angle
/// at the middle one of three (4), distances over the view's RMS radius, and the second and
/// third principal variances over the first (2); then of the angle between the surface normals
/// at two points, as |cos| (6). Compared with shape_distance.
using ShapeFeatures = std::array<float, kShapeFeatures>;

/// \brief The features of a mesh's whole surface and of the parts a plane crop could leave of it
/// (a catalogue's shape index: catalog/shape_index.h).
/// \details Every feature is a distance ratio or an angle, so it does not change when the mesh
/// is moved, rotated, mirrored or scaled, and it is measured on points drawn by area over the
/// surface (the vertices of a point cloud), so it changes little when the surface is resampled,
/// simplified, remeshed, smoothed or slightly noised, and not at all when vertices are
/// renumbered (up to the sampling's noise, which is what a suspect's own draw differs by). A
/// suspect cropped by a plane looks like the part of the nearest of kShapeCropDirections
/// directions that keeps the nearest of kShapeCropFractions of the area: views[0] is the
/// whole, then for each direction the parts keeping each fraction.
struct ShapeSignature
{
    std::vector<ShapeFeatures> views;
    /// kShapePoints points drawn by area on the surface (shape_sample), in the original's
    /// frame, and their triangles' unit normals: what shape_fit checks a candidate with. Empty
    /// in a signature stored before they were kept.
    Positions points;
    Positions normals;

    /// Compact form for storage: each feature as an 8-bit fixed-point value (30 bytes a view,
    /// 7,710 an asset; the rounding, 0.002, is below the draw's noise), then the points'
    /// section when there are points (kShapePointBytes: the points' bounding box as six 32-bit
    /// floats, each point as three 16-bit fractions of the box, each normal as three 8-bit
    /// values; 12,342 bytes in all).
    [[nodiscard]] std::vector<std::uint8_t> to_bytes() const;
    /// \throws InvalidOption when \p bytes is neither a whole number of views nor the
    /// kShapeViews views and the points' section.
    [[nodiscard]] static ShapeSignature from_bytes(std::span<const std::uint8_t> bytes);
    /// \brief The points and normals of a points' section (the bytes after the views).
    /// \throws InvalidOption when \p bytes is not kShapePointBytes long.
    static void points_from_bytes(std::span<const std::uint8_t> bytes, Positions& points,
                                  Positions& normals);
};

inline constexpr int kShapeCropDirections = 64;  ///< a Fibonacci lattice on the sphere
/// Fractions of the area a crop view keeps: a crop keeping half the vertices may keep from a
/// third to two thirds of the area.
inline constexpr std::array<double, 4> kShapeCropFractions = {0.35, 0.5, 0.65, 0.8};
inline constexpr int kShapeViews =
    1 + kShapeCropDirections * static_cast<int>(kShapeCropFractions.size());
/// Points an original's signature keeps for shape_fit: with the asset's crop views as start
/// poses, 512 rank attacked copies as well as 1,024 and 2,048
/// (bench/results/2026-11-30-shape-fit.md).
inline constexpr int kShapePoints = 512;
inline constexpr std::size_t kShapePointBytes =
    6 * sizeof(float) + static_cast<std::size_t>(kShapePoints) * (3 * 2 + 3);

/// \brief The directions of the crop views, in the original's frame: view 1 + 4 d + f keeps
/// the fraction kShapeCropFractions[f] of the area highest along direction d.
[[nodiscard]] std::vector<Eigen::Vector3d> shape_crop_directions();

/// The features of \p mesh's whole surface (a suspect's). A mesh without area or points: zeros.
[[nodiscard]] ShapeFeatures shape_features(const TriangleMesh& mesh);

/// The whole and the crop views of \p mesh (an original's). Deterministic.
[[nodiscard]] ShapeSignature shape_signature(const TriangleMesh& mesh);

/// \brief \p count points drawn by area on \p mesh's surface as shape_features draws them (in
/// an order of the triangles that does not depend on the file); a point cloud's vertices.
/// \p normals, when given, receives each point's unit triangle normal (zero for a point cloud).
[[nodiscard]] Positions shape_sample(const TriangleMesh& mesh, int count,
                                     Positions* normals = nullptr);

/// \brief Euclidean distance between two views' features, each block weighted so that a block
/// that differs entirely counts about as much as any other.
[[nodiscard]] float shape_distance(const ShapeFeatures& a, const ShapeFeatures& b) noexcept;

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <memory>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Result of one closest-point query.
struct ClosestPoint
{
    Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< Closest point on the surface (or cloud).
    double distance = 0.0;                            ///< Euclidean distance to the query.
    std::int32_t face = -1;    ///< Triangle holding the point; -1 for a point cloud.
    std::int32_t vertex = -1;  ///< Nearest vertex for a point cloud; -1 for a surface.
};

/// \brief Exact closest-point queries on a triangle surface, or nearest-vertex queries on a
/// point cloud, through a search structure built once: a bounding-volume hierarchy over the
/// triangles, or a PointKdTree over the points.
/// \details Built from a mesh's faces (a triangle soup works); a mesh with no faces is
/// treated as a point cloud. Queries are const and thread-safe, so callers parallelize over
/// them. On a surface, ties between triangles at exactly the same distance go to the lowest
/// face index, so answers depend only on the query and the mesh. Used by the resampling of
/// detection (registration/resampling.h) and the distortion metrics; ICP uses its own lighter
/// matcher over the same kd-tree and triangle routine (point_kd_tree.h, point_triangle.h).
class ClosestPointIndex
{
public:
    /// \brief Build the search structure. \p mesh need not outlive the index (its triangles or
    /// points are copied).
    /// \throws InvalidMesh if the mesh has no vertices, or more than 2^30 - 1 faces.
    explicit ClosestPointIndex(const TriangleMesh& mesh);
    ~ClosestPointIndex();
    ClosestPointIndex(ClosestPointIndex&&) noexcept;
    ClosestPointIndex& operator=(ClosestPointIndex&&) noexcept;
    ClosestPointIndex(const ClosestPointIndex&) = delete;
    ClosestPointIndex& operator=(const ClosestPointIndex&) = delete;

    /// Closest point to \p query (exact point-triangle distance; see closest_point_on_triangle).
    [[nodiscard]] ClosestPoint closest(const Eigen::Vector3d& query) const;

    /// \brief Closest points of many queries, in parallel over \p threads (0 = all cores).
    /// \param queries #Q×3. \return one result per row, in order (deterministic).
    [[nodiscard]] std::vector<ClosestPoint> closest(const Positions& queries,
                                                    int threads = 0) const;

    [[nodiscard]] bool is_point_cloud() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// One ICP correspondence: the point found on the target, the target's unit normal there
/// (zero when the target is a point set) and the distance to the query.
struct SurfaceMatch
{
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    double distance = 0.0;
};

/// \brief Closest-point queries used inside ICP: a kd-tree over the target's vertices
/// (PointKdTree) and, for a mesh, projection onto the triangles around the nearest vertex
/// (closest_point_on_triangle, without the sliver check). Triangles much larger than the
/// median edge also put a lattice of points into the tree; a query nearest to one is projected
/// onto the triangles around that triangle's corners.
/// \details Also used by detection's symmetry search, over the registration's own
/// (RegistrationOptions::keep_reference_surface), so that no second structure over the original
/// is built. Why not ClosestPointIndex (an exact bounding-volume hierarchy over the triangles)
/// here: ICP runs against the whole reference, and a kd-tree over its vertices (about half as
/// many items as triangles, no triangle copies) is the cheaper build. The one-ring projection
/// returns the exact closest point whenever the closest triangle touches the nearest vertex,
/// which holds for all but near-tied queries on meshes with obtuse triangles; ICP only needs
/// the correspondence, and the resampling (which must be exact) uses ClosestPointIndex.
/// Queries are const and thread-safe.
class SurfaceMatcher
{
public:
    /// Point target: nearest point of \p points (#P×3), zero normals.
    explicit SurfaceMatcher(Positions points);
    /// Surface target: the vertices used by \p mesh's faces, projected onto their triangles.
    /// A mesh without faces is a point target over all its vertices.
    explicit SurfaceMatcher(const TriangleMesh& mesh);
    ~SurfaceMatcher();
    SurfaceMatcher(const SurfaceMatcher&) = delete;
    SurfaceMatcher& operator=(const SurfaceMatcher&) = delete;
    SurfaceMatcher(SurfaceMatcher&&) = delete;
    SurfaceMatcher& operator=(SurfaceMatcher&&) = delete;

    /// Closest point to \p query.
    [[nodiscard]] SurfaceMatch match(const Eigen::Vector3d& query) const;

    /// Matches of every row of \p queries, in parallel over \p threads (disjoint writes).
    void match_all(const Positions& queries, std::vector<SurfaceMatch>& out, int threads) const;

    /// True when matches carry normals (the target has triangles).
    [[nodiscard]] bool has_normals() const noexcept;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace meshmark

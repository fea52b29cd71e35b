// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/geometry/closest_point_index.h"

namespace meshmark
{

/// Parameters of resample(). The crop threshold is
/// `max(edge_factor * h, quantile_factor * q)`, where `h` is the reference's mean edge length
/// (median nearest-neighbour spacing for a point cloud) and `q` the `quantile` of all
/// closest distances. Why these defaults: see docs/algorithms/registration.md ("Crop marking").
struct ResamplingOptions
{
    double edge_factor = 2.0;       ///< Floor of the threshold, in mean edge lengths.
    double quantile_factor = 10.0;  ///< Multiple of the distance quantile.
    /// Quantile of the distances that measures the attack's displacement. 0.25 stays inside the
    /// surviving part for crops that remove up to 75% of the vertices.
    double quantile = 0.25;
    int threads = 0;  ///< 0 = all cores.

    /// \throws InvalidOption naming the field, its value and the allowed range.
    void validate() const;
};

/// The suspect's surface sampled at the reference's vertices.
struct Resampling
{
    Positions points;          ///< #V_ref×3: closest suspect point, reference frame.
    Eigen::VectorXd distance;  ///< #V_ref distances to those points, reference units.
    std::vector<std::uint8_t>
        is_cropped;                 ///< #V_ref flags: 1 when the distance exceeds the threshold.
    double cropped_fraction = 0.0;  ///< Flagged fraction of the reference's vertices.
    double crop_threshold = 0.0;    ///< The threshold used, reference units.
    double mean_edge_length = 0.0;  ///< `h` above, reference units.
    /// #V_ref: the suspect's triangle holding each point (its vertex for a point cloud).
    std::vector<std::int32_t> element;
};

/// \brief For every vertex of \p reference, the closest point on the registered suspect's
/// surface (exact point-triangle distance; nearest vertex when the suspect is a point cloud),
/// and the vertices whose distance marks them as cropped.
/// \details Queries run in the suspect's own frame (reference vertices mapped by the inverse
/// of \p suspect_to_reference, results mapped back), so the suspect's index is built once and
/// never moved. Parallel over vertices with disjoint writes and a serial quantile: the result
/// is bit-identical for any thread count. Unreferenced reference vertices are resampled too.
/// \param reference             The mesh to sample at (#V_ref vertices): for detection, the
///                              original (the unwatermarked mesh the key was made from), so
///                              that no watermark displacement is copied onto the suspect.
/// \param suspect               Mesh, triangle soup or point cloud.
/// \param suspect_to_reference  A similarity, e.g. RegistrationResult::transform.
/// \throws InvalidMesh if a mesh is empty; InvalidOption if the transform is singular or
/// options are out of range.
[[nodiscard]] Resampling resample(const TriangleMesh& reference, const TriangleMesh& suspect,
                                  const Eigen::Matrix4d& suspect_to_reference,
                                  const ResamplingOptions& options = {});

/// \brief Same, with a prebuilt index of the suspect (in the suspect's frame).
[[nodiscard]] Resampling resample(const TriangleMesh& reference,
                                  const ClosestPointIndex& suspect_index,
                                  const Eigen::Matrix4d& suspect_to_reference,
                                  const ResamplingOptions& options = {});

/// \brief Measure each resampled point against the reference's own surface under the suspect's
/// triangles: `points` becomes `reference vertex + (point - the same barycentric combination of
/// the suspect triangle's corners, each moved to its closest point on the reference surface)`;
/// `distance`, `is_cropped` and the crop threshold are left as they were.
/// \details A coarse suspect (simplified, remeshed) lies off the reference by the chord error of
/// its triangles even where it carries nothing: a point in a triangle spanning a curved region
/// sits below the surface by much more than a watermark's amplitude. That error is the same
/// for the triangle laid through the closest points of its corners on the reference, so the
/// difference between the two keeps what the corners carry (their offset from the reference,
/// interpolated) and drops the chord error. For a suspect that is the reference (same surface,
/// any connectivity) every offset is 0. Only \p suspect and \p reference are used, never a
/// watermark, so a detection's false-positive bound is unaffected. Bit-identical for any thread
/// count.
/// The closest point of each corner on the reference is found by a walk over the reference's
/// faces from the reference vertex nearest to the corner (a kd-tree of the reference's
/// vertices; a search structure over its triangles would cost 190 MB more on 1M vertices).
/// \param sampled  The result of resample() for the same meshes and transform.
/// \throws InvalidOption if \p sampled was not made for \p reference.
void match_reference_surface(Resampling& sampled, const TriangleMesh& reference,
                             const TriangleMesh& suspect,
                             const Eigen::Matrix4d& suspect_to_reference, int threads = 0);

/// \brief Mean length of the face edges of \p mesh (each face's three edges, so interior
/// edges count twice); for a point cloud the median nearest-neighbour distance instead.
[[nodiscard]] double mean_edge_length(const TriangleMesh& mesh);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string_view>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/geometry/closest_point_index.h"

namespace meshmark
{

/// Automatic area-sample count: kAutoSamplesPerFace per face, at least kMinAutoSamples and at
/// most kMaxAutoSamples (the cap bounds the time on very large meshes: see
/// docs/algorithms/metrics.md).
inline constexpr std::int64_t kAutoSamplesPerFace = 10;
inline constexpr std::int64_t kMinAutoSamples = 1'000'000;
inline constexpr std::int64_t kMaxAutoSamples = 2'000'000;

/// Parameters of compare_meshes.
struct CompareOptions
{
    /// Area samples per surface, on top of its vertices; 0 = automatic (auto_sample_count).
    std::int64_t samples = 0;
    std::uint64_t seed = 0;  ///< Seed of the stratified sampling.
    int threads = 0;         ///< Worker threads (0 = all cores); results do not depend on it.
    bool keep_vertex_distances = false;  ///< Fill DistortionReport::vertex_distances_ba (heatmaps).
    /// Optional progress report, the pipeline's ProgressCallback protocol: each phase ("index",
    /// "a_to_b", "b_to_a", the names of DistortionReport::seconds) is announced with fraction 0
    /// when it starts and 1 when it ends. The library never prints.
    std::function<void(std::string_view phase, double fraction)> progress;

    /// \throws InvalidOption naming the field if samples or threads is negative.
    void validate() const;
};

/// Distances from the points of one surface to another surface, in the meshes' units.
struct OneSidedDistance
{
    double max = 0.0;   ///< One-sided Hausdorff distance: largest distance of any sample.
    double rms = 0.0;   ///< Area-weighted root mean square distance.
    double mean = 0.0;  ///< Area-weighted mean distance.
    Eigen::Vector3d max_point = Eigen::Vector3d::Zero();  ///< Sample where the maximum is reached.
    std::int64_t vertex_samples = 0;  ///< Vertices used as samples (referenced ones).
    std::int64_t area_samples = 0;    ///< Stratified area samples.
};

/// Vertex-to-vertex displacement between two meshes that share connectivity.
struct Displacement
{
    double max = 0.0;              ///< Largest |b_i - a_i|.
    double rms = 0.0;              ///< sqrt(mean |b_i - a_i|^2) over the referenced vertices.
    std::int32_t max_vertex = -1;  ///< Vertex of the largest displacement.
};

/// Wall-clock seconds of the phases of compare_meshes (not deterministic, for reports only).
struct CompareSeconds
{
    double index = 0.0;   ///< Building both closest-point indices.
    double a_to_b = 0.0;  ///< Sampling A and querying B.
    double b_to_a = 0.0;  ///< Sampling B and querying A.
    double total = 0.0;
};

/// Everything compare_meshes measures. Fields named `_rel` are divided by `diagonal`.
struct DistortionReport
{
    double diagonal =
        0.0;  ///< Bounding-box diagonal of A's referenced vertices (the unit of `_rel`).
    OneSidedDistance a_to_b;        ///< Samples of A, distances to the surface of B.
    OneSidedDistance b_to_a;        ///< Samples of B, distances to the surface of A.
    double hausdorff_rel = 0.0;     ///< Symmetric Hausdorff: max(hausdorff_ab, hausdorff_ba).
    double hausdorff_ab_rel = 0.0;  ///< a_to_b.max / diagonal.
    double hausdorff_ba_rel = 0.0;  ///< b_to_a.max / diagonal.
    double rms_ab_rel = 0.0;        ///< a_to_b.rms / diagonal.
    double rms_ba_rel = 0.0;        ///< b_to_a.rms / diagonal.
    double mrms_rel = 0.0;          ///< max(rms_ab, rms_ba) [Wang et al. 2010].
    std::optional<Displacement> displacement;  ///< Absolute; set when A and B share connectivity.
    double max_displacement_rel = 0.0;  ///< displacement->max / diagonal (0 without displacement).
    double rms_displacement_rel = 0.0;  ///< displacement->rms / diagonal (0 without displacement).
    Eigen::VectorXd vertex_distances_ba;  ///< #V_B distances of B's vertices to A, if requested.
    CompareSeconds seconds;
};

/// \brief Automatic area-sample count of a mesh: clamp(kAutoSamplesPerFace * #F,
/// kMinAutoSamples, kMaxAutoSamples); 0 for a point cloud (its points are the samples).
[[nodiscard]] std::int64_t auto_sample_count(const TriangleMesh& mesh);

/// \brief Surface-to-surface distortion between two meshes (Hausdorff, RMS, MRMS, displacement).
/// \details Each surface is sampled (its referenced vertices, plus `samples` area-proportional
/// stratified points, see sample_surface) and every sample is measured against the exact
/// closest point on the other surface's triangles, as in Metro [Cignoni et al. 1998]. The
/// one-sided Hausdorff distance is the largest sample distance (vertices included, so a
/// displaced vertex is never missed); RMS and mean are area-weighted, from the area samples
/// only. MRMS is the larger of the two one-sided RMS distances, the distortion measure of the
/// watermarking benchmark [Wang et al. 2010, "A benchmark for 3D mesh watermarking"]. A point
/// cloud is sampled at its points (equal weights) and measured by nearest point.
/// When the meshes share connectivity (has_same_connectivity), the vertex displacement is
/// reported too. Deterministic for a given seed, for any thread count.
/// \param a, b     The meshes; A defines the unit (its bounding-box diagonal).
/// \param options  See CompareOptions.
/// \throws InvalidOption (see CompareOptions::validate); InvalidMesh if a mesh has no
/// referenced vertex or A's bounding-box diagonal is zero or not finite.
[[nodiscard]] DistortionReport compare_meshes(const TriangleMesh& a, const TriangleMesh& b,
                                              const CompareOptions& options = {});

/// \brief One direction of compare_meshes: samples of \p from measured against \p to.
/// \param from     Sampled mesh (vertices and \p area_samples stratified points).
/// \param to       Index of the other surface.
/// \param vertex_distances If not null, receives the distance of every vertex of \p from
///                 (#V entries, unreferenced ones included).
/// \throws InvalidOption if area_samples is negative.
[[nodiscard]] OneSidedDistance one_sided_distance(const TriangleMesh& from,
                                                  const ClosestPointIndex& to,
                                                  std::int64_t area_samples, std::uint64_t seed,
                                                  int threads = 0,
                                                  Eigen::VectorXd* vertex_distances = nullptr);

/// \brief True when both meshes have the same vertex count and identical faces (same rows in
/// the same order); two point clouds of the same size qualify.
[[nodiscard]] bool has_same_connectivity(const TriangleMesh& a, const TriangleMesh& b);

/// \brief Displacement of each referenced vertex between two meshes with shared connectivity.
/// \throws InvalidMesh if has_same_connectivity(a, b) is false.
[[nodiscard]] Displacement vertex_displacement(const TriangleMesh& a, const TriangleMesh& b);

/// \brief First-order RMS distance between a surface and the same surface displaced by a small
/// vertex field: what compare_meshes' RMS distances read of a displacement that is small
/// against the surface's curvature radius, without sampling or a closest-point search.
/// \details A displaced point leaves the surface by the normal component of its displacement
/// (the tangential part slides along it). Over a triangle with unit normal n that component is
/// the linear interpolation of a_c = n . d_c at its corners, whose mean square over the
/// triangle is (a_0^2 + a_1^2 + a_2^2 + a_0 a_1 + a_1 a_2 + a_2 a_0) / 6; the result is the
/// square root of the area-weighted mean of that over the triangles, summed in face order in
/// fixed blocks (the same result on any thread count). Second-order terms (the curvature, the
/// tilt of the faces) lower the sampled distance: the MRMS of compare_meshes reads up to 1%
/// below this, or on it within its sampling noise (docs/algorithms/embedding.md, "Strength"). A
/// point cloud, which has no normals, gets the expected normal part of an isotropic field:
/// sqrt(mean |d|^2 / 3) over its points. \param mesh   The surface (its faces and positions).
/// \param field  #V x 3 displacement.
/// \param threads  0 = all cores (the result does not depend on it).
/// \return In the mesh's units; 0 for a mesh whose triangles have no area.
[[nodiscard]] double surface_rms_displacement(const TriangleMesh& mesh, const Positions& field,
                                              int threads = 0);

/// \brief surface_rms_displacement of many fields `base + c * field` that share `base` (a
/// family's copies: the owner's mark plus each recipient's code): the faces' unit normals and
/// weights and the base's normal components are computed once, each field then costs one pass
/// over the faces (3 dot products per face), summed in face order.
class SurfaceRmsOfSums
{
public:
    /// \param mesh  Must outlive this object. \param base  #V x 3.
    SurfaceRmsOfSums(const TriangleMesh& mesh, const Positions& base);

    /// Area-weighted first-order mean products of the normal parts:
    /// surface_rms_displacement(mesh, base + c field)^2 = bb + 2 c bf + c^2 ff.
    struct Terms
    {
        double bb = 0.0;
        double bf = 0.0;
        double ff = 0.0;
        /// surface_rms_displacement of base + c field.
        [[nodiscard]] double rms(double c) const noexcept;
        /// \brief The c > 0 for which rms(c) = \p target; 1 when there is none (a field with
        /// no normal part, or a base already beyond the target).
        [[nodiscard]] double scale_to(double target) const noexcept;
    };
    [[nodiscard]] Terms terms(const Positions& field) const;

private:
    const TriangleMesh* mesh_;
    Positions normal_;        // #F x 3 unit normals (zero for a triangle with no area)
    Eigen::VectorXd weight_;  // #F: area / total area
    Positions base_part_;     // #F x 3: n_f . base at the face's corners
    double bb_ = 0.0;
};

}  // namespace meshmark

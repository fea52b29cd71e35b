// SPDX-License-Identifier: MIT
#include "pipeline/detect/correspondence.h"

#include <cmath>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/renumbering.h"
#include "meshmark/registration/self_symmetry.h"
#include "meshmark/registration/vertex_matching.h"
#include "pipeline/detect/rows.h"
#include "pipeline/detect/similarity_fit.h"

namespace meshmark::detail
{
namespace
{

// A same-count suspect whose vertices, after the best similarity, lie within this fraction of
// the diagonal of the original (RMS) is taken vertex for vertex. Attacks that keep the
// order stay far below (1% noise: ~0.6%); a reordered copy is far above (~30%).
constexpr double kCorrespondenceTolerance = 0.02;

// Triangles cannot tell identical parts apart: Blender's OBJ writer, after joining a table's
// five objects whose legs are alike, wrote the same triangles over the legs' vertices in
// another order, and a renumbering by parts of its other writers' output was as wrong; both put
// the vertices 87% of the diagonal (RMS) from the original's after the best similarity, and the
// copies were read as unmarked (bench/results/2026-11-30-add-and-scan.md). Triangles that
// leave them farther than this (the strongest smoothing on record, Blender's Smooth 0.5 x 10,
// moves them a few percent) are taken for a wrong correspondence, and the copy is registered.
constexpr double kRenumberedTolerance = 0.1;

// Rounds of the far-rows rule and the similarity refitted without them, for a suspect read
// vertex for vertex, until the rows left out stay the same.
constexpr int kMaxOutlierRefits = 10;

// The original followed by its other instances, as one mesh (the registration's reference).
TriangleMesh with_instances(const TriangleMesh& original, const TriangleMesh& instances)
{
    TriangleMesh shown;
    shown.V.resize(original.V.rows() + instances.V.rows(), 3);
    shown.V << original.V, instances.V;
    shown.F.resize(original.F.rows() + instances.F.rows(), 3);
    shown.F << original.F,
        (instances.F.array() + static_cast<std::int32_t>(original.V.rows())).matrix();
    return shown;
}

// Two meshes with every polygon as its fan (TriangleMesh::fans), to compare their triangles.
struct FannedPair
{
    FannedPair(const TriangleMesh& original_mesh, const TriangleMesh& suspect_mesh)
        : original(fanned(original_mesh)), suspect(fanned(suspect_mesh))
    {
    }
    static TriangleMesh fanned(const TriangleMesh& mesh)
    {
        TriangleMesh out;
        out.V = mesh.V;
        out.F = with_fans(mesh);
        return out;
    }
    TriangleMesh original;
    TriangleMesh suspect;
};

// RMS distance of suspect rows in the original's order to the original, over the diagonal
// (over the rows \p kept marks, every row when null).
double relative_rms(const Positions& in_frame, const TriangleMesh& original, double diagonal,
                    const std::vector<std::uint8_t>* kept = nullptr)
{
    if (kept == nullptr)
    {
        return std::sqrt((in_frame - original.V).rowwise().squaredNorm().mean()) / diagonal;
    }
    const Eigen::VectorXd squared = (in_frame - original.V).rowwise().squaredNorm();
    double sum = 0.0;
    std::size_t count = 0;
    for (Eigen::Index i = 0; i < squared.size(); ++i)
    {
        if ((*kept)[static_cast<std::size_t>(i)] != 0)
        {
            sum += squared(i);
            ++count;
        }
    }
    return count > 0 ? std::sqrt(sum / static_cast<double>(count)) / diagonal : 0.0;
}

// A suspect in the original's vertex order (\p in_order, suspect frame; \p left_out: rows no
// suspect vertex stands for, null: none), taken onto the original by the similarity \p T fitted
// over all its rows: the rows a tool threw far away (the far-rows rule of resampled suspects, on
// the vertices' own distances) are left out too, and the similarity is fitted again without
// them, since the closed form has no defence against them.
void take_in_order(SuspectInFrame& found, const TriangleMesh& original, double amplitude,
                   const Positions& in_order, const Eigen::Matrix4d& T,
                   const std::vector<std::uint8_t>* left_out, std::size_t left_out_count)
{
    found.aligned = transform_points(T, in_order);
    found.transform = T;
    const Eigen::VectorXd distance = (found.aligned - original.V).rowwise().norm();
    std::size_t outliers = 0;
    found.kept_rows =
        kept_without_outliers(distance, left_out, kOutlierFloor * amplitude, outliers);
    // Refitted without the far rows until they stay the same: a fit over every row is pulled
    // by the far ones, and so are the distances that tell them (Blender's Smooth crushing a
    // fifth of a mesh: the first refit still left out the wrong rows).
    for (int round = 0; outliers > 0 && round < kMaxOutlierRefits; ++round)
    {
        const Eigen::Matrix4d refit =
            similarity_onto_original(original.V, in_order, &found.kept_rows);
        found.aligned = transform_points(refit, in_order);
        found.transform = refit;
        std::vector<std::uint8_t> again =
            kept_without_outliers((found.aligned - original.V).rowwise().norm(), left_out,
                                  kOutlierFloor * amplitude, outliers);
        if (again == found.kept_rows)
        {
            break;
        }
        found.kept_rows = std::move(again);
    }
    if (outliers + left_out_count > 0)
    {
        // Rows no suspect vertex stands for are what the copy no longer covers: cropped.
        found.has_kept_rows = true;
        found.outlier_fraction =
            static_cast<double>(outliers) / static_cast<double>(original.V.rows());
        found.cropped_fraction =
            static_cast<double>(left_out_count) / static_cast<double>(original.V.rows());
    }
}

// The vertices in the original's order (as they are, or renumbered by the triangles, where
// they stand or part by part) after the closed-form similarity onto the original [Umeyama
// 1991]. Whether they correspond.
bool read_in_order(SuspectInFrame& found, const DetectInputs& in, double amplitude, double diagonal,
                   const DetectFileOptions& options, PoseHints* hints)
{
    const TriangleMesh& original = in.original;
    const TriangleMesh& suspect = in.suspect;
    const bool same_count = suspect.V.rows() == original.V.rows();
    // Other triangles over as many vertices: perhaps the same mesh numbered another way, by its
    // triangles (Blender's PLY writer: renumbered_by_triangles) or where it stands (a re-encoded
    // Draco primitive: renumbered_in_place), then read in the original's order without
    // registration. Any count: perhaps the original's parts in another order, each numbered its
    // own way (Blender's writers after joining a model's objects: renumbered_by_parts).
    // A polygon's triangles depend on where its corners stand (a concave one is triangulated
    // inside its outline), so a copy whose vertices a tool moved may have other triangles over
    // the same polygons: Blender's Smooth 0.5 x 10 on an artists' bus. Their fans are the same.
    const bool has_fans = !original.fans.empty() || !suspect.fans.empty();
    std::optional<FannedPair> fanned;  // made when first needed
    const auto fans = [&]() -> const FannedPair&
    {
        if (!fanned)
        {
            fanned.emplace(original, suspect);
        }
        return *fanned;
    };
    bool same_triangles = same_count && has_same_triangles(suspect, original);
    std::optional<Positions> renumbered;
    std::optional<TriangleRenumbering> by_parts;
    if (!same_triangles && same_count)
    {
        renumbered = renumbered_by_triangles(original, suspect);
        if (!renumbered && has_fans)
        {
            same_triangles = has_same_triangles(fans().suspect, fans().original);
            if (!same_triangles)
            {
                renumbered = renumbered_by_triangles(fans().original, fans().suspect);
            }
        }
        if (same_triangles || renumbered)
        {
            if (hints != nullptr)
            {
                hints->is_numbered_by_triangles = true;
            }
        }
        else
        {
            renumbered =
                renumbered_in_place(original, suspect, kOutlierFloor * amplitude, options.threads);
        }
    }
    if (!same_triangles && !renumbered)
    {
        by_parts = renumbered_by_parts(original, suspect);
        if (!by_parts && has_fans)
        {
            by_parts = renumbered_by_parts(fans().original, fans().suspect);
        }
        if (!by_parts)
        {
            if (!same_count)
            {
                return false;
            }
        }
        else if (hints != nullptr)
        {
            hints->is_numbered_by_triangles = true;
        }
    }
    const Positions& in_order =
        by_parts ? by_parts->in_order : (renumbered ? *renumbered : suspect.V);
    const std::vector<std::uint8_t>* reached =
        by_parts && by_parts->unreached > 0 ? &by_parts->reached : nullptr;
    const Eigen::Matrix4d T = similarity_onto_original(original.V, in_order, reached);
    found.aligned = transform_points(T, in_order);
    found.registration_rms = relative_rms(found.aligned, original, diagonal, reached);
    found.transform = T;
    // Triangles that are the original's tell which vertex is which however far a tool moved
    // them (a strong smoothing of a CAD part: 2.4% of the diagonal RMS, whose far rows the
    // reading leaves out), up to kRenumberedTolerance (beyond, alike parts were taken for one
    // another); otherwise (a point cloud has none) the positions must say so.
    const bool has_triangles = original.F.rows() > 0;
    const bool by_triangles =
        (same_triangles && has_triangles) || renumbered.has_value() || by_parts.has_value();
    const bool is_corresponding =
        found.registration_rms <= (by_triangles ? kRenumberedTolerance : kCorrespondenceTolerance);
    if (!is_corresponding && hints != nullptr)
    {
        hints->is_numbered_by_triangles = false;
    }
    found.kind = Correspondence::InOrder;
    if (is_corresponding)
    {
        take_in_order(found, original, amplitude, in_order, T, reached,
                      by_parts ? by_parts->unreached : 0);
    }
    return is_corresponding;
}

// Registered: the registration's pose (or \p pose), the original's symmetries searched over its
// surface when wanted, then the vertices read in place when they are the original's again.
// The registration; \p found filled when the vertices were matched.
RegistrationResult register_copy(PhaseTimer& timer, SuspectInFrame& found, const DetectInputs& in,
                                 double amplitude, double diagonal,
                                 const DetectFileOptions& options, const Eigen::Matrix4d* pose,
                                 PoseHints* hints)
{
    const TriangleMesh& original = in.original;
    const TriangleMesh& suspect = in.suspect;
    // Any pose, connectivity or cropping: register onto the original, then take for every
    // vertex of it the closest point of the suspect's surface.
    timer.begin("register");
    RegistrationOptions registration;
    registration.threads = options.threads;
    // The poses read_symmetric_poses will read need the original's symmetries.
    const bool wants_symmetries = hints != nullptr && pose == nullptr &&
                                  in.instances.vertex_count() == 0 &&
                                  options.decision.verdict != VerdictRule::Bits;
    registration.keep_reference_surface = wants_symmetries;
    // A tool that flattens instanced meshes (gltf-transform optimize joins them) leaves a copy
    // that shows every instance: registered against the first instances alone, the others are
    // unexplained geometry that can pull the fit away.
    const bool has_instances = in.instances.vertex_count() > 0 &&
                               in.instances.is_point_cloud() == original.is_point_cloud();
    const TriangleMesh shown =
        has_instances ? with_instances(original, in.instances) : TriangleMesh{};
    const TriangleMesh& reference = has_instances ? shown : original;
    RegistrationResult registered;
    if (pose != nullptr)  // another pose of a symmetric original (read_symmetric_poses)
    {
        registered.transform = *pose;
        registered.converged = true;
    }
    else
    {
        registered = options.pairs.empty()
                         ? register_to_reference(suspect, reference, registration)
                         : register_to_reference(suspect, reference, options.pairs, registration);
    }
    timer.lap("register");
    if (hints != nullptr)
    {
        hints->other_handedness = registered.other_handedness;
    }
    if (wants_symmetries)
    {
        timer.begin("symmetry");
        hints->symmetries = self_symmetries(original, amplitude, options.threads,
                                            registered.reference_surface.get());
        registered.reference_surface.reset();
        timer.lap("symmetry");
    }
    timer.begin("correspondence");
    // The original's vertices again, reordered, split, welded or with vertices added between
    // them: read vertex for vertex (vertices_in_place), every component of the change instead
    // of its normal one. The registration need not have met its stopping tolerance: the pairs
    // are their own test of the pose (mutual nearest within a small part of an edge, nearly all
    // of them or whole original triangles), and a small thin mesh whose residual is the mark
    // itself can keep jittering between trimmed sets (Blender's glTF copy of a 762-vertex
    // spider).
    if (options.match_vertices && !has_instances)
    {
        if (const std::optional<VerticesInPlace> kept =
                vertices_in_place(original, suspect, registered.transform, amplitude,
                                  kOutlierFloor * amplitude, options.threads))
        {
            const auto n = static_cast<std::size_t>(original.V.rows());
            const std::vector<std::uint8_t>* left_out =
                kept->matched < n ? &kept->matched_rows : nullptr;
            take_in_order(found, original, amplitude, kept->in_order,
                          similarity_onto_original(original.V, kept->in_order, left_out), left_out,
                          n - kept->matched);
            found.transform = found.transform * registered.transform;  // suspect -> original
            found.kind = Correspondence::VerticesMatched;
            found.registration_rms = relative_rms(found.aligned, original, diagonal);
        }
    }
    return registered;
}

// Resampled at the original's vertices (with crop marking and the far rows left out).
void resample_copy(SuspectInFrame& found, const DetectInputs& in, const RegistrationResult& r,
                   double amplitude, const DetectFileOptions& options)
{
    const TriangleMesh& original = in.original;
    ResamplingOptions resampling;
    resampling.threads = options.threads;
    // Resample at the original's vertices: resampling at the watermarked mesh's vertices would
    // copy the watermark's tangential component onto any unmarked surface (measured: a
    // reordered unmarked bunny read R = 1.0 that way).
    found.sampled = resample(original, in.suspect, r.transform, resampling);
    found.to_original = r.transform;
    found.kind = r.converged ? Correspondence::Registered : Correspondence::RegisteredNotConverged;
    found.transform = r.transform;
    found.registration_rms = r.rms_error;
    found.cropped_fraction = found.sampled.cropped_fraction;
    found.is_cropped = found.sampled.cropped_fraction > 0.0;
    if (found.is_cropped)
    {
        found.kept_rows = kept_after_crop(original, found.sampled.is_cropped);
    }
    std::size_t outliers = 0;
    found.kept_rows =
        kept_without_outliers(found.sampled.distance, found.is_cropped ? &found.kept_rows : nullptr,
                              kOutlierFloor * amplitude, outliers);
    found.weight_scale = kWeightScale * amplitude;
    found.outlier_fraction =
        static_cast<double>(outliers) / static_cast<double>(found.kept_rows.size());
    found.has_kept_rows = found.is_cropped || outliers > 0;
    // Only the points and, for the second reading, the triangles they lie on are needed from
    // here on: the rest goes before the extraction's allocations.
    found.sampled.distance = Eigen::VectorXd();
    found.sampled.is_cropped = std::vector<std::uint8_t>();
}

}  // namespace

bool has_same_triangles(const TriangleMesh& a, const TriangleMesh& b)
{
    return a.F.rows() == b.F.rows() && (a.F.array() == b.F.array()).all();
}

SuspectInFrame find_correspondence(PhaseTimer& timer, const DetectInputs& in, double amplitude,
                                   const DetectFileOptions& options, const Eigen::Matrix4d* pose,
                                   PoseHints* hints)
{
    const TriangleMesh& original = in.original;
    const TriangleMesh& suspect = in.suspect;
    const double diagonal = bounding_box(original.V).diagonal();
    SuspectInFrame found;
    timer.begin("correspondence");
    // (A given pose is the caller's: the vertices are not taken in order without it.)
    bool is_corresponding = options.pairs.empty() && pose == nullptr &&
                            read_in_order(found, in, amplitude, diagonal, options, hints);
    RegistrationResult registered;  // suspects that do not correspond as they are
    if (!is_corresponding)
    {
        if (!options.allow_registration)
        {
            throw InvalidOption(
                in.suspect_path.string() +
                ": the suspect's vertices do not correspond to the "
                "original's (" +
                std::to_string(suspect.vertex_count()) + " vertices against " +
                std::to_string(original.vertex_count()) +
                ", or the same count in another order or shape), and registration is off "
                "(--no-register).");
        }
        registered = register_copy(timer, found, in, amplitude, diagonal, options, pose, hints);
        is_corresponding = found.kind == Correspondence::VerticesMatched;
    }
    if (!is_corresponding)
    {
        resample_copy(found, in, registered, amplitude, options);
    }
    timer.lap("correspondence");
    return found;
}

}  // namespace meshmark::detail

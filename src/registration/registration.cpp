// SPDX-License-Identifier: MIT
// register_to_reference and its variants: each lists its stages (samples and targets, starting
// transforms, the coarse tournament, the fine stage); the stages live in their own files
// (registration_problem, coarse_candidates, tournament, fine_stage; icp for the ICP runs).
#include "meshmark/registration/registration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <omp.h>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/registration/point_pairs.h"
#include "meshmark/registration/similarity_fit.h"
#include "registration/detail/coarse_alignment.h"
#include "registration/detail/coarse_candidates.h"
#include "registration/detail/fine_stage.h"
#include "registration/detail/registration_problem.h"
#include "registration/detail/tournament.h"

namespace meshmark
{
namespace
{

using Mat3 = Eigen::Matrix3d;
using detail::Candidate;
using detail::Moments;
using detail::Problem;

/// The moments both shapes are compared by, and the fine stage's target, built side by side.
/// Area-weighted when both have triangles, vertex-based as soon as one is a point cloud (or the
/// suspect's triangles have collapsed: has_collapsed_triangles). Sets the problem's initial scale
/// and the reference's half turns.
/// \throws InvalidMesh when either shape has zero extent.
std::pair<Moments, Moments> measure_shapes(Problem& p, const TriangleMesh& suspect,
                                           const TriangleMesh& reference,
                                           const std::vector<std::int32_t>& suspect_rows,
                                           const std::vector<std::int32_t>& reference_rows,
                                           bool& use_area)
{
    // The moments and the fine stage's target (a kd-tree over all the reference's vertices) are
    // independent serial computations: they run side by side, each exactly as it would alone. The
    // target is built by the calling thread (thread 0 of the team), so that its large arrays come
    // from the same allocator arena as the rest of the run (with OpenMP sections, where any thread
    // could build it, the peak RSS of a 1M-vertex detect varied between 483 and 602 MiB from run
    // to run).
    use_area = !suspect.is_point_cloud() && !reference.is_point_cloud();
    Moments ms;
    Moments mr;
    std::array<std::exception_ptr, 2> failures;
#pragma omp parallel num_threads(std::min(2, resolve_threads(p.options.threads)))
    {
        if (omp_get_thread_num() == 0)
        {
            try
            {
                p.fine_target = std::make_unique<SurfaceMatcher>(reference);
            }
            catch (...)
            {
                failures[0] = std::current_exception();
            }
        }
        if (omp_get_thread_num() == omp_get_num_threads() - 1)
        {
            try
            {
                ms = use_area ? detail::area_moments(suspect)
                              : detail::vertex_moments(suspect.V, suspect_rows);
                mr = use_area ? detail::area_moments(reference)
                              : detail::vertex_moments(reference.V, reference_rows);
            }
            catch (...)
            {
                failures[1] = std::current_exception();
            }
        }
    }
    for (const auto& failure : failures)
    {
        if (failure)
        {
            std::rethrow_exception(failure);
        }
    }
    if (use_area && detail::has_collapsed_triangles(p, suspect, suspect_rows, ms, mr))
    {
        // Its vertices still stand on the surface, but the triangles no longer cover it: the
        // area weighting measures numerical dust. Both shapes are measured by their vertices.
        use_area = false;
        ms = detail::vertex_moments(suspect.V, suspect_rows);
        mr = detail::vertex_moments(reference.V, reference_rows);
    }
    if (!(ms.covariance.trace() > 0.0) || !(mr.covariance.trace() > 0.0))
    {
        throw InvalidMesh(
            "registration: the suspect or the reference has zero extent (all its "
            "points coincide).");
    }
    p.initial_scale = std::sqrt(mr.covariance.trace() / ms.covariance.trace());
    p.reference_turns = detail::half_turns(mr);
    return {ms, mr};
}

}  // namespace

void RegistrationOptions::validate() const
{
    auto require = [](bool ok, const std::string& what)
    {
        if (!ok)
        {
            throw InvalidOption("registration option " + what + ".");
        }
    };
    require(trim_keep > 0.3 && trim_keep <= 1.0,
            "trim_keep = " + std::to_string(trim_keep) + " is outside (0.3, 1]");
    require(
        coarse_samples >= 16 && refine_samples >= 16 && fine_samples >= 16 && final_samples >= 16,
        "*_samples must be at least 16");
    require(reference_samples >= 16,
            "reference_samples = " + std::to_string(reference_samples) + " is below 16");
    require(max_iterations >= 1,
            "max_iterations = " + std::to_string(max_iterations) + " is below 1");
    require(tolerance > 0.0 && tolerance < 1.0,
            "tolerance = " + std::to_string(tolerance) + " is outside (0, 1)");
    require(min_overlap >= 0.0 && min_overlap <= 1.0,
            "min_overlap = " + std::to_string(min_overlap) + " is outside [0, 1]");
    require(max_rms_rel > 0.0, "max_rms_rel = " + std::to_string(max_rms_rel) + " is not positive");
    require(threads >= 0, "threads = " + std::to_string(threads) + " is negative");
}

RegistrationResult register_to_reference(const TriangleMesh& suspect, const TriangleMesh& reference,
                                         const RegistrationOptions& options)
{
    options.validate();
    const auto suspect_rows = detail::usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = detail::usable_vertices(reference, "reference mesh");
    Problem p =
        detail::make_problem(suspect, reference, suspect_rows, reference_rows, options, false);
    bool use_area = true;
    const auto [ms, mr] =
        measure_shapes(p, suspect, reference, suspect_rows, reference_rows, use_area);

    // Coarse alignment: the whole shape's axes, and the axes of plausible cropped parts of
    // the reference; a tournament of short trimmed ICP runs on growing samples.
    std::vector<Candidate> candidates = detail::coarse_starts(p, suspect, reference, suspect_rows,
                                                              reference_rows, ms, mr, use_area);
    const int tried = static_cast<int>(candidates.size());
    const int iterations = detail::run_tournament(p, candidates);

    // Fine alignment of the survivors: point-to-plane ICP against the whole reference surface.
    RegistrationResult result = detail::run_fine_stage(p, std::move(candidates), iterations);
    result.candidates = tried;
    if (options.keep_reference_surface)
    {
        result.reference_surface = std::move(p.fine_target);
    }
    return result;
}

RegistrationResult register_to_reference(const TriangleMesh& suspect, const TriangleMesh& reference,
                                         std::span<const PointPair> pairs,
                                         const RegistrationOptions& options)
{
    options.validate();
    const auto suspect_rows = detail::usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = detail::usable_vertices(reference, "reference mesh");
    Problem p = detail::make_problem(suspect, reference, suspect_rows, reference_rows, options);

    // Starting transforms from the pairs: the proper fit and, when allowed, the mirrored one.
    std::vector<Candidate> candidates;
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !options.allow_reflection)
        {
            continue;
        }
        std::vector<PointPair> flipped(pairs.begin(), pairs.end());
        if (mirrored)
        {
            for (PointPair& pair : flipped)
            {
                pair.suspect.x() = -pair.suspect.x();
            }
        }
        Candidate c;
        c.mirrored = mirrored;
        c.transform = similarity_parts(similarity_from_pairs(flipped, false));
        candidates.push_back(c);
    }
    p.initial_scale = candidates.front().transform.scale;
    const int iterations = detail::run_round(p, candidates, detail::kRounds.back());
    RegistrationResult result = detail::run_fine_stage(p, std::move(candidates), iterations);
    result.candidates = static_cast<int>(options.allow_reflection ? 2 : 1);
    if (options.keep_reference_surface)
    {
        result.reference_surface = std::move(p.fine_target);
    }
    return result;
}

RegistrationResult register_from(const TriangleMesh& suspect, const TriangleMesh& reference,
                                 const Eigen::Matrix4d& start, const RegistrationOptions& options)
{
    options.validate();
    const auto suspect_rows = detail::usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = detail::usable_vertices(reference, "reference mesh");
    // The start as scale * rotation (* mirror: the samples are mirrored, x -> -x, as the coarse
    // stage's mirrored candidates are).
    const Mat3 A = start.block<3, 3>(0, 0);
    Candidate c;
    c.mirrored = A.determinant() < 0.0;
    const Mat3 B = c.mirrored ? Mat3(A * detail::mirror_matrix()) : A;
    c.transform.scale = std::cbrt(B.determinant());
    if (!(c.transform.scale > 0.0) || !std::isfinite(c.transform.scale) ||
        !(B / c.transform.scale).isUnitary(1e-6))
    {
        throw InvalidOption("register_from: the start is not a similarity transform.");
    }
    c.transform.rotation = B / c.transform.scale;
    c.transform.translation = start.block<3, 1>(0, 3);
    RegistrationOptions own = options;
    own.allow_reflection = c.mirrored;  // only the start's own handedness is sampled
    Problem p = detail::make_problem(suspect, reference, suspect_rows, reference_rows, own);
    p.initial_scale = c.transform.scale;
    std::vector<Candidate> candidates{c};
    const int iterations = detail::run_round(p, candidates, detail::kRounds.back());
    RegistrationResult result = detail::run_fine_stage(p, std::move(candidates), iterations);
    result.candidates = 1;
    return result;
}

Eigen::Vector3d principal_spread(const TriangleMesh& mesh)
{
    const Moments m = mesh.is_point_cloud()
                          ? detail::vertex_moments(mesh.V, detail::usable_vertices(mesh, "mesh"))
                          : detail::area_moments(mesh);
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Mat3>(m.covariance).eigenvalues();
    if (!(e.sum() > 0.0))
    {
        throw InvalidMesh("principal_spread: the mesh has no extent.");
    }
    return e / e.sum();
}

Positions transform_points(const Eigen::Matrix4d& transform, const Positions& V)
{
    Positions result(V.rows(), 3);
    const Mat3 A = transform.block<3, 3>(0, 0);
    const Eigen::Vector3d t = transform.block<3, 1>(0, 3);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        result.row(i) = (A * V.row(i).transpose() + t).transpose();
    }
    return result;
}

}  // namespace meshmark

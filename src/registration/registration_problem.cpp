// SPDX-License-Identifier: MIT
#include "registration/detail/registration_problem.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/rng.h"
#include "registration/detail/coarse_alignment.h"

namespace meshmark::detail
{
namespace
{

// The coarse rounds' ICP stops on updates smaller than this (relative, icp.cpp): a coarse
// round only has to sort the starts, not to settle them.
constexpr double kCoarseTolerance = 1e-6;
// An overlap fraction at least this high counts as full in the score (score_of): below it, the
// samples left far from the reference mark a pose that fits only part of the suspect.
constexpr double kFullOverlap = 0.95;

/// Rows of \p V listed in \p rows, in that order.
Positions gather(const Positions& V, const std::vector<std::int32_t>& rows, std::size_t count)
{
    Positions X(static_cast<Eigen::Index>(count), 3);
    for (std::size_t i = 0; i < count; ++i)
    {
        X.row(static_cast<Eigen::Index>(i)) = V.row(rows[i]);
    }
    return X;
}

/// \p X's rows in Z (Morton) order of their positions (21 bits per axis), ties by row: the same
/// sample set, laid out so that consecutive closest-point queries land near each other in the
/// target's kd-tree and vertex arrays. On a 1M-vertex reference the fine stage's random samples
/// were memory-latency bound (about 3 CPU-us per query in shuffled order).
Positions spatially_sorted(const Positions& X)
{
    constexpr int kMortonBits = 21;  // per axis: the most that three axes fit in a 64-bit key
    const std::vector<std::size_t> order = morton_order(X, kMortonBits);
    Positions Y(X.rows(), 3);
    for (std::size_t i = 0; i < order.size(); ++i)
    {
        Y.row(static_cast<Eigen::Index>(i)) = X.row(static_cast<Eigen::Index>(order[i]));
    }
    return Y;
}

SampleSets sample_sets(const Positions& V, const std::vector<std::int32_t>& order,
                       const RegistrationOptions& options, bool mirrored)
{
    auto take = [&](int count, bool sorted = false)
    {
        Positions X = gather(V, order, std::min(order.size(), static_cast<std::size_t>(count)));
        if (sorted)
        {
            X = spatially_sorted(X);
        }
        if (mirrored)
        {
            X.col(0) = -X.col(0);
        }
        return X;
    };
    return {take(options.coarse_samples), take(2 * options.coarse_samples),
            take(options.refine_samples), take(options.fine_samples, true),
            take(options.final_samples, true)};
}

// Whether two candidates start from exactly the same place: the same handedness and the same
// transform, bit for bit. Point-to-point ICP settles on a transform computed from its pairs
// alone, so different starts that reach the same pairs reach the same transform exactly, and
// from then on run the same steps: on the held-out re-work copies, 245 of the 1,112 fine-stage
// runs of 408 registrations started where another had (docs/algorithms/registration.md).
bool same_start(const Candidate& a, const Candidate& b)
{
    return a.mirrored == b.mirrored && a.transform.scale == b.transform.scale &&
           a.transform.rotation == b.transform.rotation &&
           a.transform.translation == b.transform.translation;
}

}  // namespace

Eigen::Matrix3d mirror_matrix()
{
    return Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
}

Eigen::Matrix4d as_matrix(const Similarity& T, bool mirrored)
{
    Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
    A.block<3, 3>(0, 0) =
        T.scale * T.rotation * (mirrored ? mirror_matrix() : Eigen::Matrix3d::Identity());
    A.block<3, 1>(0, 3) = T.translation;
    return A;
}

double residual_of(const IcpOutcome& outcome)
{
    return outcome.trimmed_rms / outcome.transform.scale;
}

// The residual (at least \p floor), over the square of the overlap's shortfall from
// kFullOverlap. The trimmed RMS alone cannot tell an alignment that fits every sample from one
// that fits just the kept fraction: half of a vehicle turned end for end lays its tyres and
// body exactly on the other half's and scores as well as the right pose; the part left
// hanging lowers the overlap.
double score_of(const IcpOutcome& outcome, double floor)
{
    const double shortfall = std::clamp(outcome.overlap_fraction / kFullOverlap, 1e-3, 1.0);
    return std::max(residual_of(outcome), floor) / (shortfall * shortfall);
}

double pose_distance(const Positions& X, const Similarity& a, const Similarity& b)
{
    const Eigen::Matrix3d linear = a.scale * a.rotation - b.scale * b.rotation;
    const Eigen::Vector3d shift = a.translation - b.translation;
    double sum = 0.0;
    for (Eigen::Index i = 0; i < X.rows(); ++i)
    {
        sum += (linear * X.row(i).transpose() + shift).squaredNorm();
    }
    return std::sqrt(sum / static_cast<double>(std::max<Eigen::Index>(X.rows(), 1)));
}

void keep_best(std::vector<Candidate>& candidates, std::size_t count)
{
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    candidates.resize(std::min(count, candidates.size()));
}

std::vector<std::size_t> first_same_start(const std::vector<Candidate>& candidates)
{
    std::vector<std::size_t> leader(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i)
    {
        leader[i] = i;
        for (std::size_t j = 0; j < i; ++j)
        {
            if (leader[j] == j && same_start(candidates[j], candidates[i]))
            {
                leader[i] = j;
                break;
            }
        }
    }
    return leader;
}

void copy_run(const Candidate& from, Candidate& to)
{
    to.outcome = from.outcome;
    to.transform = from.transform;
    to.score = from.score;
    to.residual = from.residual;
}

IcpSettings coarse_settings(const Problem& p, int iterations, double scale_hint, int threads)
{
    IcpSettings s;
    s.trim_keep = p.options.trim_keep;
    s.max_iterations = iterations;
    s.tolerance = kCoarseTolerance;
    s.min_scale = kMinScaleFactor * scale_hint;
    s.max_scale = kMaxScaleFactor * scale_hint;
    s.distance_floor = kExactFit * p.reference_diagonal;
    s.threads = threads;
    return s;
}

IcpSettings fine_settings(const Problem& p, int iterations)
{
    IcpSettings s;
    s.trim_keep = p.options.trim_keep;
    s.max_iterations = iterations;
    s.tolerance = p.options.tolerance;
    s.distance_floor = kExactFit * p.reference_diagonal;
    s.threads = p.options.threads;
    return s;
}

std::vector<std::int32_t> usable_vertices(const TriangleMesh& mesh, const char* what)
{
    validate(mesh, what);
    std::vector<std::int32_t> rows = referenced_vertices(mesh);
    if (rows.size() < 4)
    {
        throw InvalidMesh(std::string(what) +
                          ": registration needs at least 4 vertices used by the "
                          "surface, found " +
                          std::to_string(rows.size()) + ".");
    }
    return rows;
}

Problem make_problem(const TriangleMesh& suspect, const TriangleMesh& reference,
                     const std::vector<std::int32_t>& suspect_rows,
                     const std::vector<std::int32_t>& reference_rows,
                     const RegistrationOptions& options, bool build_fine_target)
{
    Problem p{options, {}, nullptr, nullptr, 1.0, 1.0, 0.0, {}};
    const std::vector<std::int32_t> order =
        shuffled(suspect_rows, derive_seed(options.seed, "suspect samples"));
    p.samples[0] = sample_sets(suspect.V, order, options, false);
    if (options.allow_reflection)
    {
        p.samples[1] = sample_sets(suspect.V, order, options, true);
    }
    const std::vector<std::int32_t> reference_order =
        shuffled(reference_rows, derive_seed(options.seed, "reference samples"));
    p.coarse_target = std::make_unique<SurfaceMatcher>(gather(
        reference.V, reference_order,
        std::min(reference_order.size(), static_cast<std::size_t>(options.reference_samples))));
    if (build_fine_target)
    {
        p.fine_target = std::make_unique<SurfaceMatcher>(reference);
    }
    p.reference_diagonal = std::max(bounding_box(reference.V, reference_rows).diagonal(), 1e-300);
    p.score_floor = kExactFit * bounding_box(suspect.V, suspect_rows).diagonal();
    return p;
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#include "meshmark/registration/registration.h"

#include <algorithm>
#include <cstdlib>
#include <cstdio>
#include <sstream>
#include <array>
#include <cmath>
#include <memory>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "registration/detail/icp.h"
#include "registration/detail/surface_matcher.h"

namespace meshmark {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using detail::IcpOutcome;
using detail::IcpSettings;
using detail::Similarity;
using detail::SurfaceMatcher;

static int envi(const char* n, int d){ const char* v = std::getenv(n); return v ? std::atoi(v) : d; }
static double envd(const char* n, double d){ const char* v = std::getenv(n); return v ? std::atof(v) : d; }

/// One round of the coarse tournament: every candidate runs `iterations` of trimmed
/// point-to-point ICP on the sample tier `tier`, then the best `survivors` go on.
struct Round
{
    std::size_t tier;
    int iterations;
    std::size_t survivors;
};

// Coarse-stage budget (measured in docs/algorithms/registration.md).
static const std::array<Round, 3> kRounds = {Round{0, envi("R1IT", 10), static_cast<std::size_t>(envi("R1S", 48))},
                                             Round{1, envi("R2IT", 20), static_cast<std::size_t>(envi("R2S", 8))},
                                             Round{2, envi("R3IT", 30), static_cast<std::size_t>(envi("R3S", 2))}};
static const int kSpiralRotations = envi("NSPIRAL", 120);
constexpr double kCoarseTolerance = 1e-6;
constexpr int kFinalIterations = 6;
static const std::vector<double> kScaleHypotheses = envi("NSCALE", 1) == 1 ? std::vector<double>{1.0} : std::vector<double>{1.0, envd("SCALE2", 0.75)};
// The coarse ICP may not leave [0.25, 2] times the initial scale (collapse guard).
constexpr double kMinScaleFactor = 0.25;
constexpr double kMaxScaleFactor = 2.0;

/// The reflection used for mirrored candidates: x -> -x.
Mat3 mirror_matrix()
{
    return Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
}

/// Centroid and covariance of a shape.
struct Moments
{
    Vec3 centroid = Vec3::Zero();
    Mat3 covariance = Mat3::Zero();
};

// Moments of the uniform distribution on the triangles (area-weighted), so that remeshing
// and simplification, which change where vertices sit but not the surface, barely move them.
// Accumulated relative to the first vertex, serially in face order.
Moments area_moments(const TriangleMesh& mesh)
{
    const Vec3 o = mesh.V.row(mesh.F(0, 0)).transpose();
    double area = 0.0;
    Vec3 first = Vec3::Zero();
    Mat3 second = Mat3::Zero();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Vec3 a = mesh.V.row(mesh.F(f, 0)).transpose() - o;
        const Vec3 b = mesh.V.row(mesh.F(f, 1)).transpose() - o;
        const Vec3 c = mesh.V.row(mesh.F(f, 2)).transpose() - o;
        const double w = 0.5 * (b - a).cross(c - a).norm();
        const Vec3 s = a + b + c;
        area += w;
        first += (w / 3.0) * s;
        // E[x x^T] over a triangle = (a a^T + b b^T + c c^T + s s^T) / 12.
        second += (w / 12.0) * (a * a.transpose() + b * b.transpose() + c * c.transpose() +
                                s * s.transpose());
    }
    Moments m;
    if (!(area > 0.0))
    {
        return m;
    }
    const Vec3 mean = first / area;
    m.centroid = o + mean;
    m.covariance = second / area - mean * mean.transpose();
    return m;
}

Moments vertex_moments(const Positions& V, const std::vector<std::int32_t>& rows)
{
    const Vec3 o = V.row(rows.front()).transpose();
    Vec3 first = Vec3::Zero();
    Mat3 second = Mat3::Zero();
    for (const std::int32_t r : rows)
    {
        const Vec3 x = V.row(r).transpose() - o;
        first += x;
        second += x * x.transpose();
    }
    const auto n = static_cast<double>(rows.size());
    Moments m;
    const Vec3 mean = first / n;
    m.centroid = o + mean;
    m.covariance = second / n - mean * mean.transpose();
    return m;
}

/// Principal axes as the columns of a proper rotation, largest variance first.
Mat3 principal_frame(const Mat3& covariance)
{
    const Eigen::SelfAdjointEigenSolver<Mat3> solver(covariance);
    Mat3 E;
    E << solver.eigenvectors().col(2), solver.eigenvectors().col(1), solver.eigenvectors().col(0);
    if (E.determinant() < 0.0)
    {
        E.col(2) = -E.col(2);
    }
    return E;
}

/// The 24 rotations that map coordinate axes to signed coordinate axes.
std::vector<Mat3> axis_rotations()
{
    std::vector<Mat3> result;
    std::array<int, 3> perm = {0, 1, 2};
    do
    {
        for (unsigned signs = 0; signs < 8; ++signs)
        {
            Mat3 P = Mat3::Zero();
            for (int i = 0; i < 3; ++i)
            {
                P(i, perm[static_cast<std::size_t>(i)]) = ((signs >> static_cast<unsigned>(i)) & 1U) != 0U ? -1.0 : 1.0;
            }
            if (P.determinant() > 0.0)
            {
                result.push_back(P);
            }
        }
    } while (std::next_permutation(perm.begin(), perm.end()));
    return result;
}

// Rotations spread evenly over SO(3): a super-Fibonacci spiral of unit quaternions
// [Alexa 2022, "Super-Fibonacci Spirals: Fast, Low-Discrepancy Sampling of SO(3)"].
std::vector<Mat3> spiral_rotations(int count)
{
    const double phi = std::sqrt(2.0);
    const double psi = 1.533751168755204288118041;
    std::vector<Mat3> result;
    for (int i = 0; i < count; ++i)
    {
        const double s = i + 0.5;
        const double r = std::sqrt(s / count);
        const double R = std::sqrt(1.0 - s / count);
        const double alpha = 2.0 * M_PI * s / phi;
        const double beta = 2.0 * M_PI * s / psi;
        const Eigen::Quaterniond q(R * std::cos(beta), r * std::sin(alpha), r * std::cos(alpha), R * std::sin(beta));
        result.push_back(q.normalized().toRotationMatrix());
    }
    return result;
}

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

// A seeded random order of the usable vertices. Nested prefixes of it are the subsamples of
// every stage, so each stage sees the previous stage's points plus new ones. Deterministic
// because it depends only on the seed and the vertex count.
std::vector<std::int32_t> shuffled(std::vector<std::int32_t> rows, std::uint64_t seed)
{
    Rng rng(seed);
    for (std::size_t i = rows.size(); i > 1; --i)
    {
        const auto j = static_cast<std::size_t>(rng.below(i));
        std::swap(rows[i - 1], rows[j]);
    }
    return rows;
}

/// The suspect's point samples of every stage, by tier: the coarse rounds' three sizes,
/// then the fine and the final stage.
using SampleSets = std::array<Positions, 5>;
constexpr std::size_t kFineTier = 3;
constexpr std::size_t kFinalTier = 4;

SampleSets sample_sets(const Positions& V, const std::vector<std::int32_t>& order,
                       const RegistrationOptions& options, bool mirrored)
{
    auto take = [&](int count) {
        Positions X = gather(V, order, std::min(order.size(), static_cast<std::size_t>(count)));
        if (mirrored)
        {
            X.col(0) = -X.col(0);
        }
        return X;
    };
    return {take(options.coarse_samples), take(2 * options.coarse_samples),
            take(options.refine_samples), take(options.fine_samples), take(options.final_samples)};
}

/// One coarse hypothesis and how well it did so far.
struct Candidate
{
    Similarity transform;
    bool mirrored = false;
    double score = 0.0;  // trimmed RMS divided by the scale: the residual in suspect units
    IcpOutcome outcome;
};

double score_of(const IcpOutcome& outcome)
{
    return outcome.trimmed_rms / outcome.transform.scale;
}

/// Everything the stages share.
struct Problem
{
    const RegistrationOptions& options;
    std::array<SampleSets, 2> samples;  // [mirrored]
    std::unique_ptr<SurfaceMatcher> coarse_target;
    std::unique_ptr<SurfaceMatcher> fine_target;
    double reference_diagonal = 1.0;
    double initial_scale = 1.0;
};

IcpSettings coarse_settings(const Problem& p, int iterations, double scale_hint, int threads)
{
    IcpSettings s;
    s.trim_keep = p.options.trim_keep;
    s.max_iterations = iterations;
    s.tolerance = kCoarseTolerance;
    s.min_scale = kMinScaleFactor * scale_hint;
    s.max_scale = kMaxScaleFactor * scale_hint;
    s.distance_floor = 1e-9 * p.reference_diagonal;
    s.threads = threads;
    return s;
}

// Keep the best \p count candidates; ties broken by the original order (deterministic).
void keep_best(std::vector<Candidate>& candidates, std::size_t count)
{
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    candidates.resize(std::min(count, candidates.size()));
}

/// Coarse hypotheses from the principal axes: 24 axis rotations x scale hypotheses, for the
/// suspect and (when allowed) its mirror image.
std::vector<Candidate> axis_candidates(const Problem& p, const Moments& suspect, const Moments& reference)
{
    const Mat3 E_r = principal_frame(reference.covariance);
    const double s0 = std::sqrt(reference.covariance.trace() / suspect.covariance.trace());
    std::vector<Candidate> result;
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !p.options.allow_reflection)
        {
            continue;
        }
        const Mat3 M = mirrored ? mirror_matrix() : Mat3::Identity();
        const Vec3 c_y = M * suspect.centroid;
        const Mat3 E_y = principal_frame(M * suspect.covariance * M);
        std::vector<Mat3> rotations = axis_rotations();
        const auto extra = spiral_rotations(kSpiralRotations);
        rotations.insert(rotations.end(), extra.begin(), extra.end());
        for (const Mat3& P : rotations)
        {
            for (const double factor : kScaleHypotheses)
            {
                Candidate c;
                c.mirrored = mirrored;
                c.transform.rotation = E_r * P * E_y.transpose();
                c.transform.scale = s0 * factor;
                c.transform.translation = reference.centroid - c.transform.scale * c.transform.rotation * c_y;
                result.push_back(c);
            }
        }
    }
    return result;
}

// Each round runs its candidates in parallel (each run is single-threaded and writes only its
// own slot, so the schedule cannot change the result), then keeps the best.
int run_round(const Problem& p, std::vector<Candidate>& candidates, const Round& round)
{
    const auto count = static_cast<std::int64_t>(candidates.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(detail::resolve_threads(p.options.threads))
    for (std::int64_t i = 0; i < count; ++i)
    {
        Candidate& c = candidates[static_cast<std::size_t>(i)];
        const Positions& X = p.samples[c.mirrored ? 1 : 0][round.tier];
        const IcpSettings settings = coarse_settings(p, round.iterations, p.initial_scale, 1);
        const SurfaceMatcher& target = (round.tier == 2 && envi("R3FINE", 0)) ? *p.fine_target : *p.coarse_target;
        c.outcome = detail::icp_point_to_point(X, target, c.transform, settings);
        c.transform = c.outcome.transform;
        c.score = score_of(c.outcome);
    }
    keep_best(candidates, round.survivors);
    return round.iterations;
}

IcpSettings fine_settings(const Problem& p, int iterations)
{
    IcpSettings s;
    s.trim_keep = p.options.trim_keep;
    s.max_iterations = iterations;
    s.tolerance = p.options.tolerance;
    s.distance_floor = 1e-9 * p.reference_diagonal;
    s.threads = p.options.threads;
    return s;
}

IcpOutcome refine(const Problem& p, const Positions& X, const Similarity& start, int iterations)
{
    const IcpSettings settings = fine_settings(p, iterations);
    if (p.fine_target->has_normals())
    {
        return detail::icp_point_to_plane(X, *p.fine_target, start, settings);
    }
    return detail::icp_point_to_point(X, *p.fine_target, start, settings);
}

// Fine stage: each surviving candidate to convergence on the fine samples against the exact
// reference surface; the best one then gets its last iterations on many points.
RegistrationResult finish(const Problem& p, std::vector<Candidate> candidates, int coarse_iterations)
{
    int iterations = coarse_iterations;
    for (Candidate& c : candidates)
    {
        c.outcome = refine(p, p.samples[c.mirrored ? 1 : 0][kFineTier], c.transform, p.options.max_iterations);
        c.transform = c.outcome.transform;
        c.score = score_of(c.outcome);
        iterations += c.outcome.iterations;
    }
    keep_best(candidates, 1);
    Candidate& best = candidates.front();
    const Positions& last = p.samples[best.mirrored ? 1 : 0][kFinalTier];
    const IcpOutcome final_run = refine(p, last, best.transform, kFinalIterations);
    iterations += final_run.iterations;
    const IcpOutcome final_state = detail::evaluate(last, *p.fine_target, final_run.transform, fine_settings(p, 0));

    RegistrationResult result;
    const Similarity& T = final_state.transform;
    const Mat3 M = best.mirrored ? mirror_matrix() : Mat3::Identity();
    result.transform.block<3, 3>(0, 0) = T.scale * T.rotation * M;
    result.transform.block<3, 1>(0, 3) = T.translation;
    result.scale = T.scale;
    result.is_reflection = best.mirrored;
    result.rms_error = final_state.trimmed_rms / p.reference_diagonal;
    result.iterations = iterations;
    result.overlap_fraction = final_state.overlap_fraction;
    // Converged: the fine stage met its tolerance on either sample set, and the alignment is
    // plausible (most of the suspect lies on the reference, small residual).
    result.converged = (best.outcome.reached_tolerance || final_run.reached_tolerance) &&
                       result.overlap_fraction >= p.options.min_overlap &&
                       result.rms_error <= p.options.max_rms_rel;
    return result;
}

std::vector<std::int32_t> usable_vertices(const TriangleMesh& mesh, const char* what)
{
    validate(mesh, what);
    std::vector<std::int32_t> rows = referenced_vertices(mesh);
    if (rows.size() < 4)
    {
        throw InvalidMesh(std::string(what) + ": registration needs at least 4 vertices used by the "
                          "surface, found " + std::to_string(rows.size()) + ".");
    }
    return rows;
}

Problem make_problem(const TriangleMesh& suspect, const TriangleMesh& reference,
                     const std::vector<std::int32_t>& suspect_rows,
                     const std::vector<std::int32_t>& reference_rows, const RegistrationOptions& options)
{
    Problem p{options, {}, nullptr, nullptr, 1.0, 1.0};
    const std::vector<std::int32_t> order = shuffled(suspect_rows, derive_seed(options.seed, "suspect samples"));
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
    p.fine_target = std::make_unique<SurfaceMatcher>(reference);
    p.reference_diagonal = std::max(bounding_box(reference.V, reference_rows).diagonal(), 1e-300);
    return p;
}

}  // namespace

void RegistrationOptions::validate() const
{
    auto require = [](bool ok, const std::string& what) {
        if (!ok)
        {
            throw InvalidOption("registration option " + what + ".");
        }
    };
    require(trim_keep > 0.3 && trim_keep <= 1.0,
            "trim_keep = " + std::to_string(trim_keep) + " is outside (0.3, 1]");
    require(coarse_samples >= 16 && refine_samples >= 16 && fine_samples >= 16 && final_samples >= 16,
            "*_samples must be at least 16");
    require(reference_samples >= 16, "reference_samples = " + std::to_string(reference_samples) +
                                         " is below 16");
    require(max_iterations >= 1, "max_iterations = " + std::to_string(max_iterations) + " is below 1");
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
    const auto suspect_rows = usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = usable_vertices(reference, "reference mesh");
    Problem p = make_problem(suspect, reference, suspect_rows, reference_rows, options);

    // Principal axes of both shapes, measured the same way: area-weighted when both have
    // triangles, vertex-based as soon as one is a point cloud.
    const bool use_area = !suspect.is_point_cloud() && !reference.is_point_cloud();
    const Moments ms = use_area ? area_moments(suspect) : vertex_moments(suspect.V, suspect_rows);
    const Moments mr = use_area ? area_moments(reference) : vertex_moments(reference.V, reference_rows);
    if (!(ms.covariance.trace() > 0.0) || !(mr.covariance.trace() > 0.0))
    {
        throw InvalidMesh("registration: the suspect or the reference has zero extent (all its "
                          "points coincide).");
    }
    p.initial_scale = std::sqrt(mr.covariance.trace() / ms.covariance.trace());

    // Coarse alignment: every axis candidate on few points, the best on more points.
    std::vector<Candidate> candidates = axis_candidates(p, ms, mr);
    const int tried = static_cast<int>(candidates.size());
    int iterations = 0;
    for (const Round& round : kRounds)
    {
        iterations += run_round(p, candidates, round);
    }

    // Fine alignment of the survivors: point-to-plane ICP against the exact surface.
    RegistrationResult result = finish(p, std::move(candidates), iterations);
    result.candidates = tried;
    return result;
}

RegistrationResult register_to_reference(const TriangleMesh& suspect, const TriangleMesh& reference,
                                         std::span<const PointPair> pairs,
                                         const RegistrationOptions& options)
{
    options.validate();
    const auto suspect_rows = usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = usable_vertices(reference, "reference mesh");
    Problem p = make_problem(suspect, reference, suspect_rows, reference_rows, options);

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
        const Eigen::Matrix4d A = similarity_from_pairs(flipped, false);
        Candidate c;
        c.mirrored = mirrored;
        c.transform.scale = A.block<3, 1>(0, 0).norm();
        c.transform.rotation = A.block<3, 3>(0, 0) / c.transform.scale;
        c.transform.translation = A.block<3, 1>(0, 3);
        candidates.push_back(c);
    }
    p.initial_scale = candidates.front().transform.scale;
    const int iterations = run_round(p, candidates, kRounds.back());
    RegistrationResult result = finish(p, std::move(candidates), iterations);
    result.candidates = static_cast<int>(options.allow_reflection ? 2 : 1);
    return result;
}

Eigen::Matrix4d similarity_from_pairs(std::span<const PointPair> pairs, bool allow_reflection)
{
    if (pairs.size() < 3)
    {
        throw InvalidOption("point pairs: a similarity needs at least 3 pairs, got " +
                            std::to_string(pairs.size()) + ".");
    }
    const auto n = static_cast<Eigen::Index>(pairs.size());
    Eigen::Matrix3Xd src(3, n);
    Eigen::Matrix3Xd dst(3, n);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        src.col(i) = pairs[static_cast<std::size_t>(i)].suspect;
        dst.col(i) = pairs[static_cast<std::size_t>(i)].reference;
    }
    // Collinear or coincident suspect points leave a rotation free: refuse them.
    const Eigen::Matrix3Xd centered = src.colwise() - src.rowwise().mean();
    const Eigen::JacobiSVD<Eigen::Matrix3Xd> svd(centered);
    const auto sv = svd.singularValues();
    if (!(sv(1) > 1e-9 * sv(0)))
    {
        throw InvalidOption("point pairs: the suspect points are collinear or coincident, so they "
                            "do not determine a rotation.");
    }
    auto residual = [&](const Eigen::Matrix4d& A, const Eigen::Matrix3Xd& from) {
        return ((A.block<3, 3>(0, 0) * from).colwise() + A.block<3, 1>(0, 3) - dst).squaredNorm();
    };
    const Eigen::Matrix4d proper = Eigen::umeyama(src, dst, true);
    if (!allow_reflection)
    {
        return proper;
    }
    const Mat3 M = mirror_matrix();
    const Eigen::Matrix3Xd mirrored_src = M * src;
    Eigen::Matrix4d mirrored = Eigen::umeyama(mirrored_src, dst, true);
    const double proper_residual = residual(proper, src);
    const double mirrored_residual = residual(mirrored, mirrored_src);
    // The mirrored fit must be clearly better: with 3 pairs both are exact.
    if (mirrored_residual < 0.5 * proper_residual)
    {
        mirrored.block<3, 3>(0, 0) = mirrored.block<3, 3>(0, 0) * M;
        return mirrored;
    }
    return proper;
}

Positions transform_points(const Eigen::Matrix4d& transform, const Positions& V)
{
    Positions result(V.rows(), 3);
    const Mat3 A = transform.block<3, 3>(0, 0);
    const Vec3 t = transform.block<3, 1>(0, 3);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        result.row(i) = (A * V.row(i).transpose() + t).transpose();
    }
    return result;
}

}  // namespace meshmark

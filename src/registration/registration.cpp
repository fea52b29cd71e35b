// SPDX-License-Identifier: MIT
#include "meshmark/registration/registration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <omp.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/rng.h"
#include "meshmark/registration/similarity_fit.h"
#include "registration/detail/coarse_alignment.h"
#include "registration/detail/icp.h"
#include "registration/detail/surface_matcher.h"

namespace meshmark {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using detail::axis_rotations;
using detail::crop_hypotheses;
using detail::frame_rotations;
using detail::IcpOutcome;
using detail::IcpSettings;
using detail::Moments;
using detail::principal_frame;
using detail::shuffled;
using detail::Similarity;

/// One round of the coarse tournament: every candidate runs `iterations` of trimmed
/// point-to-point ICP on the sample tier `tier`, then the best `survivors` go on.
struct Round
{
    std::size_t tier;
    int iterations;
    std::size_t survivors;
};

// Coarse-stage budget, measured in docs/algorithms/registration.md: 64 samples and 8
// iterations sort out the hundreds of starts; the right one was always among the best 48.
constexpr std::array<Round, 3> kRounds = {Round{0, 8, 48}, Round{1, 20, 8}, Round{2, 30, 8}};
constexpr double kCoarseTolerance = 1e-6;
// Candidates that go on to the fine stage: the best two, plus the best proper one.
constexpr std::size_t kFineCandidates = 2;
// Two candidates whose poses lie within this fraction of the reference's diagonal of each other
// (RMS over the first sample tier) are one pose to a round's choice of survivors
// (distinct_poses_first). The repeats of the turned vehicle's pose (below) lay within 0.05% of
// each other; 2% merged, after the first round's 8 iterations, starts that would still have
// settled apart, and a half vehicle then lost its right pose to its mirror image
// (RegistrationTest.registers_a_half_cut_through_the_bounding_box_centre_along_an_axis).
constexpr double kSamePose = 0.005;
// A mirrored result must beat the best proper one by this factor: a mirror-symmetric shape
// (a cow, a teapot) fits itself both ways, and a copy is far more often unmirrored.
constexpr double kReflectionMargin = 0.95;
// A nearly mirror-symmetric reference (a vehicle or a walker with a part on one side) fits a
// copy about as well both ways, and the margin above then picks a handedness by a hair: the
// best fit of the other handedness is returned too (RegistrationResult::other_handedness) when
// its fine score is within this factor of the chosen one's. It reaches the fine stage when its
// coarse score is within kHandednessCoarse of the best coarse score. The ratios measured on
// the held-out assets' re-work copies (docs/algorithms/registration.md, step 6): fine, medians
// 1.00-1.16 on nearly symmetric characters and vehicles, the walker's mirrored copies 1.02 and
// 1.05, an asymmetric engine 3.2-4.1; coarse, 309 of the 313 ties within 1.2 (four up to 2.0),
// the engine's 1.43, whose fine refinement cost 12% of its detection for nothing.
constexpr double kHandednessTie = 1.5;
constexpr double kHandednessCoarse = 1.25;
// A reference that is nearly the same turned half a turn about one of its principal axes (a
// vehicle end for end) fits a resampled copy about as well both ways on the coarse rounds'
// 4,096 reference vertices, and the right pose can drop out before the fine stage: the best
// coarse pose turned so goes to the fine stage too when, after kTurnedIterations coarse
// iterations on the last round's samples, its coarse score is within this factor of the best's
// (the vehicle's voxel remesh at 1/300 marked with --strength 0.001 --seed 2: 1.04; turned poses of
// asymmetric shapes score several times worse and cost only those iterations).
constexpr double kTurnedCoarse = 1.25;
constexpr int kTurnedIterations = 10;
constexpr int kFinalIterations = 6;
// The coarse ICP may not leave [0.25, 2] times the initial scale (collapse guard).
constexpr double kMinScaleFactor = 0.25;
constexpr double kMaxScaleFactor = 2.0;
// A suspect whose centroid lies within this fraction of the reference's RMS radius of the
// reference's, with an RMS radius within this factor of the reference's, may stand where the
// original stands: its start in place is kept through every round and refined in the fine
// stage. Loose on purpose: a voxel remesh of a thin-walled part (head.ply, 1/150 of the
// diagonal) moves the area moments' centroid by 4-11% of the radius and the radius by 8%.
constexpr double kInPlaceOffset = 0.25;
constexpr double kInPlaceScale = 1.25;
// A suspect whose triangles cover less than this share of the area the reference's cover, at the
// same size, is measured by its vertices (has_collapsed_triangles): no decimation, remesh or crop
// comes near (they keep the area per squared extent within a few times: a screw's Blender
// decimation to 5% 0.99, its bisection 1.56), while a soup whose triangles were shrunk to
// slivers keeps almost none (the screw's STL smoothed by Open3D without welding: 1.6e-15 to
// 2.6e-6; Blender's Smooth modifier on a model imported with every triangle apart: 0.0017).
constexpr double kCollapsedArea = 0.01;
// A suspect whose bounding box has the reference's extents within this factor, in some order of
// the axes, is also started on the reference's coordinate axes at scale 1 (add_axis_candidates).
constexpr double kAxisExtentRatio = 1.1;
// An overlap fraction at least this high counts as full in the score (score_of): below it, the
// samples left far from the reference mark a pose that fits only part of the suspect.
constexpr double kFullOverlap = 0.95;
// Articulated copies (finish): the share of pairs kept when refining onto the largest part,
// its iterations, and how many more samples it must lay on the reference to be taken (a
// creature bent by 20 degrees at a joint: 9% of the samples within 3 trimmed RMS at the 90%
// pose, 53% at this one; the copies that fit as a whole: the same or fewer).
constexpr double kPartKeep = 0.5;
constexpr int kPartIterations = 20;
constexpr double kPartGain = 1.2;
constexpr double kPartMargin = 0.05;

/// The reflection used for mirrored candidates: x -> -x.
Mat3 mirror_matrix()
{
    return Eigen::Vector3d(-1.0, 1.0, 1.0).asDiagonal();
}

/// \p T as a 4x4 map of the suspect's frame, the samples' mirror (x -> -x) applied first when
/// \p mirrored.
Eigen::Matrix4d as_matrix(const Similarity& T, bool mirrored)
{
    Eigen::Matrix4d A = Eigen::Matrix4d::Identity();
    A.block<3, 3>(0, 0) = T.scale * T.rotation * (mirrored ? mirror_matrix() : Mat3::Identity());
    A.block<3, 1>(0, 3) = T.translation;
    return A;
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

/// The suspect's point samples of every stage, by tier: the coarse rounds' three sizes,
/// then the fine and the final stage.
using SampleSets = std::array<Positions, 5>;
constexpr std::size_t kFineTier = 3;
constexpr std::size_t kFinalTier = 4;

/// \p X's rows in Z (Morton) order of their positions (21 bits per axis), ties by row: the same
/// sample set, laid out so that consecutive closest-point queries land near each other in the
/// target's kd-tree and vertex arrays. On a 1M-vertex reference the fine stage's random samples
/// were memory-latency bound (about 3 CPU-us per query in shuffled order).
Positions spatially_sorted(const Positions& X)
{
    const std::vector<std::size_t> order = morton_order(X, 21);
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
    auto take = [&](int count, bool sorted = false) {
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
            take(options.refine_samples), take(options.fine_samples, true), take(options.final_samples, true)};
}

/// One coarse hypothesis and how well it did so far.
struct Candidate
{
    Similarity transform;
    bool mirrored = false;
    double score = 0.0;     // score_of: the residual, raised where the overlap falls short
    double residual = 0.0;  // trimmed RMS divided by the scale: the residual in suspect units
    IcpOutcome outcome;
    bool kept_in_place = false;  // the identity of a suspect that stands in place: never dropped
};

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

/// Everything the stages share.
struct Problem
{
    const RegistrationOptions& options;
    std::array<SampleSets, 2> samples;  // [mirrored]
    std::unique_ptr<SurfaceMatcher> coarse_target;
    std::unique_ptr<SurfaceMatcher> fine_target;
    double reference_diagonal = 1.0;
    double initial_scale = 1.0;
    double score_floor = 0.0;  // scores below this (suspect units) count as exact fits
    // Half turns about the reference's principal axes through its centroid (kTurnedCoarse);
    // empty where the starts are given (point pairs, a start to refine).
    std::vector<Similarity> reference_turns;
};

// The three half turns about the principal axes of \p m through its centroid.
std::vector<Similarity> half_turns(const Moments& m)
{
    const Eigen::Matrix3d frame = principal_frame(m.covariance);
    std::vector<Similarity> turns;
    for (int k = 0; k < 3; ++k)
    {
        const Eigen::Vector3d axis = frame.col(k).normalized();
        Similarity S;
        S.rotation = 2.0 * axis * axis.transpose() - Eigen::Matrix3d::Identity();
        S.translation = m.centroid - S.rotation * m.centroid;
        turns.push_back(S);
    }
    return turns;
}

// \p T followed by \p S (S a rigid motion of the reference's space).
Similarity then(const Similarity& T, const Similarity& S)
{
    Similarity R;
    R.scale = T.scale;
    R.rotation = S.rotation * T.rotation;
    R.translation = S.rotation * T.translation + S.translation;
    return R;
}

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

// RMS distance between where two similarities put the points \p X.
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

// Candidates sorted by score, rearranged so that the first \p count are distinct poses where
// there are that many: a candidate whose pose lies within kSamePose of the reference's diagonal
// of a better one of its handedness (on the first sample tier) is a repeat and goes behind, the
// rest keeping their order by score. Starts of one basin converge to the same pose in a round,
// and the survivors' places could all go to it: a Blender voxel remesh of the game-like vehicle,
// which is nearly the same turned end for end, kept seven copies of the turned pose among the
// eight survivors of the last round and not the right pose, whose fine score would have been a
// third of it (docs/algorithms/registration.md, step 4). Stops comparing once it has \p count.
void distinct_poses_first(const Problem& p, std::vector<Candidate>& candidates, std::size_t count)
{
    const double tolerance = kSamePose * p.reference_diagonal;
    std::vector<Candidate> distinct;
    std::vector<Candidate> rest;
    for (Candidate& c : candidates)
    {
        const Positions& X = p.samples[c.mirrored ? 1 : 0][0];
        const bool is_repeat = distinct.size() >= count ||
                               std::any_of(distinct.begin(), distinct.end(), [&](const Candidate& kept) {
                                   return kept.mirrored == c.mirrored &&
                                          pose_distance(X, kept.transform, c.transform) <= tolerance;
                               });
        (is_repeat ? rest : distinct).push_back(std::move(c));
    }
    std::stable_sort(rest.begin(), rest.end(), [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    candidates = std::move(distinct);
    candidates.insert(candidates.end(), std::make_move_iterator(rest.begin()), std::make_move_iterator(rest.end()));
}

// keep_best, each pose before its repeats (distinct_poses_first), but never drops a whole class:
// if the best \p count are all mirrored (or all proper), the last of them gives way to the best
// candidate of the other class. A mirror-symmetric shape (beetle.obj) fits itself both ways
// about equally well, and the coarse rounds on few samples could otherwise keep only mirrored
// starts for an unmirrored copy: a reordered copy of beetle.obj then registered as its mirror
// image for 3 of 30 keys and the mark was lost (kReflectionMargin can only choose between
// classes that reach the fine stage).
void keep_best_of_both(const Problem& p, std::vector<Candidate>& candidates, std::size_t count)
{
    std::stable_sort(candidates.begin(), candidates.end(),
                     [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    if (count == 0 || count >= candidates.size())
    {
        return;
    }
    distinct_poses_first(p, candidates, count);
    for (const bool mirrored : {false, true})
    {
        const auto kept_end = candidates.begin() + static_cast<std::ptrdiff_t>(count);
        const auto is_class = [mirrored](const Candidate& c) { return c.mirrored == mirrored; };
        if (std::none_of(candidates.begin(), kept_end, is_class))
        {
            const auto best_other = std::find_if(kept_end, candidates.end(), is_class);
            if (best_other != candidates.end() && count >= 2)
            {
                std::iter_swap(kept_end - 1, best_other);
            }
        }
    }
    // The start kept in place survives as one more (docs/algorithms/registration.md, step 4).
    const auto in_place = std::find_if(candidates.begin() + static_cast<std::ptrdiff_t>(count), candidates.end(),
                                       [](const Candidate& c) { return c.kept_in_place; });
    const std::optional<Candidate> extra =
        in_place != candidates.end() ? std::optional<Candidate>(*in_place) : std::nullopt;
    candidates.resize(count);
    if (extra)
    {
        candidates.push_back(*extra);
    }
}

/// True when the suspect's moments are close to the reference's (kInPlaceOffset, kInPlaceScale):
/// it may have been re-worked where the original stands (a modelling tool leaves it there), and
/// the identity is a start that the tournament must not drop. A mirror-symmetric shape that
/// was coarsely resampled in place (a voxel remesh) fits its mirror image about as well as
/// itself, and the coarse rounds on few samples then kept only mirrored fits and wrong turns
/// (docs/algorithms/registration.md, failure modes). A moved copy's moments differ, and its
/// starts are as before.
bool stands_in_place(const Moments& suspect, const Moments& reference)
{
    const double radius2 = reference.covariance.trace();
    const double ratio2 = suspect.covariance.trace() / radius2;
    return (suspect.centroid - reference.centroid).squaredNorm() <= kInPlaceOffset * kInPlaceOffset * radius2 &&
           ratio2 <= kInPlaceScale * kInPlaceScale && ratio2 * kInPlaceScale * kInPlaceScale >= 1.0;
}

/// True when the suspect's triangles cover (almost) none of the area its vertices span: its
/// area over its bounding box's squared diagonal is below kCollapsedArea times the reference's
/// (a triangle soup smoothed triangle by triangle, Open3D's Taubin filter on an STL read
/// without welding, shrinks every triangle to a sliver). Its area moments are then noise.
bool has_collapsed_triangles(const Problem& p, const TriangleMesh& suspect,
                             const std::vector<std::int32_t>& suspect_rows, const Moments& ms, const Moments& mr)
{
    const double suspect_span = bounding_box(suspect.V, suspect_rows).diagonal();
    const double reference_span = p.reference_diagonal;
    if (!(suspect_span > 0.0) || !(mr.weight > 0.0))
    {
        return false;
    }
    const double suspect_cover = ms.weight / (suspect_span * suspect_span);
    const double reference_cover = mr.weight / (reference_span * reference_span);
    return suspect_cover < kCollapsedArea * reference_cover;
}

/// Starts that map the suspect's principal frame onto a target frame by every rotation in
/// \p rotations, for the suspect and (when allowed) its mirror image; the scale matches the
/// RMS radii, the translation the centroids.
void add_frame_candidates(const Problem& p, const Moments& suspect, const Moments& target,
                          const std::vector<Mat3>& rotations, std::vector<Candidate>& out)
{
    const Mat3 E_t = principal_frame(target.covariance);
    const double s0 = std::sqrt(target.covariance.trace() / suspect.covariance.trace());
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !p.options.allow_reflection)
        {
            continue;
        }
        const Mat3 M = mirrored ? mirror_matrix() : Mat3::Identity();
        const Vec3 c_y = M * suspect.centroid;
        const Mat3 E_y = principal_frame(M * suspect.covariance * M);
        for (const Mat3& P : rotations)
        {
            Candidate c;
            c.mirrored = mirrored;
            c.transform.rotation = E_t * P * E_y.transpose();
            c.transform.scale = s0;
            c.transform.translation = target.centroid - s0 * c.transform.rotation * c_y;
            out.push_back(c);
        }
    }
}

/// Starts that turn the suspect by each rotation of the coordinate axes onto themselves, at
/// scale 1, its bounding box's centre onto the reference's, for the suspect and (when allowed)
/// its mirror image: the frame changes of exporters (Y up to Z up) at the original's units,
/// which need neither the moments' scale nor their axes. A copy that lost or gained surface
/// away from its outline (a voxel remesh drops the inner parts of an assembly and keeps its
/// outer shell, whose box is the original's) has other moments, which start every frame too
/// small or too large and turned; the trimmed ICP does not undo that (Khronos'
/// 2CylinderEngine voxel-remeshed by Blender, written Z up: registered at scale 0.868).
void add_axis_candidates(const Problem& p, const BoundingBox& suspect, const BoundingBox& reference,
                         std::vector<Candidate>& out)
{
    // Only for a copy whose box has the original's extents in some order (a whole copy turned
    // by axes); a crop's or a rescaled copy's starts come from the moments.
    Vec3 a = suspect.max - suspect.min;
    Vec3 b = reference.max - reference.min;
    std::sort(a.data(), a.data() + 3);
    std::sort(b.data(), b.data() + 3);
    for (int k = 0; k < 3; ++k)
    {
        if (!(a(k) <= kAxisExtentRatio * b(k) && b(k) <= kAxisExtentRatio * a(k)))
        {
            return;
        }
    }
    const Vec3 c_s = suspect.center();
    const Vec3 c_r = reference.center();
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !p.options.allow_reflection)
        {
            continue;
        }
        const Mat3 M = mirrored ? mirror_matrix() : Mat3::Identity();
        for (const Mat3& P : axis_rotations())
        {
            Candidate c;
            c.mirrored = mirrored;
            c.transform.rotation = P;
            c.transform.scale = 1.0;
            c.transform.translation = c_r - P * (M * c_s);
            out.push_back(c);
        }
    }
}

// Whether two candidates start from exactly the same place: the same handedness and the same
// transform, bit for bit. Point-to-point ICP settles on a transform computed from its pairs
// alone, so different starts that reach the same pairs reach the same transform exactly, and
// from then on run the same steps: on the held-out re-work copies, 245 of the 1,112 fine-stage
// runs of 408 registrations started where another had (docs/algorithms/registration.md).
bool same_start(const Candidate& a, const Candidate& b)
{
    return a.mirrored == b.mirrored && a.transform.scale == b.transform.scale &&
           a.transform.rotation == b.transform.rotation && a.transform.translation == b.transform.translation;
}

// For each candidate, the first earlier one with the same start, or itself: a run of ICP is a
// function of its start (and its samples, which the handedness picks), so a repeated start's
// outcome is copied instead of computed again.
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

// The outcome of \p from's run given to \p to (same start): everything but the candidate's
// own flags.
void copy_run(const Candidate& from, Candidate& to)
{
    to.outcome = from.outcome;
    to.transform = from.transform;
    to.score = from.score;
    to.residual = from.residual;
}

// Each round runs its distinct starts in parallel (each run is single-threaded and writes only
// its own slot, so the schedule cannot change the result), copies their outcomes to the repeated
// ones, then keeps the best.
int run_round(const Problem& p, std::vector<Candidate>& candidates, const Round& round)
{
    const std::vector<std::size_t> leader = first_same_start(candidates);
    const auto count = static_cast<std::int64_t>(candidates.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(resolve_threads(p.options.threads))
    for (std::int64_t i = 0; i < count; ++i)
    {
        if (leader[static_cast<std::size_t>(i)] != static_cast<std::size_t>(i))
        {
            continue;
        }
        Candidate& c = candidates[static_cast<std::size_t>(i)];
        const Positions& X = p.samples[c.mirrored ? 1 : 0][round.tier];
        const IcpSettings settings = coarse_settings(p, round.iterations, p.initial_scale, 1);
        c.outcome = detail::icp_point_to_point(X, *p.coarse_target, c.transform, settings);
        c.transform = c.outcome.transform;
        c.score = score_of(c.outcome, p.score_floor);
        c.residual = residual_of(c.outcome);
    }
    for (std::size_t i = 0; i < candidates.size(); ++i)
    {
        if (leader[i] != i)
        {
            copy_run(candidates[leader[i]], candidates[i]);
        }
    }
    keep_best_of_both(p, candidates, round.survivors);
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

// Fine stage: each surviving candidate to convergence on the fine samples against the whole
// reference surface (SurfaceMatcher over all its vertices and triangles, where the coarse stage
// used a vertex subsample); the best one then gets its last iterations on many points.
RegistrationResult finish(const Problem& p, std::vector<Candidate> candidates, int coarse_iterations)
{
    // The best few, plus the best proper candidate (see kReflectionMargin).
    keep_best(candidates, candidates.size());
    std::vector<Candidate> fine(candidates.begin(),
                                candidates.begin() + static_cast<std::ptrdiff_t>(
                                                         std::min(kFineCandidates, candidates.size())));
    const auto proper = std::find_if(candidates.begin(), candidates.end(),
                                     [](const Candidate& c) { return !c.mirrored; });
    if (proper != candidates.end() && std::none_of(fine.begin(), fine.end(), [](const Candidate& c) {
            return !c.mirrored;
        }))
    {
        fine.push_back(*proper);
    }
    const auto mirrored = std::find_if(candidates.begin(), candidates.end(),
                                       [](const Candidate& c) { return c.mirrored; });
    if (mirrored != candidates.end() && mirrored->score <= kHandednessCoarse * candidates.front().score &&
        std::none_of(fine.begin(), fine.end(), [](const Candidate& c) { return c.mirrored; }))
    {
        fine.push_back(*mirrored);
    }
    const auto in_place = std::find_if(candidates.begin(), candidates.end(),
                                       [](const Candidate& c) { return c.kept_in_place; });
    if (in_place != candidates.end() &&
        std::none_of(fine.begin(), fine.end(), [](const Candidate& c) { return c.kept_in_place; }))
    {
        fine.push_back(*in_place);
    }
    int iterations = coarse_iterations;
    // The best coarse pose turned half a turn about each of the reference's principal axes,
    // where that fits about as well (kTurnedCoarse) and is not a pose the fine stage has.
    if (!candidates.empty() && std::isfinite(candidates.front().score))
    {
        const Candidate& best = candidates.front();
        const Positions& X = p.samples[best.mirrored ? 1 : 0][kRounds.back().tier];
        const double tolerance = kSamePose * p.reference_diagonal;
        for (const Similarity& turn : p.reference_turns)
        {
            Candidate twin;
            twin.mirrored = best.mirrored;
            twin.outcome = detail::icp_point_to_point(X, *p.coarse_target, then(best.transform, turn),
                                                      coarse_settings(p, kTurnedIterations, p.initial_scale,
                                                                      p.options.threads));
            iterations += twin.outcome.iterations;
            twin.transform = twin.outcome.transform;
            twin.score = score_of(twin.outcome, p.score_floor);
            twin.residual = residual_of(twin.outcome);
            const Positions& X0 = p.samples[twin.mirrored ? 1 : 0][0];
            if (twin.score <= kTurnedCoarse * std::max(best.score, p.score_floor) &&
                std::none_of(fine.begin(), fine.end(), [&](const Candidate& c) {
                    return c.mirrored == twin.mirrored && pose_distance(X0, c.transform, twin.transform) <= tolerance;
                }))
            {
                fine.push_back(twin);
            }
        }
    }
    const std::vector<std::size_t> leader = first_same_start(fine);
    for (std::size_t i = 0; i < fine.size(); ++i)
    {
        Candidate& c = fine[i];
        if (leader[i] != i)  // refined already (the leader comes first)
        {
            copy_run(fine[leader[i]], c);
            continue;
        }
        c.outcome = refine(p, p.samples[c.mirrored ? 1 : 0][kFineTier], c.transform, p.options.max_iterations);
        c.transform = c.outcome.transform;
        c.score = score_of(c.outcome, p.score_floor);
        c.residual = residual_of(c.outcome);
        // The fine ICP has no scale clamp: a start far from the right pose can shrink the
        // suspect onto a point of the reference, where the residual vanishes. The coarse rounds
        // never leave [kMinScaleFactor, kMaxScaleFactor] times the moments' scale; neither may
        // the choice.
        if (!(c.transform.scale >= kMinScaleFactor * p.initial_scale &&
              c.transform.scale <= kMaxScaleFactor * p.initial_scale))
        {
            c.score = std::numeric_limits<double>::infinity();
            c.residual = std::numeric_limits<double>::infinity();
        }
        iterations += c.outcome.iterations;
    }
    keep_best(fine, fine.size());
    const Candidate* chosen = &fine.front();
    const auto best_proper = std::find_if(fine.begin(), fine.end(), [](const Candidate& c) { return !c.mirrored; });
    if (chosen->mirrored && best_proper != fine.end() &&
        !(chosen->residual < kReflectionMargin * best_proper->residual - p.score_floor))
    {
        chosen = &*best_proper;
    }
    const Candidate& best = *chosen;
    const auto other = std::find_if(fine.begin(), fine.end(), [&](const Candidate& c) { return c.mirrored != best.mirrored; });
    const bool tied = other != fine.end() && std::isfinite(other->score) &&
                      other->score <= kHandednessTie * std::max(best.score, p.score_floor);
    const Positions& last = p.samples[best.mirrored ? 1 : 0][kFinalTier];
    const IcpOutcome final_run = refine(p, last, best.transform, kFinalIterations);
    iterations += final_run.iterations;
    IcpOutcome final_state = detail::evaluate(last, *p.fine_target, final_run.transform, fine_settings(p, 0));
    // An articulated copy (a character re-posed, a part turned at a hinge) has no single pose:
    // trimmed at 90%, the fit settles between the parts and lays almost none of them on the
    // reference. Refined from there with half the pairs kept, it locks onto the largest part;
    // that pose is taken when it lays clearly more samples within 3 times its own trimmed RMS
    // (the rest of the copy is then read like a crop). A copy that fits as a whole gains
    // nothing: the two poses lay about as many samples on the reference.
    {
        const Positions& fine_samples = p.samples[best.mirrored ? 1 : 0][kFineTier];
        IcpSettings tight = fine_settings(p, kPartIterations);
        tight.trim_keep = kPartKeep;
        auto tight_run = [&](const Positions& X, const Similarity& start, int rounds) {
            tight.max_iterations = rounds;
            return p.fine_target->has_normals() ? detail::icp_point_to_plane(X, *p.fine_target, start, tight)
                                                : detail::icp_point_to_point(X, *p.fine_target, start, tight);
        };
        const IcpOutcome part = tight_run(fine_samples, final_state.transform, kPartIterations);
        const double within = std::max(3.0 * part.trimmed_rms, 1e-9 * p.reference_diagonal);
        auto laid_on = [&](const Similarity& T) {
            std::vector<SurfaceMatch> matches;
            p.fine_target->match_all(detail::apply(T, fine_samples, p.options.threads), matches, p.options.threads);
            const auto count = std::count_if(matches.begin(), matches.end(),
                                             [&](const SurfaceMatch& m) { return m.distance <= within; });
            return static_cast<double>(count) / static_cast<double>(std::max<std::size_t>(matches.size(), 1));
        };
        if (laid_on(part.transform) > kPartGain * laid_on(final_state.transform) + kPartMargin)
        {
            const IcpOutcome part_final = tight_run(last, part.transform, kFinalIterations);
            iterations += part.iterations + part_final.iterations;
            final_state = detail::evaluate(last, *p.fine_target, part_final.transform, fine_settings(p, 0));
        }
        else
        {
            iterations += part.iterations;
        }
    }

    RegistrationResult result;
    const Similarity& T = final_state.transform;
    result.transform = as_matrix(T, best.mirrored);
    result.scale = T.scale;
    if (tied)
    {
        const IcpOutcome other_final =
            refine(p, p.samples[other->mirrored ? 1 : 0][kFinalTier], other->transform, kFinalIterations);
        iterations += other_final.iterations;
        result.other_handedness = as_matrix(other_final.transform, other->mirrored);
    }
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

// The fine stage's target is left out when \p build_fine_target is false (the caller builds it).
Problem make_problem(const TriangleMesh& suspect, const TriangleMesh& reference,
                     const std::vector<std::int32_t>& suspect_rows,
                     const std::vector<std::int32_t>& reference_rows, const RegistrationOptions& options,
                     bool build_fine_target = true)
{
    Problem p{options, {}, nullptr, nullptr, 1.0, 1.0, 0.0, {}};
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
    if (build_fine_target)
    {
        p.fine_target = std::make_unique<SurfaceMatcher>(reference);
    }
    p.reference_diagonal = std::max(bounding_box(reference.V, reference_rows).diagonal(), 1e-300);
    p.score_floor = 1e-9 * bounding_box(suspect.V, suspect_rows).diagonal();
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
    Problem p = make_problem(suspect, reference, suspect_rows, reference_rows, options, false);

    // Principal axes of both shapes, measured the same way: area-weighted when both have
    // triangles, vertex-based as soon as one is a point cloud. The moments and the fine stage's
    // target (a kd-tree over all the reference's vertices) are independent serial computations:
    // they run side by side, each exactly as it would alone. The target is built by the calling
    // thread (thread 0 of the team), so that its large arrays come from the same allocator arena
    // as the rest of the run (with OpenMP sections, where any thread could build it, the peak
    // RSS of a 1M-vertex detect varied between 483 and 602 MiB from run to run).
    bool use_area = !suspect.is_point_cloud() && !reference.is_point_cloud();
    Moments ms;
    Moments mr;
    std::array<std::exception_ptr, 2> failures;
#pragma omp parallel num_threads(std::min(2, resolve_threads(options.threads)))
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
                ms = use_area ? detail::area_moments(suspect) : detail::vertex_moments(suspect.V, suspect_rows);
                mr = use_area ? detail::area_moments(reference) : detail::vertex_moments(reference.V, reference_rows);
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
    if (use_area && has_collapsed_triangles(p, suspect, suspect_rows, ms, mr))
    {
        // Its vertices still stand on the surface, but the triangles no longer cover it: the
        // area weighting measures numerical dust. Both shapes are measured by their vertices.
        use_area = false;
        ms = detail::vertex_moments(suspect.V, suspect_rows);
        mr = detail::vertex_moments(reference.V, reference_rows);
    }
    if (!(ms.covariance.trace() > 0.0) || !(mr.covariance.trace() > 0.0))
    {
        throw InvalidMesh("registration: the suspect or the reference has zero extent (all its "
                          "points coincide).");
    }
    p.initial_scale = std::sqrt(mr.covariance.trace() / ms.covariance.trace());
    p.reference_turns = half_turns(mr);

    // Coarse alignment: the whole shape's axes, and the axes of plausible cropped parts of
    // the reference; a tournament of short trimmed ICP runs on growing samples.
    std::vector<Candidate> candidates;
    // The suspect where it stands: a copy cut, bisected or edited in the original's own frame
    // (what a modelling tool does unless told to move it) needs no alignment at all, while the
    // moments of an unexpected part can miss it (a bisected open scan: docs/algorithms/registration.md).
    candidates.push_back(Candidate{});
    candidates.back().kept_in_place = stands_in_place(ms, mr);
    add_frame_candidates(p, ms, mr, axis_rotations(), candidates);
    add_axis_candidates(p, bounding_box(suspect.V, suspect_rows), bounding_box(reference.V, reference_rows),
                        candidates);
    for (const Moments& part : crop_hypotheses(reference, use_area, reference_rows, mr, ms,
                                               derive_seed(options.seed, "crop elements")))
    {
        add_frame_candidates(p, ms, part, frame_rotations(part.covariance, ms.covariance), candidates);
    }
    const int tried = static_cast<int>(candidates.size());
    int iterations = 0;
    for (const Round& round : kRounds)
    {
        iterations += run_round(p, candidates, round);
    }

    // Fine alignment of the survivors: point-to-plane ICP against the whole reference surface.
    RegistrationResult result = finish(p, std::move(candidates), iterations);
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
        Candidate c;
        c.mirrored = mirrored;
        c.transform = similarity_parts(similarity_from_pairs(flipped, false));
        candidates.push_back(c);
    }
    p.initial_scale = candidates.front().transform.scale;
    const int iterations = run_round(p, candidates, kRounds.back());
    RegistrationResult result = finish(p, std::move(candidates), iterations);
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
    const auto suspect_rows = usable_vertices(suspect, "suspect mesh");
    const auto reference_rows = usable_vertices(reference, "reference mesh");
    // The start as scale * rotation (* mirror: the samples are mirrored, x -> -x, as the coarse
    // stage's mirrored candidates are).
    const Mat3 A = start.block<3, 3>(0, 0);
    Candidate c;
    c.mirrored = A.determinant() < 0.0;
    const Mat3 B = c.mirrored ? Mat3(A * mirror_matrix()) : A;
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
    Problem p = make_problem(suspect, reference, suspect_rows, reference_rows, own);
    p.initial_scale = c.transform.scale;
    std::vector<Candidate> candidates{c};
    const int iterations = run_round(p, candidates, kRounds.back());
    RegistrationResult result = finish(p, std::move(candidates), iterations);
    result.candidates = 1;
    return result;
}

Eigen::Vector3d principal_spread(const TriangleMesh& mesh)
{
    const Moments m = mesh.is_point_cloud() ? detail::vertex_moments(mesh.V, usable_vertices(mesh, "mesh"))
                                            : detail::area_moments(mesh);
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Mat3>(m.covariance).eigenvalues();
    if (!(e.sum() > 0.0))
    {
        throw InvalidMesh("principal_spread: the mesh has no extent.");
    }
    return e / e.sum();
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
    const Eigen::Matrix4d proper = fit_similarity(src, dst);
    if (!allow_reflection)
    {
        return proper;
    }
    const Mat3 M = mirror_matrix();
    const Eigen::Matrix3Xd mirrored_src = M * src;
    Eigen::Matrix4d mirrored = fit_similarity(mirrored_src, dst);
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

// SPDX-License-Identifier: MIT
#include "registration/detail/fine_stage.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "registration/detail/coarse_candidates.h"
#include "registration/detail/tournament.h"

namespace meshmark::detail
{
namespace
{

// Candidates that go on to the fine stage: the best two, plus the best proper one.
constexpr std::size_t kFineCandidates = 2;
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
// Iterations of the last fine runs on the final (largest) sample tier: the pose has converged on
// the fine tier, the many samples only steady it.
constexpr int kFinalIterations = 6;
// Articulated copies (settle_on_largest_part): the share of pairs kept when refining onto the
// largest part, its iterations, and how many more samples it must lay on the reference to be
// taken (a creature bent by 20 degrees at a joint: 9% of the samples within 3 trimmed RMS at
// the 90% pose, 53% at this one; the copies that fit as a whole: the same or fewer).
constexpr double kPartKeep = 0.5;
constexpr int kPartIterations = 20;
constexpr double kPartGain = 1.2;
constexpr double kPartMargin = 0.05;

// The ICP from \p start on \p X, or \p start itself where the ICP ended on a worse fit than it
// began with (score_of): point-to-plane steps with a free scale can slide a thin, flat copy
// along its faces and shrink it while the planes' residual falls (a Blender voxel remesh of a
// stove, 5.6 x 33 x 60, started where it stands at a trimmed RMS of 0.05 ended at scale 0.64
// and 0.41).
IcpOutcome refine(const Problem& p, const Positions& X, const Similarity& start, int iterations)
{
    const IcpSettings settings = fine_settings(p, iterations);
    IcpOutcome run = p.fine_target->has_normals()
                         ? icp_point_to_plane(X, *p.fine_target, start, settings)
                         : icp_point_to_point(X, *p.fine_target, start, settings);
    IcpOutcome at_start = evaluate(X, *p.fine_target, start, fine_settings(p, 0));
    if (score_of(at_start, p.score_floor) < score_of(run, p.score_floor))
    {
        at_start.iterations = run.iterations;
        return at_start;
    }
    return run;
}

// The candidates the fine stage refines, from \p candidates sorted by score: the best few, the
// best proper one (see kReflectionMargin), the best mirrored one when its coarse score ties
// (kHandednessCoarse), and the start kept in place.
std::vector<Candidate> fine_candidates(const std::vector<Candidate>& candidates)
{
    std::vector<Candidate> fine(
        candidates.begin(), candidates.begin() + static_cast<std::ptrdiff_t>(
                                                     std::min(kFineCandidates, candidates.size())));
    const auto proper = std::find_if(candidates.begin(), candidates.end(),
                                     [](const Candidate& c) { return !c.mirrored; });
    if (proper != candidates.end() &&
        std::none_of(fine.begin(), fine.end(), [](const Candidate& c) { return !c.mirrored; }))
    {
        fine.push_back(*proper);
    }
    const auto mirrored = std::find_if(candidates.begin(), candidates.end(),
                                       [](const Candidate& c) { return c.mirrored; });
    if (mirrored != candidates.end() &&
        mirrored->score <= kHandednessCoarse * candidates.front().score &&
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
    if (in_place != candidates.end())
    {
        // The start in place itself too, not only where the coarse rounds took it: their scale
        // is clamped about the moments' scale, which a copy that lost inner parts (a voxel
        // remesh of an appliance) misleads.
        Candidate as_it_stands;
        as_it_stands.kept_in_place = true;
        fine.push_back(as_it_stands);
    }
    return fine;
}

// The best coarse pose (the first of \p candidates) turned half a turn about each of the
// reference's principal axes, added to \p fine where that fits about as well (kTurnedCoarse)
// and is not a pose \p fine has. \return The iterations run.
int add_turned_poses(const Problem& p, const std::vector<Candidate>& candidates,
                     std::vector<Candidate>& fine)
{
    int iterations = 0;
    if (candidates.empty() || !std::isfinite(candidates.front().score))
    {
        return iterations;
    }
    const Candidate& best = candidates.front();
    const Positions& X = p.samples[best.mirrored ? 1 : 0][kRounds.back().tier];
    const double tolerance = kSamePose * p.reference_diagonal;
    for (const Similarity& turn : p.reference_turns)
    {
        Candidate twin;
        twin.mirrored = best.mirrored;
        twin.outcome = icp_point_to_point(
            X, *p.coarse_target, then(best.transform, turn),
            coarse_settings(p, kTurnedIterations, p.initial_scale, p.options.threads));
        iterations += twin.outcome.iterations;
        twin.transform = twin.outcome.transform;
        twin.score = score_of(twin.outcome, p.score_floor);
        twin.residual = residual_of(twin.outcome);
        const Positions& X0 = p.samples[twin.mirrored ? 1 : 0][0];
        if (twin.score <= kTurnedCoarse * std::max(best.score, p.score_floor) &&
            std::none_of(fine.begin(), fine.end(),
                         [&](const Candidate& c)
                         {
                             return c.mirrored == twin.mirrored &&
                                    pose_distance(X0, c.transform, twin.transform) <= tolerance;
                         }))
        {
            fine.push_back(twin);
        }
    }
    return iterations;
}

// Each of \p fine to convergence on the fine samples (a repeated start copies its leader's run).
// \return The iterations run.
int refine_all(const Problem& p, std::vector<Candidate>& fine)
{
    int iterations = 0;
    const std::vector<std::size_t> leader = first_same_start(fine);
    for (std::size_t i = 0; i < fine.size(); ++i)
    {
        Candidate& c = fine[i];
        if (leader[i] != i)  // refined already (the leader comes first)
        {
            copy_run(fine[leader[i]], c);
            continue;
        }
        c.outcome = refine(p, p.samples[c.mirrored ? 1 : 0][kFineTier], c.transform,
                           p.options.max_iterations);
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
    return iterations;
}

// An articulated copy (a character re-posed, a part turned at a hinge) has no single pose:
// trimmed at 90%, the fit settles between the parts and lays almost none of them on the
// reference. Refined from \p final_state with half the pairs kept, it locks onto the largest
// part; that pose replaces \p final_state when it lays clearly more samples within 3 times its
// own trimmed RMS (the rest of the copy is then read like a crop). A copy that fits as a whole
// gains nothing: the two poses lay about as many samples on the reference. \return The
// iterations run.
int settle_on_largest_part(const Problem& p, const Positions& fine_samples, const Positions& last,
                           IcpOutcome& final_state)
{
    IcpSettings tight = fine_settings(p, kPartIterations);
    tight.trim_keep = kPartKeep;
    auto tight_run = [&](const Positions& X, const Similarity& start, int rounds)
    {
        tight.max_iterations = rounds;
        return p.fine_target->has_normals() ? icp_point_to_plane(X, *p.fine_target, start, tight)
                                            : icp_point_to_point(X, *p.fine_target, start, tight);
    };
    const IcpOutcome part = tight_run(fine_samples, final_state.transform, kPartIterations);
    const double within = std::max(3.0 * part.trimmed_rms, kExactFit * p.reference_diagonal);
    auto laid_on = [&](const Similarity& T)
    {
        std::vector<SurfaceMatch> matches;
        p.fine_target->match_all(apply(T, fine_samples, p.options.threads), matches,
                                 p.options.threads);
        const auto count =
            std::count_if(matches.begin(), matches.end(),
                          [&](const SurfaceMatch& m) { return m.distance <= within; });
        return static_cast<double>(count) /
               static_cast<double>(std::max<std::size_t>(matches.size(), 1));
    };
    if (laid_on(part.transform) > kPartGain * laid_on(final_state.transform) + kPartMargin)
    {
        const IcpOutcome part_final = tight_run(last, part.transform, kFinalIterations);
        final_state = evaluate(last, *p.fine_target, part_final.transform, fine_settings(p, 0));
        return part.iterations + part_final.iterations;
    }
    return part.iterations;
}

}  // namespace

// Each surviving candidate to convergence on the fine samples against the whole reference
// surface (SurfaceMatcher over all its vertices and triangles, where the coarse stage used a
// vertex subsample); the best one then gets its last iterations on many points.
RegistrationResult run_fine_stage(const Problem& p, std::vector<Candidate> candidates,
                                  int coarse_iterations)
{
    keep_best(candidates, candidates.size());
    std::vector<Candidate> fine = fine_candidates(candidates);
    int iterations = coarse_iterations;
    iterations += add_turned_poses(p, candidates, fine);
    iterations += refine_all(p, fine);

    // The best refined fit; a mirrored one only when it beats the best proper one clearly.
    keep_best(fine, fine.size());
    const Candidate* chosen = &fine.front();
    const auto best_proper =
        std::find_if(fine.begin(), fine.end(), [](const Candidate& c) { return !c.mirrored; });
    if (chosen->mirrored && best_proper != fine.end() &&
        !(chosen->residual < kReflectionMargin * best_proper->residual - p.score_floor))
    {
        chosen = &*best_proper;
    }
    const Candidate& best = *chosen;
    const auto other = std::find_if(
        fine.begin(), fine.end(), [&](const Candidate& c) { return c.mirrored != best.mirrored; });
    const bool tied = other != fine.end() && std::isfinite(other->score) &&
                      other->score <= kHandednessTie * std::max(best.score, p.score_floor);

    // Its last iterations on many samples, and the largest part of an articulated copy.
    const Positions& last = p.samples[best.mirrored ? 1 : 0][kFinalTier];
    const IcpOutcome final_run = refine(p, last, best.transform, kFinalIterations);
    iterations += final_run.iterations;
    IcpOutcome final_state =
        evaluate(last, *p.fine_target, final_run.transform, fine_settings(p, 0));
    iterations +=
        settle_on_largest_part(p, p.samples[best.mirrored ? 1 : 0][kFineTier], last, final_state);

    RegistrationResult result;
    const Similarity& T = final_state.transform;
    result.transform = as_matrix(T, best.mirrored);
    result.scale = T.scale;
    if (tied)
    {
        const IcpOutcome other_final = refine(p, p.samples[other->mirrored ? 1 : 0][kFinalTier],
                                              other->transform, kFinalIterations);
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

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#include "registration/detail/tournament.h"

#include <algorithm>
#include <cstdint>
#include <iterator>
#include <optional>

#include "meshmark/core/threads.h"

namespace meshmark::detail
{
namespace
{

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
        const bool is_repeat =
            distinct.size() >= count ||
            std::any_of(distinct.begin(), distinct.end(),
                        [&](const Candidate& kept)
                        {
                            return kept.mirrored == c.mirrored &&
                                   pose_distance(X, kept.transform, c.transform) <= tolerance;
                        });
        (is_repeat ? rest : distinct).push_back(std::move(c));
    }
    std::stable_sort(rest.begin(), rest.end(),
                     [](const Candidate& a, const Candidate& b) { return a.score < b.score; });
    candidates = std::move(distinct);
    candidates.insert(candidates.end(), std::make_move_iterator(rest.begin()),
                      std::make_move_iterator(rest.end()));
}

// keep_best, each pose before its repeats (distinct_poses_first), but never drops a whole class:
// if the best \p count are all mirrored (or all proper), the last of them gives way to the best
// candidate of the other class. A mirror-symmetric shape (beetle.obj) fits itself both ways
// about equally well, and the coarse rounds on few samples could otherwise keep only mirrored
// starts for an unmirrored copy: a reordered copy of beetle.obj then registered as its mirror
// image for 3 of 30 keys and the mark was lost (kReflectionMargin, fine_stage.cpp, can only
// choose between classes that reach the fine stage).
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
    const auto in_place =
        std::find_if(candidates.begin() + static_cast<std::ptrdiff_t>(count), candidates.end(),
                     [](const Candidate& c) { return c.kept_in_place; });
    const std::optional<Candidate> extra =
        in_place != candidates.end() ? std::optional<Candidate>(*in_place) : std::nullopt;
    candidates.resize(count);
    if (extra)
    {
        candidates.push_back(*extra);
    }
}

}  // namespace

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
        c.outcome = icp_point_to_point(X, *p.coarse_target, c.transform, settings);
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

int run_tournament(const Problem& p, std::vector<Candidate>& candidates)
{
    int iterations = 0;
    for (const Round& round : kRounds)
    {
        iterations += run_round(p, candidates, round);
    }
    return iterations;
}

}  // namespace meshmark::detail

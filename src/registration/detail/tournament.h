// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "registration/detail/registration_problem.h"

/// The coarse stage's tournament: every start runs a few iterations of trimmed point-to-point
/// ICP with scale on a small sample, the best go on to more iterations on more samples.
namespace meshmark::detail
{

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

/// \brief One round: the distinct starts run in parallel (each run single-threaded, writing
/// its own slot: the schedule cannot change the result), repeated starts copy their leader's
/// outcome, then the best `round.survivors` are kept (keep_best_of_both).
/// \return The round's iteration budget.
int run_round(const Problem& p, std::vector<Candidate>& candidates, const Round& round);

/// \brief Every round of kRounds in turn. \return Their iteration budgets, summed.
int run_tournament(const Problem& p, std::vector<Candidate>& candidates);

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <vector>

#include "meshmark/registration/registration.h"
#include "registration/detail/registration_problem.h"

/// The fine stage of register_to_reference: the tournament's best candidates refined to
/// convergence against the whole reference surface, the choice between them (and between a
/// copy and its mirror image), the last iterations on many samples, and the largest part of an
/// articulated copy.
namespace meshmark::detail
{

/// \brief Refine the best of \p candidates and choose the registration.
/// \param coarse_iterations  The coarse stage's iterations, counted into the result.
/// \return Everything of the result but `candidates` and `reference_surface`.
[[nodiscard]] RegistrationResult run_fine_stage(const Problem& p, std::vector<Candidate> candidates,
                                                int coarse_iterations);

}  // namespace meshmark::detail

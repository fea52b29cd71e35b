// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/triangle_mesh.h"
#include "registration/detail/coarse_alignment.h"
#include "registration/detail/registration_problem.h"

/// The coarse stage's starting transforms: the suspect where it stands, its principal frame on
/// the reference's (and on the frames of the parts a crop could have left), its coordinate axes
/// on the reference's, and the half turns tried after the tournament.
namespace meshmark::detail
{

/// True when the suspect's triangles cover (almost) none of the area its vertices span (its
/// area moments are then noise and both shapes are measured by their vertices).
[[nodiscard]] bool has_collapsed_triangles(const Problem& p, const TriangleMesh& suspect,
                                           const std::vector<std::int32_t>& suspect_rows,
                                           const Moments& ms, const Moments& mr);

/// \brief Every start of the automatic coarse stage, in a fixed order: the suspect in place
/// (kept through every round when it stands where the reference does), its principal frame
/// matched to the reference's by the 24 axis rotations, the axis-to-axis starts of a whole copy
/// turned by axes, and the frames of the reference's crop hypotheses; each for the suspect and
/// (when allowed) its mirror image.
/// \param ms, mr     The suspect's and the reference's moments, measured the same way.
/// \param use_area   Whether they are area moments (else vertex moments).
[[nodiscard]] std::vector<Candidate> coarse_starts(const Problem& p, const TriangleMesh& suspect,
                                                   const TriangleMesh& reference,
                                                   const std::vector<std::int32_t>& suspect_rows,
                                                   const std::vector<std::int32_t>& reference_rows,
                                                   const Moments& ms, const Moments& mr,
                                                   bool use_area);

/// The three half turns about the principal axes of \p m through its centroid.
[[nodiscard]] std::vector<Similarity> half_turns(const Moments& m);

/// \p T followed by \p S (S a rigid motion of the reference's space).
[[nodiscard]] Similarity then(const Similarity& T, const Similarity& S);

}  // namespace meshmark::detail

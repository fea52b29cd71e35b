// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

/// \brief The similarity taking a suspect with the original's vertex order onto the original,
/// over the rows \p kept (null: all) [Umeyama 1991].
/// \details Fitted from the original onto the suspect and inverted: noise in the suspect then
/// averages out, whereas a fit from the noisy suspect shrinks its scale (errors in the
/// fitted-from variable; measured on rocker-arm.obj with 1% noise: low-mode errors of 20-30
/// modulation steps that way). The closed form is registration's `fit_similarity`.
[[nodiscard]] Eigen::Matrix4d similarity_onto_original(const Positions& original,
                                                       const Positions& suspect,
                                                       const std::vector<std::uint8_t>* kept);

}  // namespace meshmark::detail

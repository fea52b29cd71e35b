// SPDX-License-Identifier: MIT
// Private helpers shared by the attacks: random directions.
#pragma once

#include <cmath>
#include <numbers>

#include <Eigen/Core>
#include <omp.h>

#include "meshmark/core/rng.h"
#include "meshmark/core/threads.h"

namespace meshmark::detail
{

/// Direction uniform on the unit sphere (Archimedes: z uniform in [-1, 1], longitude uniform).
inline Eigen::Vector3d random_unit_vector(Rng& rng)
{
    const double z = rng.uniform(-1.0, 1.0);
    const double phi = 2.0 * std::numbers::pi * rng.uniform();
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace meshmark::detail

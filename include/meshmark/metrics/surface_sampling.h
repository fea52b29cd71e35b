// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Area samples drawn per block; each block has its own random stream (see sample_surface), so
/// the draw does not depend on the thread count. 4096: chosen by hand; no study on record.
inline constexpr std::int64_t kSamplesPerBlock = 4096;

/// \brief Area-proportional, stratified random points on the faces of a mesh.
/// \details The total area is cut into \p count strata of equal area, in face order; sample k
/// falls at a uniformly random position of stratum k (so it lies on the face that holds that
/// position), then at a uniformly random point of that triangle. Every face receives
/// count * area / total samples with an error below 2 (whole strata plus two partial ones), so
/// the sample mean of any quantity is an area-weighted mean with low variance (stratified
/// sampling; Metro [Cignoni et al. 1998] samples faces in proportion to their area too).
/// Samples are generated in blocks of kSamplesPerBlock, block b drawing from
/// `Rng(splitmix64(splitmix64(seed) ^ b))`, so the result is identical for any thread count.
/// \param mesh    Triangle mesh; unreferenced vertices play no role.
/// \param count   Number of samples (>= 0).
/// \param seed    Seed of the random streams.
/// \param threads Worker threads (0 = all cores).
/// \return #count×3 points; empty when the mesh has no faces or zero total area.
/// \throws InvalidOption if count is negative.
[[nodiscard]] Positions sample_surface(const TriangleMesh& mesh, std::int64_t count,
                                       std::uint64_t seed, int threads = 0);

/// \brief Cumulative face areas: entry f is the area of faces 0..f (#F entries, non-decreasing).
/// \details Shared by sample_surface and the distance metrics so both cut the same strata.
[[nodiscard]] Eigen::VectorXd cumulative_face_areas(const TriangleMesh& mesh);

/// \brief The samples of block \p block, exactly as sample_surface returns them.
/// \details Resizes \p out to n×3, n = min(kSamplesPerBlock, count - block * kSamplesPerBlock).
/// Lets callers stream blocks through a computation without storing every sample.
/// \pre cumulative_areas is from cumulative_face_areas(mesh) and its last entry is positive.
void sample_surface_block(const TriangleMesh& mesh, const Eigen::VectorXd& cumulative_areas,
                          std::int64_t count, std::uint64_t seed, std::int64_t block,
                          Positions& out);

}  // namespace meshmark

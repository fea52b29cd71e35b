// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Law of the random displacement.
enum class NoiseDistribution
{
    Uniform,   ///< Uniform in [-a, a] (the benchmark's law [Wang et al. 2008]).
    Gaussian,  ///< Normal with standard deviation a.
};

/// Direction of the random displacement.
enum class NoiseDirection
{
    Isotropic,  ///< An independent draw on each of x, y, z.
    Normal,     ///< One draw per vertex, along its area-weighted vertex normal.
};

/// What the amplitude is relative to.
enum class NoiseReference
{
    BboxDiagonal,      ///< Bounding-box diagonal of the referenced vertices (meshmark's unit).
    CentroidDistance,  ///< Mean distance of the referenced vertices to their centroid (the
                       ///< benchmark's unit [Wang et al. 2008]).
};

/// Parameters of the additive-noise attack.
struct NoiseOptions
{
    /// Amplitude a as a fraction of the reference length; the benchmark's levels are
    /// 0.0005, 0.001, 0.003, 0.005 and 0.01. Range [0, 1].
    double amplitude = 1e-3;
    NoiseDistribution distribution = NoiseDistribution::Uniform;
    NoiseDirection direction = NoiseDirection::Isotropic;
    NoiseReference reference = NoiseReference::BboxDiagonal;

    /// \throws InvalidOption when amplitude is outside [0, 1] or not finite.
    void validate() const;
    bool operator==(const NoiseOptions&) const = default;
};

/// \brief Displace the vertices by independent random noise.
/// \details With amplitude `a` (absolute, after scaling by the reference length), every
/// coordinate of every vertex moves by a draw of the distribution (isotropic), or every vertex
/// moves along its unit normal by one draw (normal). So the RMS displacement per coordinate is
/// `a / sqrt(3)` (uniform) or `a` (Gaussian) for isotropic noise, and the RMS displacement
/// length is `a / sqrt(3)` or `a` for normal noise. Vertices used by no face have no normal
/// and stay put under normal noise; a point cloud has no normals, so normal noise throws.
/// Connectivity is unchanged: vertex i of the result is vertex i of \p mesh. Vertices are cut
/// into fixed blocks, each with its own stream seeded from \p rng, so the result does not
/// depend on \p threads.
/// \param threads  Worker threads (0 = all cores).
/// \throws InvalidOption from options.validate(); InvalidMesh for normal noise on a point cloud.
[[nodiscard]] TriangleMesh add_noise(const TriangleMesh& mesh, const NoiseOptions& options,
                                     Rng& rng, int threads = 0);

}  // namespace meshmark

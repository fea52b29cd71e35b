// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of uniform-weight Laplacian smoothing.
struct LaplacianSmoothingOptions
{
    /// Number of iterations; the benchmark's levels are 5, 10, 30, 50 and 100. Range 0..100000.
    int iterations = 10;
    /// Step factor lambda in (0, 1]; 0.1 is the benchmark's value [Wang et al. 2008].
    double lambda = 0.1;

    /// \throws InvalidOption naming the field when a value is out of range.
    void validate() const;
    bool operator==(const LaplacianSmoothingOptions&) const = default;
};

/// Parameters of Taubin's lambda|mu smoothing.
struct TaubinSmoothingOptions
{
    int iterations = 10;  ///< Number of (lambda, mu) step pairs. Range 0..100000.
    double lambda = 0.5;  ///< Shrinking step, in (0, 1].
    double mu = -0.53;    ///< Inflating step, in [-1, 0) with -mu >= lambda [Taubin 1995].

    /// \throws InvalidOption naming the field when a value is out of range.
    void validate() const;
    bool operator==(const TaubinSmoothingOptions&) const = default;
};

/// \brief Uniform-weight Laplacian smoothing: `p_i += lambda * (mean of the neighbours - p_i)`,
/// repeated.
/// \details Each iteration updates every vertex from the previous positions (Jacobi), so the
/// result does not depend on vertex order or on \p threads. Neighbours are the vertices sharing
/// an edge (see vertex_adjacency()); boundary vertices are smoothed too, and vertices with no
/// neighbour stay put. The mesh shrinks as it smooths. Connectivity is unchanged.
/// [Taubin 1995; the benchmark's smoothing attack, Wang et al. 2008]
/// \param threads  Worker threads (0 = all cores).
/// \throws InvalidOption from options.validate(); InvalidMesh for a point cloud (no edges).
[[nodiscard]] TriangleMesh smooth_laplacian(const TriangleMesh& mesh,
                                            const LaplacianSmoothingOptions& options,
                                            int threads = 0);

/// \brief Taubin's lambda|mu smoothing: each iteration is a Laplacian step with factor lambda
/// followed by one with factor mu (< 0), which removes noise with little shrinkage.
/// [Taubin, "A signal processing approach to fair surface design", SIGGRAPH 1995]
/// \details Same neighbourhoods, determinism and failures as smooth_laplacian().
[[nodiscard]] TriangleMesh smooth_taubin(const TriangleMesh& mesh,
                                         const TaubinSmoothingOptions& options, int threads = 0);

}  // namespace meshmark

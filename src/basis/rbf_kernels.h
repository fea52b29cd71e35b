// SPDX-License-Identifier: MIT
// Block kernels of the RBF basis passes, in three builds: a portable one (Eigen, whatever the
// baseline x86-64 target vectorizes, i.e. SSE2), an AVX2+FMA one and an AVX-512 one
// (intrinsics, selected at run time; the AVX-512 set gives the AVX2 set's bits). Internal to
// the basis module.
#pragma once

#include <cstddef>

namespace meshmark::detail
{

/// \brief Squared distance beyond which phi is certainly 0: (sigma (1 + 1e-9))^2.
/// \details The evaluation skips the square root there. For d = sqrt(s) / sigma with s above
/// this bound, the computed d is >= 1 whatever the rounding (each of the three roundings is
/// relative 2^-53 << 1e-9), so the full formula would give t = 0 and phi = +0 as well: the
/// shortcut does not change a bit.
[[nodiscard]] inline double outside_squared_distance(double inv_sigma) noexcept
{
    const double reach = (1.0 + 1e-9) / inv_sigma;
    return reach * reach;
}

/// \brief One entry phi(|p - q| / sigma) of B, in the operation order of one lane of the
/// vector kernels (they use it for the columns past their last full vector): keep the two
/// identical, entry for entry.
[[nodiscard]] inline double wendland_entry(double px, double py, double pz, double qx, double qy,
                                           double qz, double inv_sigma,
                                           double outside_squared) noexcept
{
    const double dx = px - qx;
    const double dy = py - qy;
    const double dz = pz - qz;
    const double sq = dx * dx + dy * dy + dz * dz;
    if (sq >= outside_squared)
    {
        return 0.0;
    }
    const double d = __builtin_sqrt(sq) * inv_sigma;
    const double t = d < 1.0 ? 1.0 - d : 0.0;
    const double t2 = t * t;
    return t2 * t2 * (4.0 * d + 1.0);
}

/// \brief The four operations of a row block, on row-major blocks.
/// \details B is rows x ld (ld a multiple of 4, >= k), row r holding phi(|p_r - q_j| / sigma)
/// for j < k and zeros for k <= j < ld (callers may overwrite the padding columns). Within one
/// implementation every entry is a fixed sequence of operations over the rows in order, so
/// the results do not depend on how blocks are distributed over threads.
struct BlockKernels
{
    const char* name;
    /// B = phi(|P - Q| / sigma): P is rows x 3 (row-major), Q is 3 x ld (x, y and z of the
    /// centers, structure of arrays). Bit-identical in both implementations (no FMA).
    void (*evaluate)(const double* P, std::size_t rows, const double* Q, std::size_t k,
                     std::size_t ld, double inv_sigma, double* B);
    /// G += B^T B on the lower triangle (G is ld x ld row-major; entries above the diagonal
    /// may be touched and are meaningless).
    void (*gram)(const double* B, std::size_t rows, std::size_t ld, double* G);
    /// out = B M, with M given transposed: Mt is w x ld row-major (zero where B's columns are
    /// padding); out is rows x w row-major.
    void (*multiply)(const double* B, std::size_t rows, std::size_t ld, const double* Mt,
                     std::size_t w, double* out);
    /// acc += X^T B: X is rows x w row-major, acc is w x ld row-major (acc^T = B^T X).
    void (*accumulate)(const double* B, std::size_t rows, std::size_t ld, const double* X,
                       std::size_t w, double* acc);
};

/// Baseline kernels, any x86-64 (and any other) CPU.
[[nodiscard]] const BlockKernels& portable_kernels() noexcept;

/// AVX2+FMA kernels, or nullptr when this build or this CPU lacks them.
[[nodiscard]] const BlockKernels* avx2_kernels() noexcept;

/// AVX-512 kernels (Gram, accumulate on 8 lanes; AVX2's evaluate and multiply), bit-identical to
/// the AVX2 ones, or nullptr when this build or this CPU lacks AVX-512F, AVX2 or FMA.
[[nodiscard]] const BlockKernels* avx512_kernels() noexcept;

/// The kernels set_basis_kernel() (or MESHMARK_BASIS_KERNEL) chose, falling back to what this
/// CPU has: what an RbfBasis built now uses.
[[nodiscard]] const BlockKernels& selected_kernels() noexcept;

}  // namespace meshmark::detail

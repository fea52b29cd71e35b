// SPDX-License-Identifier: MIT
// AVX2+FMA block kernels, written with intrinsics in functions compiled for that target only
// (function attributes, not -mavx2 on the file): Eigen picks its instruction set when it is
// compiled, and an AVX2 instantiation of an Eigen template in one object could replace the
// baseline one program-wide at link time. Nothing here is inline outside this file.
// Measured with the project's flags, Eigen's SSE2 rankUpdate of a 256 x 100 block runs at
// ~9 GFLOP/s per core and this kernel at ~30 (docs/performance.md).
#include "basis/rbf_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__)
#define MESHMARK_HAVE_AVX2_KERNELS 1
#include <immintrin.h>
#endif

namespace meshmark::detail
{

#ifdef MESHMARK_HAVE_AVX2_KERNELS
namespace
{

#define MESHMARK_AVX2 __attribute__((target("avx2,fma")))

// Rows per sub-block of the Gram update: 32 rows of ~100 doubles stay in the L1 cache while
// every tile of the triangle passes over them.
constexpr std::size_t kGramRows = 32;

MESHMARK_AVX2 void evaluate(const double* P, std::size_t rows, const double* Q, std::size_t k,
                            std::size_t ld, double inv_sigma, double* B)
{
    // Same operations in the same order as the portable loop (no FMA), so B is bit-identical.
    const double* qx = Q;
    const double* qy = Q + ld;
    const double* qz = Q + 2 * ld;
    const __m256d one = _mm256_set1_pd(1.0);
    const __m256d four = _mm256_set1_pd(4.0);
    const __m256d scale = _mm256_set1_pd(inv_sigma);
    const __m256d outside = _mm256_set1_pd(outside_squared_distance(inv_sigma));
    const double outside_squared = outside_squared_distance(inv_sigma);
    const std::size_t k4 = k / 4 * 4;
    for (std::size_t r = 0; r < rows; ++r)
    {
        const double px = P[3 * r];
        const double py = P[3 * r + 1];
        const double pz = P[3 * r + 2];
        const __m256d vx = _mm256_set1_pd(px);
        const __m256d vy = _mm256_set1_pd(py);
        const __m256d vz = _mm256_set1_pd(pz);
        double* row = B + r * ld;
        std::size_t j = 0;
        for (; j < k4; j += 4)
        {
            const __m256d dx = _mm256_sub_pd(vx, _mm256_loadu_pd(qx + j));
            const __m256d dy = _mm256_sub_pd(vy, _mm256_loadu_pd(qy + j));
            const __m256d dz = _mm256_sub_pd(vz, _mm256_loadu_pd(qz + j));
            const __m256d sq = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)), _mm256_mul_pd(dz, dz));
            if (_mm256_movemask_pd(_mm256_cmp_pd(sq, outside, _CMP_LT_OQ)) == 0)
            {
                // All four centers out of reach: the formula gives +0 (see kOutsideMargin).
                _mm256_storeu_pd(row + j, _mm256_setzero_pd());
                continue;
            }
            const __m256d d = _mm256_mul_pd(_mm256_sqrt_pd(sq), scale);
            const __m256d inside = _mm256_cmp_pd(d, one, _CMP_LT_OQ);
            const __m256d t = _mm256_and_pd(inside, _mm256_sub_pd(one, d));
            const __m256d t2 = _mm256_mul_pd(t, t);
            const __m256d value =
                _mm256_mul_pd(_mm256_mul_pd(t2, t2), _mm256_add_pd(_mm256_mul_pd(four, d), one));
            _mm256_storeu_pd(row + j, value);
        }
        for (; j < k; ++j)
        {
            row[j] = wendland_entry(px, py, pz, qx[j], qy[j], qz[j], inv_sigma, outside_squared);
        }
        for (; j < ld; ++j)
        {
            row[j] = 0.0;
        }
    }
}

// G[i0..i0+3][j0..j0+4NJ-1] += sum over rows of B[r][i] B[r][j]: 4 x NJ accumulators in
// registers, one broadcast per i and one load per j-vector per row.
template <std::size_t NJ>
MESHMARK_AVX2 void gram_tile(const double* B, std::size_t rows, std::size_t ld, std::size_t i0,
                             std::size_t j0, double* G)
{
    __m256d acc[4][NJ];
    for (std::size_t a = 0; a < 4; ++a)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            acc[a][v] = _mm256_loadu_pd(G + (i0 + static_cast<std::size_t>(a)) * ld + j0 +
                                        4 * static_cast<std::size_t>(v));
        }
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        const double* row = B + r * ld;
        __m256d bj[NJ];
        for (std::size_t v = 0; v < NJ; ++v)
        {
            bj[v] = _mm256_loadu_pd(row + j0 + 4 * static_cast<std::size_t>(v));
        }
        for (std::size_t a = 0; a < 4; ++a)
        {
            const __m256d bi = _mm256_broadcast_sd(row + i0 + static_cast<std::size_t>(a));
            for (std::size_t v = 0; v < NJ; ++v)
            {
                acc[a][v] = _mm256_fmadd_pd(bi, bj[v], acc[a][v]);
            }
        }
    }
    for (std::size_t a = 0; a < 4; ++a)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            _mm256_storeu_pd(
                G + (i0 + static_cast<std::size_t>(a)) * ld + j0 + 4 * static_cast<std::size_t>(v),
                acc[a][v]);
        }
    }
}

MESHMARK_AVX2 void gram(const double* B, std::size_t rows, std::size_t ld, double* G)
{
    // Every entry adds its rows in order, whatever the sub-blocking.
    for (std::size_t begin = 0; begin < rows; begin += kGramRows)
    {
        const std::size_t count = rows - begin < kGramRows ? rows - begin : kGramRows;
        const double* block = B + begin * ld;
        for (std::size_t i0 = 0; i0 < ld; i0 += 4)
        {
            const std::size_t j_end = i0 + 4;  // lower triangle, diagonal 4 x 4 tile included
            std::size_t j0 = 0;
            for (; j0 + 12 <= j_end; j0 += 12)
            {
                gram_tile<3>(block, count, ld, i0, j0, G);
            }
            if (j_end - j0 == 8)
            {
                gram_tile<2>(block, count, ld, i0, j0, G);
            }
            else if (j_end - j0 == 4)
            {
                gram_tile<1>(block, count, ld, i0, j0, G);
            }
        }
    }
}

// Sum of the 4 lanes in a fixed order: (l0 + l2) + (l1 + l3).
MESHMARK_AVX2 double lane_sum(__m256d v)
{
    const __m128d pair = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
    return _mm_cvtsd_f64(_mm_add_sd(pair, _mm_unpackhi_pd(pair, pair)));
}

// out[r][c0 + c] = B[r] . Mt[c0 + c] for W columns, 4 rows at a time (4W independent chains).
template <std::size_t W>
MESHMARK_AVX2 void multiply_columns(const double* B, std::size_t rows, std::size_t ld,
                                    const double* Mt, std::size_t w, std::size_t c0, double* out)
{
    std::size_t r = 0;
    for (; r + 4 <= rows; r += 4)
    {
        __m256d acc[4][W];
        for (std::size_t q = 0; q < 4; ++q)
        {
            for (std::size_t c = 0; c < W; ++c)
            {
                acc[q][c] = _mm256_setzero_pd();
            }
        }
        for (std::size_t j = 0; j < ld; j += 4)
        {
            __m256d m[W];
            for (std::size_t c = 0; c < W; ++c)
            {
                m[c] = _mm256_loadu_pd(Mt + (c0 + static_cast<std::size_t>(c)) * ld + j);
            }
            for (std::size_t q = 0; q < 4; ++q)
            {
                const __m256d b = _mm256_loadu_pd(B + (r + static_cast<std::size_t>(q)) * ld + j);
                for (std::size_t c = 0; c < W; ++c)
                {
                    acc[q][c] = _mm256_fmadd_pd(b, m[c], acc[q][c]);
                }
            }
        }
        for (std::size_t q = 0; q < 4; ++q)
        {
            for (std::size_t c = 0; c < W; ++c)
            {
                out[(r + static_cast<std::size_t>(q)) * w + c0 + static_cast<std::size_t>(c)] =
                    lane_sum(acc[q][c]);
            }
        }
    }
    for (; r < rows; ++r)
    {
        __m256d acc[W];
        for (std::size_t c = 0; c < W; ++c)
        {
            acc[c] = _mm256_setzero_pd();
        }
        for (std::size_t j = 0; j < ld; j += 4)
        {
            const __m256d b = _mm256_loadu_pd(B + r * ld + j);
            for (std::size_t c = 0; c < W; ++c)
            {
                acc[c] = _mm256_fmadd_pd(
                    b, _mm256_loadu_pd(Mt + (c0 + static_cast<std::size_t>(c)) * ld + j), acc[c]);
            }
        }
        for (std::size_t c = 0; c < W; ++c)
        {
            out[r * w + c0 + static_cast<std::size_t>(c)] = lane_sum(acc[c]);
        }
    }
}

MESHMARK_AVX2 void multiply(const double* B, std::size_t rows, std::size_t ld, const double* Mt,
                            std::size_t w, double* out)
{
    std::size_t c0 = 0;
    for (; c0 + 3 <= w; c0 += 3)
    {
        multiply_columns<3>(B, rows, ld, Mt, w, c0, out);
    }
    if (w - c0 == 2)
    {
        multiply_columns<2>(B, rows, ld, Mt, w, c0, out);
    }
    else if (w - c0 == 1)
    {
        multiply_columns<1>(B, rows, ld, Mt, w, c0, out);
    }
}

// acc[c0 + c][j0 .. j0 + 4NJ - 1] += sum over rows of X[r][c0 + c] B[r][j]: W x NJ registers.
template <std::size_t W, std::size_t NJ>
MESHMARK_AVX2 void accumulate_tile(const double* B, std::size_t rows, std::size_t ld,
                                   const double* X, std::size_t w, std::size_t c0, std::size_t j0,
                                   double* acc_out)
{
    __m256d acc[W][NJ];
    for (std::size_t c = 0; c < W; ++c)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            acc[c][v] = _mm256_loadu_pd(acc_out + (c0 + static_cast<std::size_t>(c)) * ld + j0 +
                                        4 * static_cast<std::size_t>(v));
        }
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        __m256d b[NJ];
        for (std::size_t v = 0; v < NJ; ++v)
        {
            b[v] = _mm256_loadu_pd(B + r * ld + j0 + 4 * static_cast<std::size_t>(v));
        }
        for (std::size_t c = 0; c < W; ++c)
        {
            const __m256d x = _mm256_broadcast_sd(X + r * w + c0 + static_cast<std::size_t>(c));
            for (std::size_t v = 0; v < NJ; ++v)
            {
                acc[c][v] = _mm256_fmadd_pd(x, b[v], acc[c][v]);
            }
        }
    }
    for (std::size_t c = 0; c < W; ++c)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            _mm256_storeu_pd(acc_out + (c0 + static_cast<std::size_t>(c)) * ld + j0 +
                                 4 * static_cast<std::size_t>(v),
                             acc[c][v]);
        }
    }
}

template <std::size_t W>
MESHMARK_AVX2 void accumulate_columns(const double* B, std::size_t rows, std::size_t ld,
                                      const double* X, std::size_t w, std::size_t c0, double* acc)
{
    std::size_t j0 = 0;
    for (; j0 + 12 <= ld; j0 += 12)
    {
        accumulate_tile<W, 3>(B, rows, ld, X, w, c0, j0, acc);
    }
    if (ld - j0 == 8)
    {
        accumulate_tile<W, 2>(B, rows, ld, X, w, c0, j0, acc);
    }
    else if (ld - j0 == 4)
    {
        accumulate_tile<W, 1>(B, rows, ld, X, w, c0, j0, acc);
    }
}

MESHMARK_AVX2 void accumulate(const double* B, std::size_t rows, std::size_t ld, const double* X,
                              std::size_t w, double* acc)
{
    std::size_t c0 = 0;
    for (; c0 + 3 <= w; c0 += 3)
    {
        accumulate_columns<3>(B, rows, ld, X, w, c0, acc);
    }
    if (w - c0 == 2)
    {
        accumulate_columns<2>(B, rows, ld, X, w, c0, acc);
    }
    else if (w - c0 == 1)
    {
        accumulate_columns<1>(B, rows, ld, X, w, c0, acc);
    }
}

constexpr BlockKernels kAvx2{"avx2-fma", evaluate, gram, multiply, accumulate};

}  // namespace

const BlockKernels* avx2_kernels() noexcept
{
    static const bool supported = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    return supported ? &kAvx2 : nullptr;
}

#else

const BlockKernels* avx2_kernels() noexcept
{
    return nullptr;
}

#endif

}  // namespace meshmark::detail

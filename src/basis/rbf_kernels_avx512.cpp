// SPDX-License-Identifier: MIT
// AVX-512 block kernels: the Gram update and the accumulation of rbf_kernels_avx2.cpp on 8-lane
// vectors (32 registers), compiled for that target only through function attributes, as
// there. Every entry of both products is one FMA chain over the rows in order, exactly as in
// the AVX2 kernels, so both sets give the same bits: switching between them changes speed,
// never a result (tested). The other two operations stay AVX2: the multiply sums 4-lane
// partial products (a lane structure 8 lanes would change), and an 8-lane evaluation was
// slower (fewer all-out-of-reach groups skip the square root, and the 8-lane square root is
// slow): measured with bench/perf at 1M vertices, 1 thread, basis pass 303 ms with the AVX2
// evaluation against 338 ms with the 8-lane one (AVX2 alone: 333 ms).
#include "basis/rbf_kernels.h"

#if defined(__x86_64__) && defined(__GNUC__)
#define MESHMARK_HAVE_AVX512_KERNELS 1
#include <immintrin.h>
#endif

namespace meshmark::detail
{

#ifdef MESHMARK_HAVE_AVX512_KERNELS
namespace
{

#define MESHMARK_AVX512 __attribute__((target("avx512f,avx2,fma")))

// As in the AVX2 kernels: 32 rows of ~100 doubles stay in L1 while every tile passes over them.
constexpr std::size_t kGramRows = 32;

// G[i0..i0+3][j0..j0+8NJ-1] += sum over rows of B[r][i] B[r][j]: 4 x NJ accumulators.
template <std::size_t NJ>
MESHMARK_AVX512 void gram_tile(const double* B, std::size_t rows, std::size_t ld, std::size_t i0,
                               std::size_t j0, double* G)
{
    __m512d acc[4][NJ];
    for (std::size_t a = 0; a < 4; ++a)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            acc[a][v] = _mm512_loadu_pd(G + (i0 + a) * ld + j0 + 8 * v);
        }
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        const double* row = B + r * ld;
        __m512d bj[NJ];
        for (std::size_t v = 0; v < NJ; ++v)
        {
            bj[v] = _mm512_loadu_pd(row + j0 + 8 * v);
        }
        for (std::size_t a = 0; a < 4; ++a)
        {
            const __m512d bi = _mm512_set1_pd(row[i0 + a]);
            for (std::size_t v = 0; v < NJ; ++v)
            {
                acc[a][v] = _mm512_fmadd_pd(bi, bj[v], acc[a][v]);
            }
        }
    }
    for (std::size_t a = 0; a < 4; ++a)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            _mm512_storeu_pd(G + (i0 + a) * ld + j0 + 8 * v, acc[a][v]);
        }
    }
}

// The 4 x 4 remainder of a tile row (ld is a multiple of 4, not always of 8).
MESHMARK_AVX512 void gram_tile4(const double* B, std::size_t rows, std::size_t ld, std::size_t i0,
                                std::size_t j0, double* G)
{
    __m256d acc[4];
    for (std::size_t a = 0; a < 4; ++a)
    {
        acc[a] = _mm256_loadu_pd(G + (i0 + a) * ld + j0);
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        const double* row = B + r * ld;
        const __m256d bj = _mm256_loadu_pd(row + j0);
        for (std::size_t a = 0; a < 4; ++a)
        {
            acc[a] = _mm256_fmadd_pd(_mm256_broadcast_sd(row + i0 + a), bj, acc[a]);
        }
    }
    for (std::size_t a = 0; a < 4; ++a)
    {
        _mm256_storeu_pd(G + (i0 + a) * ld + j0, acc[a]);
    }
}

MESHMARK_AVX512 void gram(const double* B, std::size_t rows, std::size_t ld, double* G)
{
    for (std::size_t begin = 0; begin < rows; begin += kGramRows)
    {
        const std::size_t count = rows - begin < kGramRows ? rows - begin : kGramRows;
        const double* block = B + begin * ld;
        for (std::size_t i0 = 0; i0 < ld; i0 += 4)
        {
            const std::size_t j_end = i0 + 4;  // lower triangle, diagonal 4 x 4 tile included
            std::size_t j0 = 0;
            for (; j0 + 24 <= j_end; j0 += 24)
            {
                gram_tile<3>(block, count, ld, i0, j0, G);
            }
            if (j_end - j0 >= 16)
            {
                gram_tile<2>(block, count, ld, i0, j0, G);
                j0 += 16;
            }
            if (j_end - j0 >= 8)
            {
                gram_tile<1>(block, count, ld, i0, j0, G);
                j0 += 8;
            }
            if (j_end - j0 == 4)
            {
                gram_tile4(block, count, ld, i0, j0, G);
            }
        }
    }
}

// acc[c0 + c][j0 .. j0 + 8NJ - 1] += sum over rows of X[r][c0 + c] B[r][j]: W x NJ registers.
template <std::size_t W, std::size_t NJ>
MESHMARK_AVX512 void accumulate_tile(const double* B, std::size_t rows, std::size_t ld,
                                     const double* X, std::size_t w, std::size_t c0, std::size_t j0,
                                     double* acc_out)
{
    __m512d acc[W][NJ];
    for (std::size_t c = 0; c < W; ++c)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            acc[c][v] = _mm512_loadu_pd(acc_out + (c0 + c) * ld + j0 + 8 * v);
        }
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        __m512d b[NJ];
        for (std::size_t v = 0; v < NJ; ++v)
        {
            b[v] = _mm512_loadu_pd(B + r * ld + j0 + 8 * v);
        }
        for (std::size_t c = 0; c < W; ++c)
        {
            const __m512d x = _mm512_set1_pd(X[r * w + c0 + c]);
            for (std::size_t v = 0; v < NJ; ++v)
            {
                acc[c][v] = _mm512_fmadd_pd(x, b[v], acc[c][v]);
            }
        }
    }
    for (std::size_t c = 0; c < W; ++c)
    {
        for (std::size_t v = 0; v < NJ; ++v)
        {
            _mm512_storeu_pd(acc_out + (c0 + c) * ld + j0 + 8 * v, acc[c][v]);
        }
    }
}

// The 4-wide remainder of the columns of B.
template <std::size_t W>
MESHMARK_AVX512 void accumulate_tile4(const double* B, std::size_t rows, std::size_t ld,
                                      const double* X, std::size_t w, std::size_t c0,
                                      std::size_t j0, double* acc_out)
{
    __m256d acc[W];
    for (std::size_t c = 0; c < W; ++c)
    {
        acc[c] = _mm256_loadu_pd(acc_out + (c0 + c) * ld + j0);
    }
    for (std::size_t r = 0; r < rows; ++r)
    {
        const __m256d b = _mm256_loadu_pd(B + r * ld + j0);
        for (std::size_t c = 0; c < W; ++c)
        {
            acc[c] = _mm256_fmadd_pd(_mm256_broadcast_sd(X + r * w + c0 + c), b, acc[c]);
        }
    }
    for (std::size_t c = 0; c < W; ++c)
    {
        _mm256_storeu_pd(acc_out + (c0 + c) * ld + j0, acc[c]);
    }
}

template <std::size_t W>
MESHMARK_AVX512 void accumulate_columns(const double* B, std::size_t rows, std::size_t ld,
                                        const double* X, std::size_t w, std::size_t c0, double* acc)
{
    std::size_t j0 = 0;
    for (; j0 + 24 <= ld; j0 += 24)
    {
        accumulate_tile<W, 3>(B, rows, ld, X, w, c0, j0, acc);
    }
    if (ld - j0 >= 16)
    {
        accumulate_tile<W, 2>(B, rows, ld, X, w, c0, j0, acc);
        j0 += 16;
    }
    if (ld - j0 >= 8)
    {
        accumulate_tile<W, 1>(B, rows, ld, X, w, c0, j0, acc);
        j0 += 8;
    }
    if (ld - j0 == 4)
    {
        accumulate_tile4<W>(B, rows, ld, X, w, c0, j0, acc);
    }
}

MESHMARK_AVX512 void accumulate(const double* B, std::size_t rows, std::size_t ld, const double* X,
                                std::size_t w, double* acc)
{
    if (w < 4)
    {
        // The synthesis's round-trip check (w = 3): 8 lanes gained nothing there and lost
        // ~10% of the synthesis pass (measured with BM_Synthesis); same bits either way.
        avx2_kernels()->accumulate(B, rows, ld, X, w, acc);
        return;
    }
    // Four design columns per pass: 12 of the 32 registers accumulate.
    std::size_t c0 = 0;
    for (; c0 + 4 <= w; c0 += 4)
    {
        accumulate_columns<4>(B, rows, ld, X, w, c0, acc);
    }
    switch (w - c0)
    {
        case 3:
            accumulate_columns<3>(B, rows, ld, X, w, c0, acc);
            break;
        case 2:
            accumulate_columns<2>(B, rows, ld, X, w, c0, acc);
            break;
        case 1:
            accumulate_columns<1>(B, rows, ld, X, w, c0, acc);
            break;
        default:
            break;
    }
}

}  // namespace

const BlockKernels* avx512_kernels() noexcept
{
    static const BlockKernels* const kernels = []() -> const BlockKernels*
    {
        const BlockKernels* avx2 = avx2_kernels();  // its multiply, and AVX2 + FMA themselves
        if (avx2 == nullptr || !__builtin_cpu_supports("avx512f"))
        {
            return nullptr;
        }
        static const BlockKernels set{"avx512", avx2->evaluate, gram, avx2->multiply, accumulate};
        return &set;
    }();
    return kernels;
}

#else

const BlockKernels* avx512_kernels() noexcept
{
    return nullptr;
}

#endif

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

namespace meshmark
{

/// \brief The worker-thread count for a `threads` option: \p requested when it is positive,
/// otherwise (0, "all cores") OpenMP's default team size, omp_get_max_threads().
/// \details That default honours the OMP_NUM_THREADS environment variable and the process's
/// CPU affinity mask, so `OMP_NUM_THREADS=2 meshmark ...` limits every parallel step, OpenMP
/// loops and std::thread workers alike, to two threads. Every `threads` option of the library
/// resolves 0 through this one function. Results are bit-identical for any thread count (each
/// parallel step has a fixed partition and reduction order), so this only changes speed.
/// \return At least 1.
[[nodiscard]] int resolve_threads(int requested);

}  // namespace meshmark

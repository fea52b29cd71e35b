// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <functional>

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

/// \brief Calls \p each(i) for every i in [0, \p count) on up to \p threads threads (the
/// calling one among them), handing the indices out one at a time in order: for items of
/// uneven cost (files, assets). Returns when every call has returned.
/// \details When a call throws, no further index is handed out, the calls running finish, and
/// the first exception is rethrown here.
void for_each_index(std::size_t count, int threads, const std::function<void(std::size_t)>& each);

}  // namespace meshmark

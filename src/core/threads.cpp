// SPDX-License-Identifier: MIT
#include "meshmark/core/threads.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include <omp.h>

namespace meshmark
{

int resolve_threads(int requested)
{
    return requested > 0 ? requested : std::max(1, omp_get_max_threads());
}

void for_each_index(std::size_t count, int threads, const std::function<void(std::size_t)>& each)
{
    std::atomic<std::size_t> next{0};
    std::exception_ptr failure;
    std::mutex failure_mutex;
    const auto work = [&]
    {
        for (std::size_t i = next++; i < count; i = next++)
        {
            try
            {
                each(i);
            }
            catch (...)
            {
                const std::lock_guard lock(failure_mutex);
                if (!failure)
                {
                    failure = std::current_exception();
                }
                next = count;
                return;
            }
        }
    };
    {
        std::vector<std::jthread> workers;
        const auto extra = std::min<std::size_t>(static_cast<std::size_t>(std::max(threads, 1)),
                                                 std::max<std::size_t>(count, 1)) -
                           1;
        for (std::size_t t = 0; t < extra; ++t)
        {
            workers.emplace_back(work);
        }
        work();
    }  // joins
    if (failure)
    {
        std::rethrow_exception(failure);
    }
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/core/threads.h"

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace meshmark
{

TEST(ResolveThreadsTest, a_positive_request_is_kept_and_zero_means_at_least_one)
{
    EXPECT_EQ(resolve_threads(1), 1);
    EXPECT_EQ(resolve_threads(7), 7);
    EXPECT_GE(resolve_threads(0), 1);
    EXPECT_EQ(resolve_threads(-1), resolve_threads(0));
}

}  // namespace meshmark

namespace meshmark
{

TEST(ForEachIndexTest, every_index_is_called_once_on_any_number_of_threads)
{
    for (const int threads : {1, 2, 5})
    {
        for (const std::size_t count : {std::size_t{0}, std::size_t{1}, std::size_t{1000}})
        {
            std::vector<std::atomic<int>> calls(count);
            std::mutex mutex;
            std::set<std::thread::id> ran_on;
            for_each_index(count, threads,
                           [&](std::size_t i)
                           {
                               ++calls[i];
                               const std::lock_guard lock(mutex);
                               ran_on.insert(std::this_thread::get_id());
                           });
            for (std::size_t i = 0; i < count; ++i)
            {
                EXPECT_EQ(calls[i].load(), 1) << "index " << i << ", " << threads << " threads";
            }
            EXPECT_LE(ran_on.size(), static_cast<std::size_t>(threads));
        }
    }
}

TEST(ForEachIndexTest, the_first_exception_is_rethrown_and_no_index_is_handed_out_after_it)
{
    std::atomic<std::size_t> calls{0};
    EXPECT_THROW(for_each_index(1'000'000, 2,
                                [&](std::size_t i)
                                {
                                    ++calls;
                                    if (i == 10)
                                    {
                                        throw std::runtime_error("index 10");
                                    }
                                }),
                 std::runtime_error);
    // The other thread goes on while the exception is thrown (microseconds, thousands of these
    // calls), then stops: far from all of them ran.
    EXPECT_LT(calls.load(), std::size_t{500'000});
}

}  // namespace meshmark

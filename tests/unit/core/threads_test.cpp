// SPDX-License-Identifier: MIT
#include "meshmark/core/threads.h"

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

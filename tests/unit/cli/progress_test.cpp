// SPDX-License-Identifier: MIT
#include "progress.h"

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"

namespace meshmark::cli
{
namespace
{

using Updates = std::vector<std::pair<std::string, double>>;

// What a PhaseProgress labelled "meshmark embed" that shows after \p delay seconds writes when
// fed \p updates and finished (twice: finish() is idempotent).
std::string shown(double delay, const Updates& updates)
{
    std::FILE* file = std::tmpfile();
    if (file == nullptr)
    {
        ADD_FAILURE() << "no temporary file";
        return {};
    }
    {
        PhaseProgress progress(PhaseProgressOptions{"meshmark embed", delay, 0.01, file});
        const auto callback = progress.callback();
        for (const auto& [phase, fraction] : updates)
        {
            callback(phase, fraction);
        }
        progress.finish();
        progress.finish();
    }
    std::fflush(file);
    std::rewind(file);
    std::string text;
    char buffer[256];
    std::size_t n = 0;
    while ((n = std::fread(buffer, 1, sizeof(buffer), file)) > 0)
    {
        text.append(buffer, n);
    }
    std::fclose(file);
    return text;
}

}  // namespace

TEST(PhaseProgressTest, shows_finished_phases_with_times_and_ends_the_line)
{
    const std::string text =
        shown(0.0, {{"read", 0.0}, {"read", 1.0}, {"basis", 0.0}, {"basis", 0.5}, {"basis", 1.0}});
    EXPECT_NE(text.find("meshmark embed:"), std::string::npos) << text;
    EXPECT_NE(text.find(" 50% "), std::string::npos) << text;
    const auto last = text.rfind('\r');
    ASSERT_NE(last, std::string::npos);
    const std::string final_line = text.substr(last);
    EXPECT_NE(final_line.find("meshmark embed: read 0.00 s | basis 0.00 s\n"), std::string::npos)
        << final_line;
    EXPECT_EQ(text.back(), '\n');
}

TEST(PhaseProgressTest, short_runs_print_nothing)
{
    EXPECT_TRUE(shown(30.0, {{"read", 0.0}, {"read", 1.0}}).empty());
    EXPECT_FALSE(PhaseProgress::should_show(true));
    EXPECT_THROW(PhaseProgress(PhaseProgressOptions{"x", -1.0, 0.1, stderr}), InvalidOption);
}

}  // namespace meshmark::cli

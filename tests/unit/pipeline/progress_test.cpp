// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "meshmark/core/error.h"

namespace meshmark {
namespace {

std::string contents(std::FILE* file)
{
    std::fflush(file);
    std::rewind(file);
    std::string text;
    char buffer[256];
    std::size_t n = 0;
    while ((n = std::fread(buffer, 1, sizeof(buffer), file)) > 0)
    {
        text.append(buffer, n);
    }
    return text;
}

}  // namespace

TEST(PhaseProgressTest, shows_finished_phases_with_times_and_ends_the_line)
{
    std::FILE* file = std::tmpfile();
    ASSERT_NE(file, nullptr);
    {
        PhaseProgress progress(PhaseProgressOptions{"meshmark embed", 0.0, 0.01, file});
        const auto callback = progress.callback();
        callback("read", 0.0);
        callback("read", 1.0);
        callback("basis", 0.0);
        callback("basis", 0.5);
        callback("basis", 1.0);
        progress.finish();
        progress.finish();  // idempotent
    }
    const std::string text = contents(file);
    std::fclose(file);
    EXPECT_NE(text.find("meshmark embed:"), std::string::npos) << text;
    EXPECT_NE(text.find(" 50% "), std::string::npos) << text;
    const auto last = text.rfind('\r');
    ASSERT_NE(last, std::string::npos);
    const std::string final_line = text.substr(last);
    EXPECT_NE(final_line.find("meshmark embed: read 0.00 s | basis 0.00 s\n"), std::string::npos) << final_line;
    EXPECT_EQ(text.back(), '\n');
}

TEST(PhaseProgressTest, short_runs_print_nothing)
{
    std::FILE* file = std::tmpfile();
    ASSERT_NE(file, nullptr);
    {
        PhaseProgress progress(PhaseProgressOptions{"meshmark embed", 30.0, 0.01, file});
        const auto callback = progress.callback();
        callback("read", 0.0);
        callback("read", 1.0);
    }
    EXPECT_TRUE(contents(file).empty());
    std::fclose(file);
    EXPECT_FALSE(PhaseProgress::should_show(true));
    EXPECT_THROW(PhaseProgress(PhaseProgressOptions{"x", -1.0, 0.1, stderr}), InvalidOption);
}

}  // namespace meshmark

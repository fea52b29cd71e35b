// SPDX-License-Identifier: MIT
// `meshmark demo`: the whole story passes and leaves a picture of the mark.
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>
#include <stb_image.h>
#include <sys/wait.h>

#include "support/test_paths.h"

namespace meshmark
{

TEST(DemoTest, demo_succeeds_and_draws_the_mark)
{
    if (test::cli_path().empty())
    {
        GTEST_SKIP() << "the CLI is not built";
    }
    const auto dir = test::temp_dir("demo");
    const std::string command = "\"" + test::cli_path().string() +
                                "\" demo --quiet --subdivisions 4 --threads 2 --dir \"" +
                                dir.string() + "\" > /dev/null 2>&1";
    const int status = std::system(command.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_EQ(WEXITSTATUS(status), 0);
    int w = 0;
    int h = 0;
    int channels = 0;
    unsigned char* data = stbi_load((dir / "heatmap.png").c_str(), &w, &h, &channels, 3);
    ASSERT_NE(data, nullptr) << stbi_failure_reason();
    EXPECT_EQ(w, 1024);
    EXPECT_EQ(h, 768);
    // The model covers a good part of the left three quarters, in more than one colour.
    int model = 0;
    int red = 0;
    int blue = 0;
    for (int y = 0; y < h; ++y)
    {
        for (int x = 0; x < 3 * w / 4; ++x)
        {
            const unsigned char* p = data + 3 * (static_cast<std::size_t>(y) * w + x);
            model += p[0] == 255 && p[1] == 255 && p[2] == 255 ? 0 : 1;
            red += p[0] > 120 && p[1] < p[0] / 2 && p[2] < p[0] / 3 ? 1 : 0;
            blue += p[2] > 100 && p[0] < p[2] / 3 && p[1] < p[2] / 2 ? 1 : 0;
        }
    }
    stbi_image_free(data);
    EXPECT_GT(model, w * h / 5);
    EXPECT_GT(red, 100);
    EXPECT_GT(blue, 100);

    // The demo's picture is `compare --heatmap` of its original and marked copy, byte for byte:
    // one quantity (each vertex's distance to the original surface), one scale, one legend.
    const std::string compare =
        "\"" + test::cli_path().string() + "\" compare \"" + (dir / "original.ply").string() +
        "\" \"" + (dir / "marked.ply").string() + "\" --heatmap \"" +
        (dir / "compare.png").string() + "\" --threads 2 -q > /dev/null 2>&1";
    const int compared = std::system(compare.c_str());
    ASSERT_TRUE(WIFEXITED(compared));
    ASSERT_EQ(WEXITSTATUS(compared), 0);
    EXPECT_EQ(test::file_bytes(dir / "compare.png"), test::file_bytes(dir / "heatmap.png"));
}

}  // namespace meshmark

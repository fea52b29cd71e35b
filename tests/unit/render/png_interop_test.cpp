// SPDX-License-Identifier: MIT
// The PNG pictures read by an independent decoder: Python's zlib and struct (check_png.py).
#include <cstdio>
#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/render/heatmap_image.h"
#include "support/test_paths.h"

namespace meshmark
{

TEST(PngInteropTest, python_reads_the_picture)
{
    if (std::system("python3 -c 'import zlib' > /dev/null 2>&1") != 0)
    {
        if (std::getenv("CI") != nullptr)
        {
            FAIL() << "python3 is missing";
        }
        GTEST_SKIP() << "python3 is missing";
    }
    const TriangleMesh sphere = icosphere(3);
    HeatmapImageOptions options;
    options.size = {320, 200};
    const HeatmapPicture picture =
        render_heatmap(sphere, Eigen::VectorXd(sphere.V.col(0).array().abs()), options);
    const auto path = test::temp_dir("png_interop") / "picture.png";
    write_png(path, picture.image);
    const std::string command =
        "python3 \"" MESHMARK_CHECK_PNG_SCRIPT "\" \"" + path.string() + "\" 2>&1";
    FILE* pipe = popen(command.c_str(), "r");
    ASSERT_NE(pipe, nullptr);
    std::string out;
    char buffer[256];
    while (std::fgets(buffer, sizeof buffer, pipe) != nullptr)
    {
        out += buffer;
    }
    EXPECT_EQ(pclose(pipe), 0) << out;
    EXPECT_EQ(out, "320x200\n");
}

}  // namespace meshmark

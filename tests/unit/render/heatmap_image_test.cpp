// SPDX-License-Identifier: MIT
#include "meshmark/render/heatmap_image.h"

#include <numbers>

#include <gtest/gtest.h>
#include <stb_image.h>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

bool is_background(Rgb8 c)
{
    return c == Rgb8{255, 255, 255};
}
bool is_reddish(Rgb8 c)
{
    return c[0] > 120 && c[1] < c[0] / 3 && c[2] < c[0] / 3;
}
bool is_bluish(Rgb8 c)
{
    return c[2] > 100 && c[0] < c[2] / 3 && c[1] < c[2] / 2;
}

struct Counts
{
    int model = 0;  // non-background pixels of the model area
    int red = 0;
    int blue = 0;
};

Counts count(const HeatmapPicture& p, int x0, int x1)
{
    Counts c;
    for (int y = 0; y < p.image.height; ++y)
    {
        for (int x = x0; x < x1; ++x)
        {
            const Rgb8 rgb = p.image.at(x, y);
            c.model += is_background(rgb) ? 0 : 1;
            c.red += is_reddish(rgb) ? 1 : 0;
            c.blue += is_bluish(rgb) ? 1 : 0;
        }
    }
    return c;
}

/// A unit sphere with distance 1 on the vertices with \p axis coordinate above 0.2, 0 elsewhere.
Eigen::VectorXd half_lit(const TriangleMesh& sphere, int axis)
{
    Eigen::VectorXd d(sphere.vertex_count());
    for (Eigen::Index i = 0; i < d.size(); ++i)
    {
        d[i] = sphere.V(i, axis) > 0.2 ? 1.0 : 0.0;
    }
    return d;
}

HeatmapImageOptions small(const char* view)
{
    HeatmapImageOptions o;
    o.size = {400, 300};
    o.view = parse_view(view);
    o.threads = 1;
    return o;
}

}  // namespace

TEST(HeatmapImageTest, picture_has_the_size_asked_and_a_colour_bar)
{
    const TriangleMesh sphere = icosphere(3);
    const HeatmapPicture p = render_heatmap(sphere, half_lit(sphere, 0), small("front"));
    EXPECT_EQ(p.image.width, 400);
    EXPECT_EQ(p.image.height, 300);
    EXPECT_EQ(p.image.pixels.size(), 400u * 300u * 3u);
    EXPECT_EQ(p.max_distance, 1.0);
    EXPECT_NEAR(p.unit_length, std::sqrt(12.0), 0.05);  // the sphere's box diagonal, 2 sqrt(3)
    // The bar: red at the top, blue at the bottom, green half way.
    const HeatmapLayout& l = p.layout;
    ASSERT_LT(l.bar_x0, l.bar_x1);
    ASSERT_LT(l.bar_y0, l.bar_y1);
    EXPECT_GE(l.bar_x0, l.model_width);
    EXPECT_LE(l.bar_x1, 400);
    const int mid_x = (l.bar_x0 + l.bar_x1) / 2;
    EXPECT_EQ(p.image.at(mid_x, l.bar_y0), (Rgb8{255, 0, 0}));
    EXPECT_EQ(p.image.at(mid_x, l.bar_y1 - 1), (Rgb8{0, 0, 255}));
    EXPECT_EQ(p.image.at(mid_x, (l.bar_y0 + l.bar_y1) / 2)[1], 255);
    // Labels: dark pixels to the right of the bar, and above it (the title).
    int ink_right = 0;
    int ink_above = 0;
    for (int y = 0; y < 300; ++y)
    {
        for (int x = l.bar_x1 + 4; x < 400; ++x)
        {
            ink_right += p.image.at(x, y)[0] < 100 && y >= l.bar_y0 - 8 ? 1 : 0;
        }
        for (int x = l.model_width; x < 400; ++x)
        {
            ink_above += p.image.at(x, y)[0] < 100 && y < l.bar_y0 - 4 ? 1 : 0;
        }
    }
    EXPECT_GT(ink_right, 50);
    EXPECT_GT(ink_above, 50);
}

TEST(HeatmapImageTest, model_fills_its_area_and_shows_the_displaced_side)
{
    const TriangleMesh sphere = icosphere(4);
    const HeatmapPicture p = render_heatmap(sphere, half_lit(sphere, 0), small("front"));
    const int w = p.layout.model_width;
    // A sphere fitted with 5% margins covers pi/4 * 0.9^2 of a square of the shorter side.
    const Counts all = count(p, 0, w);
    const double disc = std::numbers::pi / 4.0 * 0.81 * 300.0 * 300.0;
    EXPECT_NEAR(all.model, disc, 0.03 * disc);
    // Seen from the front, +X is to the right: red there, blue on the left.
    const Counts left = count(p, 0, w / 2);
    const Counts right = count(p, w / 2, w);
    EXPECT_EQ(left.red, 0);
    EXPECT_GT(left.blue, left.model / 2);
    EXPECT_GT(right.red, right.model / 3);
    // From the back, the sides swap.
    const HeatmapPicture back = render_heatmap(sphere, half_lit(sphere, 0), small("back"));
    EXPECT_GT(count(back, 0, w / 2).red, right.red / 2);
    EXPECT_EQ(count(back, w / 2, w).red, 0);
}

TEST(HeatmapImageTest, hidden_side_does_not_show_through)
{
    // Distance 1 on the back half (z < -0.2): from the front only blue, from the back red.
    const TriangleMesh sphere = icosphere(4);
    Eigen::VectorXd d(sphere.vertex_count());
    for (Eigen::Index i = 0; i < d.size(); ++i)
    {
        d[i] = sphere.V(i, 2) < -0.2 ? 1.0 : 0.0;
    }
    const HeatmapPicture front = render_heatmap(sphere, d, small("front"));
    const HeatmapPicture back = render_heatmap(sphere, d, small("back"));
    const int w = front.layout.model_width;
    EXPECT_EQ(count(front, 0, w).red, 0);
    EXPECT_GT(count(back, 0, w).red, count(back, 0, w).model / 2);
}

TEST(HeatmapImageTest, same_pixels_for_any_thread_count_and_run)
{
    const TriangleMesh torus_mesh = torus(1.0, 0.3, 48, 24);
    Eigen::VectorXd d = torus_mesh.V.col(1).array().abs();
    HeatmapImageOptions o = small("iso");
    const std::string one = encode_png(render_heatmap(torus_mesh, d, o).image);
    o.threads = 3;
    const std::string three = encode_png(render_heatmap(torus_mesh, d, o).image);
    const std::string again = encode_png(render_heatmap(torus_mesh, d, o).image);
    EXPECT_EQ(one, three);
    EXPECT_EQ(three, again);
    o.view = parse_view("top");
    EXPECT_NE(encode_png(render_heatmap(torus_mesh, d, o).image), one);
}

TEST(HeatmapImageTest, point_cloud_is_drawn_as_dots)
{
    TriangleMesh cloud = icosphere(4);
    cloud.F.resize(0, 3);
    const HeatmapPicture p = render_heatmap(cloud, half_lit(cloud, 0), small("front"));
    const int w = p.layout.model_width;
    const Counts all = count(p, 0, w);
    // Dots sized from the spacing cover most of the disc the sphere projects to.
    const double disc = std::numbers::pi / 4.0 * 0.81 * 300.0 * 300.0;
    EXPECT_GT(all.model, 0.5 * disc);
    EXPECT_LT(all.model, 1.1 * disc);
    EXPECT_EQ(count(p, 0, w / 2).red, 0);
    EXPECT_GT(count(p, w / 2, w).red, 0);
}

TEST(HeatmapImageTest, png_decodes_to_the_same_pixels)
{
    const TriangleMesh sphere = icosphere(3);
    const HeatmapPicture p = render_heatmap(sphere, half_lit(sphere, 1), small("front34"));
    const auto path = test::temp_dir("heatmap_png") / "picture.png";
    write_png(path, p.image);
    int w = 0;
    int h = 0;
    int channels = 0;
    unsigned char* data = stbi_load(path.c_str(), &w, &h, &channels, 3);
    ASSERT_NE(data, nullptr);
    EXPECT_EQ(w, 400);
    EXPECT_EQ(h, 300);
    EXPECT_EQ(channels, 3);
    EXPECT_TRUE(std::equal(p.image.pixels.begin(), p.image.pixels.end(), data));
    stbi_image_free(data);
}

TEST(HeatmapImageTest, bad_input_is_refused)
{
    const TriangleMesh sphere = icosphere(2);
    EXPECT_THROW((void)render_heatmap(sphere, Eigen::VectorXd::Zero(3)), InvalidOption);
    HeatmapImageOptions o;
    o.size = {100, 768};
    EXPECT_THROW((void)render_heatmap(sphere, Eigen::VectorXd::Zero(sphere.vertex_count()), o),
                 InvalidOption);
    o = {};
    o.supersampling = 9;
    EXPECT_THROW((void)render_heatmap(sphere, Eigen::VectorXd::Zero(sphere.vertex_count()), o),
                 InvalidOption);
    EXPECT_THROW((void)render_heatmap(TriangleMesh{}, Eigen::VectorXd{}), InvalidMesh);
    // Nothing is left behind when the folder cannot be made (a file is in the way); a missing
    // folder is created.
    const auto dir = test::temp_dir("heatmap_missing");
    write_png(dir / "no", RgbImage(2, 2, {0, 0, 0}));
    EXPECT_THROW(write_png(dir / "no" / "picture.png", RgbImage(200, 200, {0, 0, 0})), IoError);
    EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
    write_png(dir / "new" / "picture.png", RgbImage(2, 2, {0, 0, 0}));
    EXPECT_TRUE(std::filesystem::exists(dir / "new" / "picture.png"));
}

TEST(HeatmapImageTest, all_zero_distances_are_blue)
{
    const TriangleMesh sphere = icosphere(3);
    const HeatmapPicture p =
        render_heatmap(sphere, Eigen::VectorXd::Zero(sphere.vertex_count()), small("front"));
    EXPECT_EQ(p.max_distance, 0.0);
    const Counts c = count(p, 0, p.layout.model_width);
    EXPECT_EQ(c.red, 0);
    EXPECT_GT(c.blue, c.model * 9 / 10);
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/render/view.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "meshmark/core/error.h"

namespace meshmark
{

TEST(ViewTest, named_and_numeric_views)
{
    EXPECT_EQ(parse_view("front").azimuth_deg, 0.0);
    EXPECT_EQ(parse_view("back").azimuth_deg, 180.0);
    EXPECT_EQ(parse_view("right").azimuth_deg, 90.0);
    EXPECT_EQ(parse_view("top").elevation_deg, 90.0);
    EXPECT_EQ(parse_view("front34").azimuth_deg, kDefaultView.azimuth_deg);
    EXPECT_NEAR(parse_view("iso").elevation_deg, 35.264, 1e-3);
    const ViewAngles v = parse_view("-120.5,15");
    EXPECT_EQ(v.azimuth_deg, -120.5);
    EXPECT_EQ(v.elevation_deg, 15.0);
    EXPECT_THROW((void)parse_view("sideways"), InvalidOption);
    EXPECT_THROW((void)parse_view("30,"), InvalidOption);
    EXPECT_THROW((void)parse_view("30,95"), InvalidOption);
    EXPECT_THROW((void)parse_view("nan,0"), InvalidOption);
    try
    {
        (void)parse_view("sideways");
    }
    catch (const InvalidOption& e)
    {
        EXPECT_NE(std::string(e.what()).find("'sideways'"), std::string::npos);
        EXPECT_NE(std::string(e.what()).find("iso"), std::string::npos);
    }
}

TEST(ViewTest, frames_are_orthonormal_and_follow_the_convention)
{
    const ViewFrame front = view_frame(parse_view("front"));
    EXPECT_TRUE(front.toward.isApprox(Eigen::Vector3d::UnitZ()));
    EXPECT_TRUE(front.right.isApprox(Eigen::Vector3d::UnitX()));
    EXPECT_TRUE(front.up.isApprox(Eigen::Vector3d::UnitY()));
    const ViewFrame right = view_frame(parse_view("right"));
    EXPECT_TRUE(right.toward.isApprox(Eigen::Vector3d::UnitX()));
    const ViewFrame top = view_frame(parse_view("top"));
    EXPECT_TRUE(top.toward.isApprox(Eigen::Vector3d::UnitY()));
    EXPECT_TRUE(top.up.isApprox(-Eigen::Vector3d::UnitZ()));  // the back of the model at the top
    for (const char* name : {"front34", "iso", "bottom", "left", "back", "33,-71"})
    {
        const ViewFrame f = view_frame(parse_view(name));
        EXPECT_NEAR(f.right.norm(), 1.0, 1e-12) << name;
        EXPECT_NEAR(f.up.norm(), 1.0, 1e-12) << name;
        EXPECT_NEAR(f.right.dot(f.up), 0.0, 1e-12) << name;
        EXPECT_NEAR(f.right.dot(f.toward), 0.0, 1e-12) << name;
        EXPECT_NEAR(f.right.cross(f.up).dot(f.toward), 1.0, 1e-12) << name;  // right-handed
    }
}

// The up axis turns the whole camera: with +Z up the front view looks along +Y (the model's
// front faces -Y, as in Blender), the image's up is +Z and its right +X.
TEST(ViewTest, up_axis_turns_the_camera)
{
    EXPECT_EQ(parse_up_axis("y"), UpAxis::PosY);
    EXPECT_EQ(parse_up_axis("+z"), UpAxis::PosZ);
    EXPECT_EQ(parse_up_axis("-x"), UpAxis::NegX);
    EXPECT_THROW((void)parse_up_axis("w"), InvalidOption);
    EXPECT_THROW((void)parse_up_axis(""), InvalidOption);
    const ViewFrame z = view_frame(parse_view("front"), UpAxis::PosZ);
    EXPECT_TRUE(z.toward.isApprox(Eigen::Vector3d(0, -1, 0), 1e-12));
    EXPECT_TRUE(z.up.isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
    EXPECT_TRUE(z.right.isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
    const ViewFrame top = view_frame(parse_view("top"), UpAxis::PosZ);
    EXPECT_TRUE(top.toward.isApprox(Eigen::Vector3d(0, 0, 1), 1e-12));
    // Every axis: a right-handed orthonormal frame whose image-up leans towards that axis.
    for (const char* name : {"y", "z", "x", "-y", "-z", "-x"})
    {
        const UpAxis up = parse_up_axis(name);
        const ViewFrame f = view_frame(kDefaultView, up);
        EXPECT_NEAR(f.right.cross(f.up).dot(f.toward), 1.0, 1e-12) << name;
        EXPECT_NEAR(f.right.norm(), 1.0, 1e-12) << name;
        EXPECT_NEAR(f.up.dot(f.toward), 0.0, 1e-12) << name;
        const ViewFrame front = view_frame(parse_view("front"), up);
        const Eigen::Vector3d axis = front.up;
        EXPECT_NEAR(axis.cwiseAbs().maxCoeff(), 1.0, 1e-12) << name;  // exactly the up axis
    }
    EXPECT_TRUE(view_frame(parse_view("front"), UpAxis::NegZ)
                    .up.isApprox(Eigen::Vector3d(0, 0, -1), 1e-12));
    EXPECT_TRUE(
        view_frame(parse_view("front"), UpAxis::PosX).up.isApprox(Eigen::Vector3d(1, 0, 0), 1e-12));
}

TEST(ViewTest, image_sizes)
{
    const ImageSize s = parse_image_size("640x480");
    EXPECT_EQ(s.width, 640);
    EXPECT_EQ(s.height, 480);
    EXPECT_EQ(parse_image_size("8192X160").width, 8192);
    EXPECT_THROW((void)parse_image_size("100x100"), InvalidOption);
    EXPECT_THROW((void)parse_image_size("640x9000"), InvalidOption);
    EXPECT_THROW((void)parse_image_size("640"), InvalidOption);
    EXPECT_THROW((void)parse_image_size("640x480px"), InvalidOption);
}

}  // namespace meshmark

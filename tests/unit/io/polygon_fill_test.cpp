// SPDX-License-Identifier: MIT
// Polygons that are not convex: the OBJ, OFF and PLY readers triangulate them inside their
// outline (a fan from the first corner lays triangles outside it: an artist's headphones read
// with 2.3x their area).
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

using Point2 = std::array<double, 2>;

/// A point of the plane z = x / 2 (tilted: the readers project each polygon into its plane).
std::array<double, 3> lifted(const Point2& p)
{
    return {p[0], p[1], 0.5 * p[0]};
}

/// The same polygon written as an OBJ, an OFF and an ASCII PLY file of one face each.
std::vector<std::filesystem::path> write_polygon(const std::filesystem::path& folder,
                                                 const std::vector<Point2>& outline,
                                                 const std::vector<int>& corners)
{
    std::ostringstream positions;
    positions.precision(17);
    for (const Point2& p : outline)
    {
        const auto q = lifted(p);
        positions << q[0] << ' ' << q[1] << ' ' << q[2] << '\n';
    }
    std::ostringstream obj;
    std::ostringstream off;
    std::ostringstream ply;
    std::ostringstream face;
    for (const int c : corners)
    {
        face << ' ' << c;
    }
    std::istringstream lines(positions.str());
    for (std::string line; std::getline(lines, line);)
    {
        obj << "v " << line << '\n';
    }
    obj << 'f';
    for (const int c : corners)
    {
        obj << ' ' << c + 1;
    }
    obj << '\n';
    off << "OFF\n"
        << outline.size() << " 1 0\n"
        << positions.str() << corners.size() << face.str() << '\n';
    ply << "ply\nformat ascii 1.0\nelement vertex " << outline.size()
        << "\nproperty double x\nproperty double y\nproperty double z\nelement face 1\n"
           "property list uchar int vertex_indices\nend_header\n"
        << positions.str() << corners.size() << face.str() << '\n';
    std::vector<std::filesystem::path> files = {folder / "polygon.obj", folder / "polygon.off",
                                                folder / "polygon.ply"};
    test::put_bytes(files[0], obj.str());
    test::put_bytes(files[1], off.str());
    test::put_bytes(files[2], ply.str());
    return files;
}

/// Signed area of a triangle of the plane z = x / 2, seen along the plane's normal.
double signed_area(const TriangleMesh& mesh, Eigen::Index t)
{
    const Eigen::RowVector3d a = mesh.V.row(mesh.F(t, 0));
    const Eigen::RowVector3d b = mesh.V.row(mesh.F(t, 1));
    const Eigen::RowVector3d c = mesh.V.row(mesh.F(t, 2));
    const Eigen::RowVector3d normal = Eigen::RowVector3d(-0.5, 0.0, 1.0).normalized();
    return 0.5 * (b - a).cross(c - a).dot(normal);
}

/// Every triangle faces the polygon's way, and together they cover its area exactly.
void expect_tiles(const TriangleMesh& mesh, std::size_t triangles, double area)
{
    ASSERT_EQ(static_cast<std::size_t>(mesh.F.rows()), triangles);
    const double tilt = std::sqrt(1.25);  // area in the plane / area seen from +z
    double covered = 0.0;
    for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
    {
        EXPECT_GT(signed_area(mesh, t), 0.0) << "triangle " << t << " is flipped or flat";
        covered += signed_area(mesh, t);
    }
    EXPECT_NEAR(covered, area * tilt, 1e-9);
}

}  // namespace

TEST(PolygonFillTest, a_concave_polygon_is_triangulated_inside_its_outline_by_every_reader)
{
    // An L of area 3 whose first corner is the inner one: its fan's first triangle fills the
    // notch, outside the L.
    const std::vector<Point2> l_shape = {{2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}};
    const auto folder = test::temp_dir("polygon_fill_l");
    for (const auto& file : write_polygon(folder, l_shape, {0, 1, 2, 3, 4, 5}))
    {
        SCOPED_TRACE(file.filename().string());
        const TriangleMesh mesh = read_mesh(file);
        expect_tiles(mesh, 4, 3.0);
        for (Eigen::Index t = 0; t < mesh.F.rows(); ++t)
        {
            const Eigen::RowVector3d centroid =
                (mesh.V.row(mesh.F(t, 0)) + mesh.V.row(mesh.F(t, 1)) + mesh.V.row(mesh.F(t, 2))) /
                3.0;
            EXPECT_FALSE(centroid.x() > 1.0 && centroid.y() > 1.0)
                << "triangle " << t << " in the notch";
        }
    }
}

TEST(PolygonFillTest, every_reader_keeps_each_polygon_and_its_outline_is_its_adjacency)
{
    // The L again (triangulated inside its outline) and a convex hexagon (its fan): either
    // way the polygon's rows are kept, and the neighbours along the file's edges are its two
    // neighbours on the outline, not the triangles' inner edges.
    const std::vector<Point2> l_shape = {{2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}, {2, 0}};
    const std::vector<Point2> hexagon = {{2, 1}, {1.5, 2}, {0.5, 2}, {0, 1}, {0.5, 0}, {1.5, 0}};
    for (const auto& outline : {l_shape, hexagon})
    {
        const auto folder = test::temp_dir("polygon_fill_outline");
        for (const auto& file : write_polygon(folder, outline, {0, 1, 2, 3, 4, 5}))
        {
            SCOPED_TRACE(file.filename().string());
            const TriangleMesh mesh = read_mesh(file);
            ASSERT_EQ(mesh.polygons.size(), 1U);
            EXPECT_EQ(mesh.polygons[0].first, 0);
            EXPECT_EQ(mesh.polygons[0].corners, 6);
            const VertexAdjacency outline_adjacency = polygon_adjacency(mesh);
            for (std::int32_t v = 0; v < 6; ++v)
            {
                const auto row = outline_adjacency.of(static_cast<std::size_t>(v));
                const std::vector<std::int32_t> expected = {std::min((v + 5) % 6, (v + 1) % 6),
                                                            std::max((v + 5) % 6, (v + 1) % 6)};
                EXPECT_EQ(std::vector<std::int32_t>(row.begin(), row.end()), expected)
                    << "vertex " << v;
            }
            // The triangles' own adjacency has the inner edges too.
            EXPECT_GT(vertex_adjacency(mesh).neighbors.size(), outline_adjacency.neighbors.size());
        }
    }
}

TEST(PolygonFillTest, a_polygon_with_a_bridged_hole_is_triangulated_around_the_hole)
{
    // A 4 x 4 square with a 2 x 2 hole, one outline joined by a bridge walked both ways (as CAD
    // exporters write faces with holes): corners 0 and 4 repeat.
    const std::vector<Point2> points = {{0, 0}, {4, 0}, {4, 4}, {0, 4},
                                        {1, 1}, {1, 3}, {3, 3}, {3, 1}};
    const auto folder = test::temp_dir("polygon_fill_hole");
    for (const auto& file : write_polygon(folder, points, {0, 1, 2, 3, 0, 4, 5, 6, 7, 4}))
    {
        SCOPED_TRACE(file.filename().string());
        const TriangleMesh mesh = read_mesh(file);
        expect_tiles(mesh, 8, 12.0);
    }
}

TEST(PolygonFillTest, a_many_cornered_concave_polygon_is_tiled_exactly)
{
    // A 40-pointed star (a gear's outline) starting at an inner corner.
    std::vector<Point2> star;
    std::vector<int> corners;
    double area = 0.0;
    constexpr int kCorners = 80;
    for (int k = 0; k < kCorners; ++k)
    {
        const double angle = 2.0 * M_PI * k / kCorners;
        const double radius = k % 2 == 0 ? 1.0 : 3.0;
        star.push_back({radius * std::cos(angle), radius * std::sin(angle)});
        corners.push_back(k);
    }
    for (int k = 0; k < kCorners; ++k)
    {
        const Point2& a = star[static_cast<std::size_t>(k)];
        const Point2& b = star[static_cast<std::size_t>((k + 1) % kCorners)];
        area += 0.5 * (a[0] * b[1] - a[1] * b[0]);
    }
    const auto folder = test::temp_dir("polygon_fill_star");
    for (const auto& file : write_polygon(folder, star, corners))
    {
        SCOPED_TRACE(file.filename().string());
        expect_tiles(read_mesh(file), kCorners - 2, area);
    }
}

TEST(PolygonFillTest, an_outline_that_crosses_itself_keeps_its_fan)
{
    // Two sides cross the first one: no triangulation on the corners alone exists.
    const std::vector<Point2> crossed = {{0, 0},  {4, 0},  {4, 3}, {2, 3},
                                         {2, -1}, {1, -1}, {1, 2}, {0, 2}};
    const auto folder = test::temp_dir("polygon_fill_crossed");
    for (const auto& file : write_polygon(folder, crossed, {0, 1, 2, 3, 4, 5, 6, 7}))
    {
        SCOPED_TRACE(file.filename().string());
        const TriangleMesh mesh = read_mesh(file);
        ASSERT_EQ(mesh.F.rows(), 6);
        for (int k = 0; k < 6; ++k)
        {
            EXPECT_EQ(mesh.F(k, 0), 0);
            EXPECT_EQ(mesh.F(k, 1), k + 1);
            EXPECT_EQ(mesh.F(k, 2), k + 2);
        }
    }
}

}  // namespace meshmark

namespace meshmark
{

TEST(PolygonFillTest, a_concave_polygon_with_a_non_finite_corner_is_refused_not_triangulated)
{
    // The OBJ reader checks the positions after the triangles are made: the triangulation must
    // leave such a polygon alone (CGAL on infinite points is undefined).
    const auto folder = test::temp_dir("polygon_fill_infinite");
    for (const char* bad : {"inf", "nan", "1e300"})
    {
        SCOPED_TRACE(bad);
        const auto path = folder / "bad.obj";
        test::put_bytes(path, std::string("v 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 ") + bad +
                                  "\nv 2 0 0\nf 1 2 3 4 5 6\n");
        if (std::string(bad) == "1e300")
        {
            // Finite, but its products overflow: read, not refused.
            EXPECT_EQ(read_mesh(path).F.rows(), 4);
        }
        else
        {
            test::expect_error<InvalidMesh>([&] { (void)read_mesh(path); }, {"non-finite"});
        }
    }
}

}  // namespace meshmark

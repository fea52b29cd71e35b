// SPDX-License-Identifier: MIT
// The library facade (meshmark.h) reading copies of originals made of polygons: a polygon's
// triangles depend on where its corners stand (a concave one is triangulated inside its
// outline, a convex one is its fan), so a copy whose vertices a tool moved may be read with
// other triangles over the same polygons.
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/geometry/shapes.h"
#include "meshmark/meshmark.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

using Quad = std::array<std::int32_t, 4>;

constexpr int kRings = 48;
constexpr int kSides = 24;

// The torus' grid cells as quads, corners in turn as torus() numbers its vertices.
std::vector<Quad> torus_quads()
{
    const auto index = [](int i, int j)
    { return static_cast<std::int32_t>((i % kRings) * kSides + (j % kSides)); };
    std::vector<Quad> quads;
    for (int i = 0; i < kRings; ++i)
    {
        for (int j = 0; j < kSides; ++j)
        {
            quads.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)});
        }
    }
    return quads;
}

void write_text(const fs::path& path, const std::string& text)
{
    std::ofstream out(path, std::ios::binary);
    out << text;
    ASSERT_TRUE(out.good()) << path;
}

void write_obj(const fs::path& path, const Positions& V, const std::vector<Quad>& quads)
{
    std::ostringstream obj;
    obj.precision(17);
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        obj << "v " << V(i, 0) << ' ' << V(i, 1) << ' ' << V(i, 2) << '\n';
    }
    for (const Quad& q : quads)
    {
        obj << "f " << q[0] + 1 << ' ' << q[1] + 1 << ' ' << q[2] + 1 << ' ' << q[3] + 1 << '\n';
    }
    write_text(path, obj.str());
}

// As Blender's PLY writer writes a mesh: the polygons as they are, the vertices numbered in the
// order the polygons first use them.
void write_ply_renumbered(const fs::path& path, const Positions& V, const std::vector<Quad>& quads)
{
    std::vector<std::int32_t> number(static_cast<std::size_t>(V.rows()), -1);
    std::vector<std::int32_t> order;
    for (const Quad& q : quads)
    {
        for (const std::int32_t v : q)
        {
            if (number[static_cast<std::size_t>(v)] < 0)
            {
                number[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(order.size());
                order.push_back(v);
            }
        }
    }
    std::ostringstream ply;
    ply.precision(17);
    ply << "ply\nformat ascii 1.0\nelement vertex " << order.size()
        << "\nproperty double x\nproperty double y\nproperty double z\nelement face "
        << quads.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (const std::int32_t v : order)
    {
        ply << V(v, 0) << ' ' << V(v, 1) << ' ' << V(v, 2) << '\n';
    }
    for (const Quad& q : quads)
    {
        ply << "4";
        for (const std::int32_t v : q)
        {
            ply << ' ' << number[static_cast<std::size_t>(v)];
        }
        ply << '\n';
    }
    write_text(path, ply.str());
}

// Each vertex moved \p factor of the way to the mean of its neighbours along the polygons'
// sides, \p repeats times: Blender's Smooth modifier with twice that factor (it moves a vertex
// its factor of the way to the mean of its sides' midpoints; measured on an artists' bus,
// bench/results/2026-12-02-smoothed-polygons.md).
Positions smoothed(const Positions& V, const std::vector<Quad>& quads, double factor, int repeats)
{
    std::vector<std::vector<std::int32_t>> neighbours(static_cast<std::size_t>(V.rows()));
    for (const Quad& q : quads)
    {
        for (std::size_t k = 0; k < 4; ++k)
        {
            neighbours[static_cast<std::size_t>(q[k])].push_back(q[(k + 1) % 4]);
            neighbours[static_cast<std::size_t>(q[(k + 1) % 4])].push_back(q[k]);
        }
    }
    Positions out = V;
    for (int r = 0; r < repeats; ++r)
    {
        const Positions before = out;
        for (Eigen::Index i = 0; i < V.rows(); ++i)
        {
            Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
            for (const std::int32_t n : neighbours[static_cast<std::size_t>(i)])
            {
                mean += before.row(n);
            }
            mean /= static_cast<double>(neighbours[static_cast<std::size_t>(i)].size());
            out.row(i) = before.row(i) + factor * (mean - before.row(i));
        }
    }
    return out;
}

// \p suspect (in \p dir, beside original.obj and key.json) read in the original's order, and
// claimed when \p is_marked, else not.
void expect_read_in_order(const fs::path& dir, const std::string& suspect, bool is_marked)
{
    const DetectReport found =
        detect_file(dir / suspect, dir / "original.obj", dir / "key.json", {});
    EXPECT_EQ(found.correspondence, Correspondence::InOrder) << suspect;
    EXPECT_EQ(found.decision.is_present, is_marked) << suspect << ": z " << found.decision.score;
}

}  // namespace

// A torus of quads where every 16th cell is a dart: its first corner pushed past the cell's
// other diagonal, each such quad written from its second corner (whose fan lays a triangle in
// the notch), so the reader triangulates it inside its outline. The marked copy, smoothed as
// Blender's Smooth 1.0 x 5 does (the darts become convex again: their fans are kept) and
// written as Blender's PLY writer numbers the vertices, has other triangles over those quads;
// their fans are the original's, so it is still read vertex for vertex.
TEST(FacadeTest, a_smoothed_copy_of_concave_polygons_is_read_by_its_polygons_fans)
{
    const fs::path dir = test::temp_dir("facade-polygon-fans");
    Positions V = torus(1.0, 0.35, kRings, kSides).V;
    std::vector<Quad> quads = torus_quads();
    int darts = 0;
    for (Quad& q : quads)
    {
        const int i = q[0] / kSides;
        const int j = q[0] % kSides;
        if (i % 4 == 0 && j % 4 == 0)
        {
            V.row(q[0]) += 0.6 * (V.row(q[2]) - V.row(q[0]));  // past the diagonal q1-q3
            q = {q[1], q[2], q[3], q[0]};
            ++darts;
        }
    }
    ASSERT_EQ(darts, (kRings / 4) * (kSides / 4));
    write_obj(dir / "original.obj", V, quads);
    const TriangleMesh original = read_mesh(dir / "original.obj");
    ASSERT_EQ(original.fans.size(), 2 * static_cast<std::size_t>(darts));

    EmbedFileOptions embed;
    embed.seed = 11;
    (void)embed_file(dir / "original.obj", dir / "marked.obj", dir / "key.json", embed);
    const Positions copy = smoothed(read_mesh(dir / "marked.obj").V, quads, 0.5, 5);
    write_ply_renumbered(dir / "suspect.ply", copy, quads);
    const TriangleMesh suspect = read_mesh(dir / "suspect.ply");
    ASSERT_LT(suspect.fans.size(), original.fans.size()) << "the smoothing left the darts";

    expect_read_in_order(dir, "suspect.ply", true);

    // The same steps on the never-marked original: read in order, not claimed.
    write_ply_renumbered(dir / "unmarked.ply", smoothed(V, quads, 0.5, 5), quads);
    expect_read_in_order(dir, "unmarked.ply", false);
}

// A torus of quads whose cells are uneven (corners moved along the surface by up to 0.3 of a
// cell, the tube's radius varying by 30%), marked, and smoothed as Blender's Smooth 0.5 x 30
// does: along the quads' sides only. The triangles' Laplacian has each quad's diagonal too and
// leaves much of that change unexplained (z 3.46 without the polygons' Laplacian); the
// polygons' own Laplacian explains it.
TEST(FacadeTest, a_copy_smoothed_along_its_polygons_sides_is_read_with_their_laplacian)
{
    const fs::path dir = test::temp_dir("facade-polygon-smooth");
    std::mt19937 random(3);
    std::uniform_real_distribution<double> jitter(-0.3, 0.3);
    Positions V(kRings * kSides, 3);
    for (int i = 0; i < kRings; ++i)
    {
        for (int j = 0; j < kSides; ++j)
        {
            const double u = 2.0 * std::numbers::pi * (i + jitter(random)) / kRings;
            const double v = 2.0 * std::numbers::pi * (j + jitter(random)) / kSides;
            const double tube = 0.35 * (1.0 + 0.3 * std::sin(3.0 * u) * std::cos(2.0 * v));
            V.row(i * kSides + j) << (1.0 + tube * std::cos(v)) * std::cos(u),
                (1.0 + tube * std::cos(v)) * std::sin(u), tube * std::sin(v);
        }
    }
    const std::vector<Quad> quads = torus_quads();
    write_obj(dir / "original.obj", V, quads);
    ASSERT_EQ(read_mesh(dir / "original.obj").polygons.size(), quads.size());

    EmbedFileOptions embed;
    embed.seed = 5;
    (void)embed_file(dir / "original.obj", dir / "marked.obj", dir / "key.json", embed);
    write_obj(dir / "suspect.obj", smoothed(read_mesh(dir / "marked.obj").V, quads, 0.25, 30),
              quads);
    expect_read_in_order(dir, "suspect.obj", true);

    write_obj(dir / "unmarked.obj", smoothed(V, quads, 0.25, 30), quads);
    expect_read_in_order(dir, "unmarked.obj", false);
}

}  // namespace meshmark

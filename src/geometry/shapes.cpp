// SPDX-License-Identifier: MIT
#include "meshmark/geometry/shapes.h"

#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

using Vec3 = Eigen::Vector3d;

// Midpoint subdivision of a triangle list with a shared-edge cache, projected on the unit sphere.
void subdivide_on_sphere(std::vector<Vec3>& vertices,
                         std::vector<std::array<std::int32_t, 3>>& faces)
{
    std::map<std::pair<std::int32_t, std::int32_t>, std::int32_t> midpoint;
    auto middle = [&](std::int32_t a, std::int32_t b)
    {
        const auto key = std::minmax(a, b);
        const auto it = midpoint.find(key);
        if (it != midpoint.end())
        {
            return it->second;
        }
        const auto index = static_cast<std::int32_t>(vertices.size());
        vertices.push_back(
            (vertices[static_cast<std::size_t>(a)] + vertices[static_cast<std::size_t>(b)])
                .normalized());
        midpoint.emplace(key, index);
        return index;
    };
    std::vector<std::array<std::int32_t, 3>> next;
    next.reserve(faces.size() * 4);
    for (const auto& f : faces)
    {
        const auto ab = middle(f[0], f[1]);
        const auto bc = middle(f[1], f[2]);
        const auto ca = middle(f[2], f[0]);
        next.push_back({f[0], ab, ca});
        next.push_back({f[1], bc, ab});
        next.push_back({f[2], ca, bc});
        next.push_back({ab, bc, ca});
    }
    faces = std::move(next);
}

TriangleMesh to_mesh(const std::vector<Vec3>& vertices,
                     const std::vector<std::array<std::int32_t, 3>>& faces)
{
    TriangleMesh mesh;
    mesh.V.resize(static_cast<Eigen::Index>(vertices.size()), 3);
    for (std::size_t i = 0; i < vertices.size(); ++i)
    {
        mesh.V.row(static_cast<Eigen::Index>(i)) = vertices[i].transpose();
    }
    mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t f = 0; f < faces.size(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            mesh.F(static_cast<Eigen::Index>(f), c) = faces[f][static_cast<std::size_t>(c)];
        }
    }
    return mesh;
}

}  // namespace

TriangleMesh icosphere(int subdivisions)
{
    if (subdivisions < 0 || subdivisions > 10)
    {
        throw InvalidOption("icosphere: subdivisions = " + std::to_string(subdivisions) +
                            " is outside 0..10.");
    }
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<Vec3> vertices = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                  {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                  {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    for (auto& v : vertices)
    {
        v.normalize();
    }
    std::vector<std::array<std::int32_t, 3>> faces = {
        {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
        {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
    for (int s = 0; s < subdivisions; ++s)
    {
        subdivide_on_sphere(vertices, faces);
    }
    return to_mesh(vertices, faces);
}

TriangleMesh torus(double R, double r, int rings, int sides)
{
    if (!(r > 0.0 && r < R) || rings < 3 || sides < 3)
    {
        throw InvalidOption("torus: need 0 < r < R and rings, sides >= 3.");
    }
    std::vector<Vec3> vertices;
    std::vector<std::array<std::int32_t, 3>> faces;
    for (int i = 0; i < rings; ++i)
    {
        const double u = 2.0 * std::numbers::pi * i / rings;
        for (int j = 0; j < sides; ++j)
        {
            const double v = 2.0 * std::numbers::pi * j / sides;
            vertices.emplace_back((R + r * std::cos(v)) * std::cos(u),
                                  (R + r * std::cos(v)) * std::sin(u), r * std::sin(v));
        }
    }
    auto index = [&](int i, int j)
    { return static_cast<std::int32_t>((i % rings) * sides + (j % sides)); };
    for (int i = 0; i < rings; ++i)
    {
        for (int j = 0; j < sides; ++j)
        {
            faces.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
            faces.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
        }
    }
    return to_mesh(vertices, faces);
}

TriangleMesh plane_grid(int nx, int ny)
{
    if (nx < 1 || ny < 1)
    {
        throw InvalidOption("plane_grid: need nx, ny >= 1.");
    }
    std::vector<Vec3> vertices;
    std::vector<std::array<std::int32_t, 3>> faces;
    for (int j = 0; j <= ny; ++j)
    {
        for (int i = 0; i <= nx; ++i)
        {
            vertices.emplace_back(static_cast<double>(i) / nx, static_cast<double>(j) / ny, 0.0);
        }
    }
    auto index = [&](int i, int j) { return static_cast<std::int32_t>(j * (nx + 1) + i); };
    for (int j = 0; j < ny; ++j)
    {
        for (int i = 0; i < nx; ++i)
        {
            faces.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
            faces.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
        }
    }
    return to_mesh(vertices, faces);
}

TriangleMesh lumpy_ellipsoid(int subdivisions)
{
    TriangleMesh mesh = icosphere(subdivisions);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const Vec3 p = mesh.V.row(i).transpose();
        // Smooth bumps: low-order products of sines keep the surface smooth and asymmetric.
        const double bump = 1.0 + 0.12 * std::sin(3.0 * p.x() + 1.0) * std::cos(2.0 * p.y() - 0.5) +
                            0.08 * std::sin(5.0 * p.z() + 2.0 * p.x());
        mesh.V.row(i) = Eigen::RowVector3d(1.0 * p.x(), 0.7 * p.y(), 0.45 * p.z()) * bump;
    }
    return mesh;
}

}  // namespace meshmark

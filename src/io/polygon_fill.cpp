// SPDX-License-Identifier: MIT
// Polygons that are not convex, triangulated inside their outline (fill_polygons).
//
// The triangulation is CGAL's constrained Delaunay triangulation in the polygon's plane, with
// exact predicates: artists' outlines carry collinear runs, repeated points and near-touching
// corners, which an ear clipper written with floating-point orientation tests gets wrong.
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include "detail/support.h"

namespace meshmark::detail
{
namespace
{

/// Which corner of the polygon a vertex of the triangulation is (-1: a point CGAL added where
/// two sides cross).
struct Corner
{
    std::int32_t k = -1;
};

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<Corner, Kernel>;
using FaceBase = CGAL::Constrained_triangulation_face_base_2<Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;
using Point2 = std::array<double, 2>;

/// Above this, a polygon that is not convex keeps its fan: telling which triangles lie inside
/// costs corners x triangles (8,192 corners: ~0.1 s).
constexpr std::uint32_t kMaxFilledCorners = 8192;

/// The polygon's corners in its own plane, counterclockwise; false when it has no area.
bool project(const double* xyz, const std::vector<std::int32_t>& corners,
             std::vector<Point2>& plane, double& area)
{
    const auto at = [xyz](std::int32_t v) { return xyz + 3 * static_cast<std::size_t>(v); };
    const double* o = at(corners[0]);
    // Newell's normal: twice the vector area, well defined for non-planar outlines too.
    double n[3] = {0.0, 0.0, 0.0};
    const std::size_t count = corners.size();
    for (std::size_t i = 0; i < count; ++i)
    {
        const double* p = at(corners[i]);
        const double* q = at(corners[(i + 1) % count]);
        const double a[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
        const double b[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]};
        n[0] += a[1] * b[2] - a[2] * b[1];
        n[1] += a[2] * b[0] - a[0] * b[2];
        n[2] += a[0] * b[1] - a[1] * b[0];
    }
    const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(length > 0.0))
    {
        return false;
    }
    for (double& c : n)
    {
        c /= length;
    }
    // u: the axis least aligned with n, made perpendicular; v = n x u, so (u, v, n) is
    // right-handed and the outline runs counterclockwise in (u, v).
    int axis = 0;
    for (int d = 1; d < 3; ++d)
    {
        axis = std::abs(n[d]) < std::abs(n[axis]) ? d : axis;
    }
    double u[3] = {-n[axis] * n[0], -n[axis] * n[1], -n[axis] * n[2]};
    u[axis] += 1.0;
    const double u_length = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (double& c : u)
    {
        c /= u_length;
    }
    const double v[3] = {n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2],
                         n[0] * u[1] - n[1] * u[0]};
    plane.resize(count);
    for (std::size_t i = 0; i < count; ++i)
    {
        const double* p = at(corners[i]);
        const double d[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
        plane[i] = {d[0] * u[0] + d[1] * u[1] + d[2] * u[2],
                    d[0] * v[0] + d[1] * v[1] + d[2] * v[2]};
    }
    area = 0.5 * length;
    return true;
}

double cross(const Point2& a, const Point2& b, const Point2& c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/// No corner turns clockwise (beyond rounding): the fan from any corner lies inside.
bool is_convex(const std::vector<Point2>& plane, double area)
{
    const double tolerance = 1e-12 * area;
    const std::size_t count = plane.size();
    for (std::size_t i = 0; i < count; ++i)
    {
        if (cross(plane[(i + count - 1) % count], plane[i], plane[(i + 1) % count]) < -tolerance)
        {
            return false;
        }
    }
    return true;
}

/// Winding number of the outline around \p p.
int winding(const std::vector<Point2>& plane, const Point2& p)
{
    int w = 0;
    const std::size_t count = plane.size();
    for (std::size_t i = 0; i < count; ++i)
    {
        const Point2& a = plane[i];
        const Point2& b = plane[(i + 1) % count];
        if (a[1] <= p[1])
        {
            w += b[1] > p[1] && cross(a, b, p) > 0.0 ? 1 : 0;
        }
        else
        {
            w -= b[1] <= p[1] && cross(a, b, p) < 0.0 ? 1 : 0;
        }
    }
    return w;
}

/// The n - 2 triangles (corner numbers, counterclockwise) inside the outline, or none when
/// the triangulation needs points of its own or does not cover the polygon's area.
bool triangulate(const std::vector<Point2>& plane, double area, Cdt& cdt,
                 std::vector<std::array<std::int32_t, 3>>& out)
{
    cdt.clear();
    out.clear();
    const std::size_t count = plane.size();
    std::vector<Cdt::Vertex_handle> handles(count);
    for (std::size_t i = 0; i < count; ++i)
    {
        handles[i] = cdt.insert(Cdt::Point(plane[i][0], plane[i][1]));
        if (handles[i]->info().k < 0)  // a repeated point keeps its first corner
        {
            handles[i]->info().k = static_cast<std::int32_t>(i);
        }
    }
    for (std::size_t i = 0; i < count; ++i)
    {
        if (handles[i] != handles[(i + 1) % count])
        {
            cdt.insert_constraint(handles[i], handles[(i + 1) % count]);
        }
    }
    for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v)
    {
        if (v->info().k < 0)
        {
            return false;  // sides cross: no triangulation on the corners alone
        }
    }
    double covered = 0.0;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f)
    {
        std::array<Point2, 3> p;
        std::array<std::int32_t, 3> k{};
        for (int j = 0; j < 3; ++j)
        {
            k[static_cast<std::size_t>(j)] = f->vertex(j)->info().k;
            p[static_cast<std::size_t>(j)] =
                plane[static_cast<std::size_t>(k[static_cast<std::size_t>(j)])];
        }
        const Point2 centroid = {(p[0][0] + p[1][0] + p[2][0]) / 3.0,
                                 (p[0][1] + p[1][1] + p[2][1]) / 3.0};
        if (winding(plane, centroid) != 0)
        {
            out.push_back(k);
            covered += 0.5 * cross(p[0], p[1], p[2]);
        }
    }
    return out.size() + 2 == count && std::abs(covered - area) <= 1e-6 * area;
}

}  // namespace

void fill_polygons(const double* xyz, TriangleBuffer& triangles)
{
    Cdt cdt;
    std::vector<std::int32_t> corners;
    std::vector<Point2> plane;
    std::vector<std::array<std::int32_t, 3>> inside;
    for (const TriangleBuffer::Polygon& polygon : triangles.polygons())
    {
        // The fan (c0, ck, ck+1) holds the corners: c0 and each triangle's second, then the last
        // triangle's third.
        const std::size_t fan = polygon.corners - 2;
        corners.resize(polygon.corners);
        corners[0] = triangles.triangle(polygon.first)[0];
        for (std::size_t t = 0; t < fan; ++t)
        {
            corners[t + 1] = triangles.triangle(polygon.first + t)[1];
        }
        corners[polygon.corners - 1] = triangles.triangle(polygon.first + fan - 1)[2];
        double area = 0.0;
        if (!project(xyz, corners, plane, area) || is_convex(plane, area) ||
            polygon.corners > kMaxFilledCorners || !triangulate(plane, area, cdt, inside))
        {
            continue;
        }
        for (std::size_t t = 0; t < fan; ++t)
        {
            std::int32_t* triangle = triangles.triangle(polygon.first + t);
            for (std::size_t j = 0; j < 3; ++j)
            {
                triangle[j] = corners[static_cast<std::size_t>(inside[t][j])];
            }
        }
    }
}

}  // namespace meshmark::detail

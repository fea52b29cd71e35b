// SPDX-License-Identifier: MIT
// Polygons that are not convex, triangulated inside their outline (fill_polygons).
//
// The triangulation is CGAL's constrained Delaunay triangulation in the polygon's plane, with
// exact predicates: artists' outlines carry collinear runs, repeated points and near-touching
// corners, which an ear clipper written with floating-point orientation tests gets wrong.
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_2.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>
#include <CGAL/property_map.h>
#include <CGAL/spatial_sort.h>

#include "io/detail/support.h"

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
/// The outline's winding number around a face of the triangulation (kUnset: not reached yet).
struct Winding
{
    static constexpr int kUnset = std::numeric_limits<int>::min();
    int w = kUnset;
};

using FaceBase =
    CGAL::Triangulation_face_base_with_info_2<Winding, Kernel,
                                              CGAL::Constrained_triangulation_face_base_2<Kernel>>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;
using Point2 = std::array<double, 2>;

using Vec3 = std::array<double, 3>;

Vec3 minus(const double* p, const double* q)
{
    return {p[0] - q[0], p[1] - q[1], p[2] - q[2]};
}

Vec3 cross(const Vec3& a, const Vec3& b)
{
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dot(const Vec3& a, const Vec3& b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/// \brief Twice the vector area of the polygon (Newell's normal, the sum of its fan triangles'
/// normals), and whether its fan from corner 0 lies inside it.
/// \details The fan's signed areas (along the normal) add up to the polygon's; when none is
/// negative or flat, they cover each point as often as the outline winds around it: once,
/// inside a simple outline (convex, or concave but seen whole from corner 0).
Vec3 fan_normal(const double* xyz, const std::vector<std::int32_t>& corners,
                std::vector<Vec3>& normals, bool& fan_is_inside)
{
    const auto at = [xyz](std::int32_t v) { return xyz + 3 * static_cast<std::size_t>(v); };
    const double* o = at(corners[0]);
    const std::size_t fan = corners.size() - 2;
    normals.resize(fan);
    Vec3 normal = {0.0, 0.0, 0.0};
    for (std::size_t t = 0; t < fan; ++t)
    {
        normals[t] = cross(minus(at(corners[t + 1]), o), minus(at(corners[t + 2]), o));
        normal = {normal[0] + normals[t][0], normal[1] + normals[t][1], normal[2] + normals[t][2]};
    }
    const double length = std::sqrt(dot(normal, normal));
    fan_is_inside = length > 0.0;
    for (std::size_t t = 0; t < fan && fan_is_inside; ++t)
    {
        // Flat: within rounding of 0 (a corner on the line through two others).
        fan_is_inside =
            dot(normals[t], normal) > 1e-9 * std::sqrt(dot(normals[t], normals[t])) * length;
    }
    return normal;
}

/// The polygon's corners in the plane normal to \p normal (its fan_normal, not zero),
/// counterclockwise.
void project(const double* xyz, const std::vector<std::int32_t>& corners, const Vec3& normal,
             std::vector<Point2>& plane)
{
    const double length = std::sqrt(dot(normal, normal));
    const Vec3 n = {normal[0] / length, normal[1] / length, normal[2] / length};
    // u: the axis least aligned with n, made perpendicular; v = n x u, so (u, v, n) is
    // right-handed and the outline runs counterclockwise in (u, v).
    std::size_t axis = 0;
    for (std::size_t d = 1; d < 3; ++d)
    {
        axis = std::abs(n[d]) < std::abs(n[axis]) ? d : axis;
    }
    Vec3 u = {-n[axis] * n[0], -n[axis] * n[1], -n[axis] * n[2]};
    u[axis] += 1.0;
    const double u_length = std::sqrt(dot(u, u));
    u = {u[0] / u_length, u[1] / u_length, u[2] / u_length};
    const Vec3 v = cross(n, u);
    const double* o = xyz + 3 * static_cast<std::size_t>(corners[0]);
    plane.resize(corners.size());
    for (std::size_t i = 0; i < corners.size(); ++i)
    {
        const Vec3 d = minus(xyz + 3 * static_cast<std::size_t>(corners[i]), o);
        plane[i] = {dot(d, u), dot(d, v)};
    }
}

double cross(const Point2& a, const Point2& b, const Point2& c)
{
    return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

/// Key of the directed side from corner \p a to corner \p b.
std::uint64_t side_key(std::int32_t a, std::int32_t b)
{
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32U) |
           static_cast<std::uint32_t>(b);
}

/// The n - 2 triangles (corner numbers, counterclockwise) inside the outline, or none when
/// the triangulation needs points of its own or does not cover the polygon's area.
/// \details Inside is where the outline winds around a point (nonzero rule: a bridge walked both
/// ways to a hole cancels out). The winding number is carried from the outer faces across the
/// triangulation: crossing a side from its left to its right lowers it by one, once per time
/// the outline walks that side in that direction.
bool triangulate(const std::vector<Point2>& plane, double area, Cdt& cdt,
                 std::vector<std::array<std::int32_t, 3>>& out)
{
    cdt.clear();
    out.clear();
    const std::size_t count = plane.size();
    // Inserted in CGAL's spatial order (a shuffle, then Hilbert curves by rounds; the shuffle's
    // generator is a local one with a fixed seed, so a file reads the same every time), each
    // located from the one before. In outline order, or along a Hilbert curve alone, an outline
    // running along a circle costs n^2 flips (100,000 corners: 12 s or 0.7 s instead of 0.14 s).
    std::vector<Cdt::Point> points(count);
    std::vector<std::size_t> order(count);
    for (std::size_t i = 0; i < count; ++i)
    {
        points[i] = Cdt::Point(plane[i][0], plane[i][1]);
        order[i] = i;
    }
    using SortTraits =
        CGAL::Spatial_sort_traits_adapter_2<Kernel, CGAL::Pointer_property_map<Cdt::Point>::type>;
    CGAL::spatial_sort(order.begin(), order.end(), SortTraits(CGAL::make_property_map(points)));
    std::vector<Cdt::Vertex_handle> handles(count);
    Cdt::Face_handle hint;
    for (const std::size_t i : order)
    {
        handles[i] = cdt.insert(points[i], hint);
        if (handles[i]->info().k < 0)  // a repeated point keeps the corner inserted first
        {
            handles[i]->info().k = static_cast<std::int32_t>(i);
        }
        hint = handles[i]->face();
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
    // How many times the outline walks each side one way minus the other.
    std::unordered_map<std::uint64_t, int> walked;
    walked.reserve(2 * count);
    for (std::size_t i = 0; i < count; ++i)
    {
        const Cdt::Vertex_handle a = handles[i];
        const Cdt::Vertex_handle b = handles[(i + 1) % count];
        if (a == b)
        {
            continue;
        }
        if (!cdt.is_edge(a, b))
        {
            return false;  // a corner lies on another side, which the triangulation split
        }
        ++walked[side_key(a->info().k, b->info().k)];
        --walked[side_key(b->info().k, a->info().k)];
    }
    std::vector<Cdt::Face_handle> stack;
    for (auto f = cdt.all_faces_begin(); f != cdt.all_faces_end(); ++f)
    {
        if (cdt.is_infinite(f))
        {
            f->info().w = 0;
            stack.push_back(f);
        }
    }
    while (!stack.empty())
    {
        const Cdt::Face_handle f = stack.back();
        stack.pop_back();
        for (int i = 0; i < 3; ++i)
        {
            const Cdt::Face_handle g = f->neighbor(i);
            if (g->info().w != Winding::kUnset)
            {
                continue;
            }
            // f is on the left of the side p -> q opposite its vertex i.
            const Cdt::Vertex_handle p = f->vertex(Cdt::ccw(i));
            const Cdt::Vertex_handle q = f->vertex(Cdt::cw(i));
            int change = 0;
            if (!cdt.is_infinite(p) && !cdt.is_infinite(q))
            {
                const auto side = walked.find(side_key(p->info().k, q->info().k));
                change = side == walked.end() ? 0 : side->second;
            }
            g->info().w = f->info().w - change;
            stack.push_back(g);
        }
    }
    double covered = 0.0;
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f)
    {
        if (f->info().w == 0)
        {
            continue;
        }
        std::array<std::int32_t, 3> k{};
        for (std::size_t j = 0; j < 3; ++j)
        {
            k[j] = f->vertex(static_cast<int>(j))->info().k;
        }
        out.push_back(k);
        covered += 0.5 * cross(plane[static_cast<std::size_t>(k[0])],
                               plane[static_cast<std::size_t>(k[1])],
                               plane[static_cast<std::size_t>(k[2])]);
    }
    return out.size() + 2 == count && std::abs(covered - area) <= 1e-6 * area;
}

}  // namespace

void fill_polygons(const double* xyz, TriangleBuffer& triangles)
{
    Cdt cdt;
    std::vector<std::int32_t> corners;
    std::vector<Point2> plane;
    std::vector<Vec3> normals;
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
        bool fan_is_inside = false;
        const Vec3 normal = fan_normal(xyz, corners, normals, fan_is_inside);
        const double area = 0.5 * std::sqrt(dot(normal, normal));
        if (fan_is_inside || !(area > 0.0) || !std::isfinite(area))  // NaN, infinity: refused later
        {
            continue;
        }
        project(xyz, corners, normal, plane);
        if (!triangulate(plane, area, cdt, inside))
        {
            continue;
        }
        for (std::size_t t = 0; t < fan; ++t)
        {
            std::int32_t* triangle = triangles.triangle(polygon.first + t);
            triangles.keep_fan(polygon.first + t, triangle[0], triangle[1], triangle[2]);
            for (std::size_t j = 0; j < 3; ++j)
            {
                triangle[j] = corners[static_cast<std::size_t>(inside[t][j])];
            }
        }
    }
}

}  // namespace meshmark::detail

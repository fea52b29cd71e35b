// SPDX-License-Identifier: MIT
#pragma once

#include <algorithm>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace meshmark
{

/// \brief A triangle given by its three corners.
struct TriangleCorners
{
    Eigen::Vector3d a;
    Eigen::Vector3d b;
    Eigen::Vector3d c;
};

/// \brief A triangle given by its corner a and its edges from a (ab = b - a, ac = c - a),
/// computed once: the form a search structure stores, so that queries do not redo them.
struct TriangleEdges
{
    Eigen::Vector3d a;
    Eigen::Vector3d ab;
    Eigen::Vector3d ac;
};

/// \brief True when the triangle (\p a, \p b, \p c) is degenerate or nearly so: its smallest
/// altitude is at most 1e-3 of its longest edge (zero area included). Such a triangle needs
/// `is_sliver = true` in closest_point_on_triangle() for an exact answer.
[[nodiscard]] inline bool is_sliver_triangle(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                             const Eigen::Vector3d& c)
{
    constexpr double kSliverAltitude = 1e-3;  // chosen by hand; no study on record
    const Eigen::Vector3d ab = b - a;
    const Eigen::Vector3d ac = c - a;
    const double longest2 = std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
    // (2 area)^2 <= (altitude * longest)^2, with altitude = kSliverAltitude * longest.
    const double twice_area2 = ab.cross(ac).squaredNorm();
    return twice_area2 <= kSliverAltitude * kSliverAltitude * longest2 * longest2;
}

namespace triangle_detail
{

// What the closest-point walk needs of a triangle, in each of the two forms: its edges from a,
// its corner k (1 = b, 2 = c) given the edge from a to it, and p minus that corner given
// ap = p - a. Each form keeps its own rounding (p - b, or (p - a) - ab): sharing the walk does
// not change the answers of either.
inline Eigen::Vector3d edge_ab(const TriangleCorners& t)
{
    return t.b - t.a;
}
inline Eigen::Vector3d edge_ac(const TriangleCorners& t)
{
    return t.c - t.a;
}
inline Eigen::Vector3d corner(const TriangleCorners& t, int k, const Eigen::Vector3d& /*edge*/)
{
    return k == 1 ? t.b : t.c;
}
inline Eigen::Vector3d from_corner(const TriangleCorners& t, int k, const Eigen::Vector3d& p,
                                   const Eigen::Vector3d& /*ap*/, const Eigen::Vector3d& edge)
{
    return p - corner(t, k, edge);
}

inline const Eigen::Vector3d& edge_ab(const TriangleEdges& t)
{
    return t.ab;
}
inline const Eigen::Vector3d& edge_ac(const TriangleEdges& t)
{
    return t.ac;
}
inline Eigen::Vector3d corner(const TriangleEdges& t, int /*k*/, const Eigen::Vector3d& edge)
{
    return t.a + edge;
}
inline Eigen::Vector3d from_corner(const TriangleEdges& /*t*/, int /*k*/,
                                   const Eigen::Vector3d& /*p*/, const Eigen::Vector3d& ap,
                                   const Eigen::Vector3d& edge)
{
    return ap - edge;
}

/// Edge from b to c, as each form computes it (c - b, or ac - ab).
inline Eigen::Vector3d edge_bc(const TriangleCorners& t, const Eigen::Vector3d& /*ab*/,
                               const Eigen::Vector3d& /*ac*/)
{
    return t.c - t.b;
}
inline Eigen::Vector3d edge_bc(const TriangleEdges& /*t*/, const Eigen::Vector3d& ab,
                               const Eigen::Vector3d& ac)
{
    return ac - ab;
}

/// Closest point to \p p on the segment a + t d, t in [0, 1] (d may be zero).
[[nodiscard]] inline Eigen::Vector3d closest_on_segment(const Eigen::Vector3d& p,
                                                        const Eigen::Vector3d& a,
                                                        const Eigen::Vector3d& d)
{
    const double dd = d.squaredNorm();
    if (dd <= 0.0)
    {
        return a;
    }
    const double t = std::clamp(d.dot(p - a) / dd, 0.0, 1.0);
    return a + t * d;
}

/// num / den clamped to [0, 1]; 0 when den is zero (an edge of zero length).
[[nodiscard]] inline double ratio(double num, double den)
{
    return den > 0.0 ? std::clamp(num / den, 0.0, 1.0) : 0.0;
}

/// The regions of corner k (1 = b, 2 = c) and of the edge from a to it, tested in that order.
/// \p edge: from a to the corner; \p own_a, \p other_a: that edge and the other one dotted
/// with p - a; \p own_k, \p other_k: the same dotted with p minus the corner. Sets \p v to the
/// barycentric numerator of the other corner, and \p answer when p lies in one of the regions.
template <class Triangle>
[[gnu::always_inline]] inline bool in_corner_regions(const Triangle& t, int k,
                                                     const Eigen::Vector3d& edge, double own_a,
                                                     double other_a, double own_k, double other_k,
                                                     double& v, Eigen::Vector3d& answer)
{
    if (own_k >= 0.0 && other_k <= own_k)
    {
        answer = corner(t, k, edge);  // vertex region
        return true;
    }
    v = own_a * other_k - own_k * other_a;
    if (v <= 0.0 && own_a >= 0.0 && own_k <= 0.0)
    {
        answer = t.a + ratio(own_a, own_a - own_k) * edge;  // edge from a
        return true;
    }
    return false;
}

/// Closest point by Voronoi regions [Ericson 2005, Real-Time Collision Detection, 5.1.5]:
/// exact for proper triangles, but its region tests can pick the wrong feature when the
/// triangle is degenerate (collinear corners, a zero-length edge).
// Inlined into the callers' query loops: called once per triangle visited, it is the hot path
// of the closest-point queries.
template <class Triangle>
[[nodiscard, gnu::always_inline]] inline Eigen::Vector3d closest_by_regions(
    const Eigen::Vector3d& p, const Triangle& t)
{
    const Eigen::Vector3d ab = edge_ab(t);
    const Eigen::Vector3d ac = edge_ac(t);
    const Eigen::Vector3d ap = p - t.a;
    const double d1 = ab.dot(ap);
    const double d2 = ac.dot(ap);
    if (d1 <= 0.0 && d2 <= 0.0)
    {
        return t.a;  // vertex region a
    }
    Eigen::Vector3d answer;
    const Eigen::Vector3d bp = from_corner(t, 1, p, ap, ab);
    const double d3 = ab.dot(bp);
    const double d4 = ac.dot(bp);
    double vc = 0.0;
    if (in_corner_regions(t, 1, ab, d1, d2, d3, d4, vc, answer))
    {
        return answer;  // vertex region b or edge ab
    }
    const Eigen::Vector3d cp = from_corner(t, 2, p, ap, ac);
    const double d5 = ab.dot(cp);
    const double d6 = ac.dot(cp);
    double vb = 0.0;  // d2 d5 - d6 d1
    if (in_corner_regions(t, 2, ac, d2, d1, d6, d5, vb, answer))
    {
        return answer;  // vertex region c or edge ac
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0)
    {
        return corner(t, 1, ab) +
               ratio(d4 - d3, (d4 - d3) + (d5 - d6)) * edge_bc(t, ab, ac);  // edge bc
    }
    const double sum = va + vb + vc;
    if (!(sum > 0.0))
    {
        return t.a;  // only reachable for degenerate triangles (see closest_point_on_triangle)
    }
    return t.a + (vb / sum) * ab + (vc / sum) * ac;  // interior
}

}  // namespace triangle_detail

/// \brief Closest point to \p p on the triangle \p t (TriangleCorners or TriangleEdges).
/// \details Walks the Voronoi regions of the corners and edges [Ericson 2005, Real-Time
/// Collision Detection, 5.1.5], which is exact for a proper triangle. On a degenerate triangle
/// (collinear corners, a zero-length edge) the region tests can pick the wrong feature: with
/// \p is_sliver (is_sliver_triangle(), computed once per triangle by the caller) the nearest of
/// the region answer and the three edges' answers is taken, which is exact as well (both are
/// points of the triangle, and the edges cover a degenerate one). Without it the answer on a
/// degenerate triangle is a point of the triangle, not necessarily the closest. The two forms
/// of a triangle round differently in the last bits (see TriangleEdges); each form gives the
/// same bits for the same inputs on every call.
template <class Triangle>
[[nodiscard, gnu::always_inline]] inline Eigen::Vector3d closest_point_on_triangle(
    const Eigen::Vector3d& p, const Triangle& t, bool is_sliver = false)
{
    using namespace triangle_detail;
    Eigen::Vector3d best = closest_by_regions(p, t);
    if (!is_sliver)
    {
        return best;
    }
    const Eigen::Vector3d ab = edge_ab(t);
    const Eigen::Vector3d ac = edge_ac(t);
    double best2 = (best - p).squaredNorm();
    for (const Eigen::Vector3d& q : {closest_on_segment(p, t.a, ab), closest_on_segment(p, t.a, ac),
                                     closest_on_segment(p, corner(t, 1, ab), edge_bc(t, ab, ac))})
    {
        const double q2 = (q - p).squaredNorm();
        if (q2 < best2)
        {
            best = q;
            best2 = q2;
        }
    }
    return best;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "registration/detail/surface_matcher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/Geometry>
#include <omp.h>

#include "meshmark/core/error.h"
#include "meshmark/core/median.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/point_triangle.h"

namespace meshmark
{

namespace
{

struct FacePoint
{
    Eigen::Vector3d point;
    std::int32_t face;
};

// Median edge length over at most 100,000 evenly spaced faces.
double median_edge(const TriangleMesh& mesh)
{
    const auto faces = static_cast<std::size_t>(mesh.F.rows());
    const std::size_t step = std::max<std::size_t>(1, faces / 100000);
    std::vector<double> lengths;
    for (std::size_t f = 0; f < faces; f += step)
    {
        for (int c = 0; c < 3; ++c)
        {
            lengths.push_back((mesh.V.row(mesh.F(static_cast<Eigen::Index>(f), c)) -
                               mesh.V.row(mesh.F(static_cast<Eigen::Index>(f), (c + 1) % 3)))
                                  .norm());
        }
    }
    return median_in_place(lengths);
}

// Points inside the triangles much larger than the mesh's typical edge: a barycentric lattice
// about one typical edge apart (k = ceil(longest edge / spacing) steps per side, corners left
// out), at most \p budget points in all (the spacing grows until they fit). Without them the
// kd-tree knows only the vertices, and on a mesh of large flat faces beside dense parts (a
// game vehicle: 96 vertices for its body, 5,120 in its tyres) the nearest vertex to a point
// above a large face is often another part's: projected on that vertex's triangles, the match
// is far from the closest point, and ICP settles on a wrong pose (docs/algorithms/registration.md).
std::vector<FacePoint> face_points(const TriangleMesh& mesh, std::size_t budget)
{
    std::vector<FacePoint> result;
    const auto faces = static_cast<Eigen::Index>(mesh.F.rows());
    if (faces == 0 || budget == 0)
    {
        return result;
    }
    std::vector<double> longest(static_cast<std::size_t>(faces));
    for (Eigen::Index f = 0; f < faces; ++f)
    {
        double l = 0.0;
        for (int c = 0; c < 3; ++c)
        {
            l = std::max(l, (mesh.V.row(mesh.F(f, c)) - mesh.V.row(mesh.F(f, (c + 1) % 3))).norm());
        }
        longest[static_cast<std::size_t>(f)] = l;
    }
    double spacing = median_edge(mesh);
    if (!(spacing > 0.0))
    {
        return result;
    }
    // A face gets (k + 1)(k + 2)/2 - 3 lattice points, k = ceil(longest edge / spacing); only
    // faces whose longest edge exceeds twice the spacing get any. Counted in floating point: a
    // sliver of a huge triangle beside tiny ones must not overflow the count.
    // Above a face larger than this many spacings the nearest vertex may be another part's
    // (docs/algorithms/registration.md, step 5); meshes of even triangles get no points.
    constexpr double kLargeFace = 2.0;
    auto steps = [&](std::size_t f)
    { return longest[f] > kLargeFace * spacing ? std::ceil(longest[f] / spacing) : 0.0; };
    auto count = [](double k) { return k >= 3.0 ? (k + 1.0) * (k + 2.0) / 2.0 - 3.0 : 0.0; };
    const auto allowed = static_cast<double>(budget);
    for (int attempt = 0; attempt < 8; ++attempt)
    {
        double total = 0.0;
        for (std::size_t f = 0; f < longest.size(); ++f)
        {
            total += count(steps(f));
        }
        if (total <= allowed)
        {
            break;
        }
        spacing *= std::sqrt(total / allowed) * 1.01;
    }
    for (std::size_t f = 0; f < longest.size(); ++f)
    {
        const double points = count(steps(f));
        if (points == 0.0 || static_cast<double>(result.size()) + points > allowed)
        {
            continue;  // none, or over the budget (a face of a mesh still over it after 8 rounds)
        }
        const auto k = static_cast<std::size_t>(steps(f));
        const auto row = mesh.F.row(static_cast<Eigen::Index>(f));
        const Eigen::Vector3d a = mesh.V.row(row(0)).transpose();
        const Eigen::Vector3d b = mesh.V.row(row(1)).transpose();
        const Eigen::Vector3d c = mesh.V.row(row(2)).transpose();
        for (std::size_t i = 0; i <= k; ++i)
        {
            for (std::size_t j = 0; i + j <= k; ++j)
            {
                const std::size_t l = k - i - j;
                if (i == k || j == k || l == k)
                {
                    continue;  // a corner: the vertex is in the tree already
                }
                const double u = static_cast<double>(i) / static_cast<double>(k);
                const double v = static_cast<double>(j) / static_cast<double>(k);
                result.push_back({(1.0 - u - v) * a + u * b + v * c, static_cast<std::int32_t>(f)});
            }
        }
    }
    return result;
}

}  // namespace

struct SurfaceMatcher::Impl
{
    std::vector<std::int32_t> vertex_of;    // kd point -> mesh vertex (surface mode).
    std::vector<std::int32_t> face_of;      // kd point vertex_of.size() + i -> its face.
    Positions V;                            // mesh positions (surface mode).
    Faces F;                                // mesh faces (surface mode).
    Positions face_normal;                  // unit face normals (surface mode).
    std::vector<std::size_t> ring_offsets;  // vertex -> incident faces, CSR.
    std::vector<std::int32_t> ring_faces;
    std::unique_ptr<PointKdTree> tree;  // Over the target's (referenced) vertices.

    void build_tree(Positions points)
    {
        if (points.rows() == 0)
        {
            throw InvalidMesh("registration: the target of a closest-point search has no points.");
        }
        tree = std::make_unique<PointKdTree>(std::move(points));
    }

    // Unit normals by the right-hand rule; zero for a degenerate triangle.
    void build_face_normals()
    {
        face_normal.resize(F.rows(), 3);
        for (Eigen::Index f = 0; f < F.rows(); ++f)
        {
            const Eigen::Vector3d a = V.row(F(f, 0)).transpose();
            const Eigen::Vector3d n =
                (V.row(F(f, 1)).transpose() - a).cross(V.row(F(f, 2)).transpose() - a);
            const double length = n.norm();
            face_normal.row(f) =
                (length > 0.0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero()).transpose();
        }
    }

    void build_rings()
    {
        const auto n = static_cast<std::size_t>(V.rows());
        ring_offsets.assign(n + 1, 0);
        for (Eigen::Index i = 0; i < F.size(); ++i)
        {
            ++ring_offsets[static_cast<std::size_t>(F.data()[i]) + 1];
        }
        for (std::size_t v = 0; v < n; ++v)
        {
            ring_offsets[v + 1] += ring_offsets[v];
        }
        ring_faces.resize(ring_offsets.back());
        std::vector<std::size_t> cursor(ring_offsets.begin(), ring_offsets.end() - 1);
        for (Eigen::Index f = 0; f < F.rows(); ++f)
        {
            for (int c = 0; c < 3; ++c)
            {
                const auto v = static_cast<std::size_t>(F(f, c));
                ring_faces[cursor[v]++] = static_cast<std::int32_t>(f);
            }
        }
    }
};

SurfaceMatcher::SurfaceMatcher(Positions points) : impl_(std::make_unique<Impl>())
{
    impl_->build_tree(std::move(points));
}

SurfaceMatcher::SurfaceMatcher(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>())
{
    if (mesh.F.rows() == 0)
    {
        impl_->build_tree(mesh.V);
        return;
    }
    impl_->V = mesh.V;
    impl_->F = mesh.F;
    impl_->build_face_normals();
    impl_->vertex_of = referenced_vertices(mesh);
    const std::vector<FacePoint> inside = face_points(mesh, impl_->vertex_of.size());
    const std::size_t n = impl_->vertex_of.size();
    Positions points(static_cast<Eigen::Index>(n + inside.size()), 3);
    for (std::size_t i = 0; i < n; ++i)
    {
        points.row(static_cast<Eigen::Index>(i)) = mesh.V.row(impl_->vertex_of[i]);
    }
    impl_->face_of.reserve(inside.size());
    for (std::size_t i = 0; i < inside.size(); ++i)
    {
        points.row(static_cast<Eigen::Index>(n + i)) = inside[i].point.transpose();
        impl_->face_of.push_back(inside[i].face);
    }
    impl_->build_rings();
    impl_->build_tree(std::move(points));
}

SurfaceMatcher::~SurfaceMatcher() = default;

bool SurfaceMatcher::has_normals() const noexcept
{
    return impl_->F.rows() > 0;
}

SurfaceMatch SurfaceMatcher::match(const Eigen::Vector3d& query) const
{
    const Impl& m = *impl_;
    double squared = 0.0;
    const std::uint32_t k = m.tree->nearest(query, squared);
    SurfaceMatch result;
    result.point = m.tree->points().row(static_cast<Eigen::Index>(k)).transpose();
    result.distance = std::sqrt(squared);
    if (m.F.rows() == 0)
    {
        return result;
    }
    // Project onto every triangle around the nearest vertex (around the three corners of the
    // face when the nearest point lies inside a large face); the first strictly closer triangle
    // in ring order wins, so ties resolve the same way on every run.
    const bool on_vertex = k < m.vertex_of.size();
    const std::int32_t face = on_vertex ? -1 : m.face_of[k - m.vertex_of.size()];
    double best = squared;
    std::int32_t best_face =
        on_vertex ? m.ring_faces[m.ring_offsets[static_cast<std::size_t>(m.vertex_of[k])]] : face;
    auto project_ring = [&](std::size_t v)
    {
        for (std::size_t r = m.ring_offsets[v]; r < m.ring_offsets[v + 1]; ++r)
        {
            const std::int32_t f = m.ring_faces[r];
            const auto row = m.F.row(f);
            const TriangleCorners t{m.V.row(row(0)).transpose(), m.V.row(row(1)).transpose(),
                                    m.V.row(row(2)).transpose()};
            const Eigen::Vector3d p = closest_point_on_triangle(query, t);
            const double d2 = (p - query).squaredNorm();
            if (d2 < best)
            {
                best = d2;
                best_face = f;
                result.point = p;
            }
        }
    };
    if (on_vertex)
    {
        project_ring(static_cast<std::size_t>(m.vertex_of[k]));
    }
    else
    {
        for (int c = 0; c < 3; ++c)
        {
            project_ring(static_cast<std::size_t>(m.F(face, c)));
        }
    }
    result.distance = std::sqrt(best);
    result.normal = m.face_normal.row(best_face).transpose();
    return result;
}

void SurfaceMatcher::match_all(const Positions& queries, std::vector<SurfaceMatch>& out,
                               int threads) const
{
    const auto count = static_cast<std::int64_t>(queries.rows());
    out.resize(static_cast<std::size_t>(count));
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads)) if (threads != 1)
    for (std::int64_t i = 0; i < count; ++i)
    {
        out[static_cast<std::size_t>(i)] =
            match(queries.row(static_cast<Eigen::Index>(i)).transpose());
    }
}

namespace detail
{

double median_neighbor_spacing(const Positions& V, std::size_t max_queries)
{
    const auto n = static_cast<std::size_t>(V.rows());
    if (n < 2)
    {
        return 0.0;
    }
    const PointKdTree tree(V);
    const std::size_t step = std::max<std::size_t>(1, n / std::max<std::size_t>(max_queries, 1));
    std::vector<double> spacing;
    for (std::size_t i = 0; i < n; i += step)
    {
        std::array<std::uint32_t, 2> index{};
        std::array<double, 2> squared{};
        const Eigen::Vector3d q = V.row(static_cast<Eigen::Index>(i)).transpose();
        (void)tree.nearest(q, 2, index.data(), squared.data());
        spacing.push_back(std::sqrt(squared[1]));
    }
    return median_in_place(spacing);
}

}  // namespace detail

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "attacks/detail/cgal_mesh.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>

#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace pmp = CGAL::Polygon_mesh_processing;

namespace
{

using Triangle = std::array<std::size_t, 3>;

std::uint64_t edge_key(std::size_t a, std::size_t b)
{
    return (static_cast<std::uint64_t>(std::min(a, b)) << 32U) | std::max(a, b);
}

// Drops the fewest faces needed so that no edge has more than two, preferring to drop faces on
// many non-manifold edges (the fins and folds that decimators leave behind). CGAL's
// orient_polygon_soup would instead cut the surface apart along every non-manifold edge, which
// shatters meshes like dragon_vrip_res4.ply (803 such edges) into hundreds of loose triangles
// that no edge collapse can remove. Faces with a repeated corner are dropped too.
std::vector<Triangle> at_most_two_faces_per_edge(const std::vector<Triangle>& triangles)
{
    std::unordered_map<std::uint64_t, int> uses;
    uses.reserve(triangles.size() * 2);
    for (const auto& t : triangles)
    {
        for (int c = 0; c < 3; ++c)
        {
            ++uses[edge_key(t[static_cast<std::size_t>(c)],
                            t[static_cast<std::size_t>((c + 1) % 3)])];
        }
    }
    // Faces with fewer non-manifold edges first; ties keep the file order (deterministic).
    std::vector<std::pair<int, std::size_t>> order;
    order.reserve(triangles.size());
    for (std::size_t f = 0; f < triangles.size(); ++f)
    {
        const auto& t = triangles[f];
        if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0])
        {
            continue;
        }
        int crowded = 0;
        for (int c = 0; c < 3; ++c)
        {
            crowded += uses[edge_key(t[static_cast<std::size_t>(c)],
                                     t[static_cast<std::size_t>((c + 1) % 3)])] > 2
                           ? 1
                           : 0;
        }
        order.emplace_back(crowded, f);
    }
    std::sort(order.begin(), order.end());
    std::unordered_map<std::uint64_t, int> accepted;
    accepted.reserve(triangles.size() * 2);
    std::vector<char> is_kept(triangles.size(), 0);
    for (const auto& [crowded, f] : order)
    {
        const auto& t = triangles[f];
        std::array<std::uint64_t, 3> keys{};
        bool fits = true;
        for (std::size_t c = 0; c < 3; ++c)
        {
            keys[c] = edge_key(t[c], t[(c + 1) % 3]);
            fits = fits && accepted[keys[c]] < 2;
        }
        if (fits)
        {
            for (const auto key : keys)
            {
                ++accepted[key];
            }
            is_kept[f] = 1;
        }
    }
    std::vector<Triangle> kept;
    kept.reserve(triangles.size());
    for (std::size_t f = 0; f < triangles.size(); ++f)
    {
        if (is_kept[f] != 0)
        {
            kept.push_back(triangles[f]);
        }
    }
    return kept;
}

struct Soup
{
    std::vector<CgalPoint> points;
    std::vector<Triangle> triangles;
};

// The triangles over the referenced vertices only, renumbered in order.
Soup referenced_soup(const TriangleMesh& mesh)
{
    Soup soup;
    const auto rows = referenced_vertices(mesh);
    std::vector<std::size_t> soup_index(static_cast<std::size_t>(mesh.V.rows()), 0);
    soup.points.reserve(rows.size());
    for (const auto i : rows)
    {
        soup_index[static_cast<std::size_t>(i)] = soup.points.size();
        soup.points.emplace_back(mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
    }
    soup.triangles.resize(static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            soup.triangles[static_cast<std::size_t>(f)][static_cast<std::size_t>(c)] =
                soup_index[static_cast<std::size_t>(mesh.F(f, c))];
        }
    }
    return soup;
}

// Drops the triangles of zero area: a repeated corner, or three corners on one line (exact
// predicate; coincident corners included). CGAL's isotropic remeshing assumes there are none:
// a part collapsed to a point crashed it (SIGSEGV in its tangential relaxation). Returns the
// number dropped.
std::size_t drop_degenerate_triangles(const std::vector<CgalPoint>& points,
                                      std::vector<Triangle>& triangles)
{
    const auto before = triangles.size();
    std::erase_if(triangles,
                  [&points](const Triangle& t)
                  {
                      return t[0] == t[1] || t[1] == t[2] || t[2] == t[0] ||
                             CGAL::collinear(points[t[0]], points[t[1]], points[t[2]]);
                  });
    return before - triangles.size();
}

// True when two of \p points are at the same position (bit for bit).
bool has_coincident_points(const std::vector<CgalPoint>& points)
{
    std::vector<std::array<double, 3>> sorted;
    sorted.reserve(points.size());
    for (const CgalPoint& p : points)
    {
        sorted.push_back({p.x(), p.y(), p.z()});
    }
    std::sort(sorted.begin(), sorted.end());
    return std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end();
}

}  // namespace

SurfaceMesh to_surface_mesh(const TriangleMesh& mesh, std::string_view attack, bool weld)
{
    if (mesh.F.rows() == 0)
    {
        throw InvalidMesh(std::string(attack) +
                          ": the mesh has no faces (a point cloud); this attack needs a "
                          "triangle surface.");
    }
    Soup soup = referenced_soup(mesh);
    const bool had_degenerate = drop_degenerate_triangles(soup.points, soup.triangles) > 0;

    // Clean soups (the check is much cheaper than the repair) go straight in. Others: thin out
    // non-manifold edges, then let CGAL merge coincident points, drop degenerate and duplicate
    // faces and the points no face uses any more, and orient, duplicating points where the
    // surface is still non-manifold. The repair works on variable-size polygons, since it only
    // drops faces that become degenerate when coincident points merge from those.
    SurfaceMesh surface;
    // Welding: points at one position become one (the repair's merge), so that a surface split
    // into separate pieces (a triangle soup, seams split by an exporter) is remeshed as one.
    const bool must_weld = weld && has_coincident_points(soup.points);
    if (!had_degenerate && !must_weld && pmp::is_polygon_soup_a_polygon_mesh(soup.triangles))
    {
        pmp::polygon_soup_to_polygon_mesh(soup.points, soup.triangles, surface);
    }
    else
    {
        std::vector<std::vector<std::size_t>> polygons;
        for (const auto& t : at_most_two_faces_per_edge(soup.triangles))
        {
            polygons.push_back({t[0], t[1], t[2]});
        }
        pmp::repair_polygon_soup(soup.points, polygons);
        pmp::orient_polygon_soup(soup.points, polygons);
        if (!polygons.empty())
        {
            pmp::polygon_soup_to_polygon_mesh(soup.points, polygons, surface);
        }
    }
    if (surface.number_of_faces() == 0)
    {
        throw InvalidMesh(std::string(attack) +
                          ": no usable triangle is left after removing degenerate faces.");
    }
    return surface;
}

TriangleMesh to_triangle_mesh(const SurfaceMesh& surface)
{
    // Dense numbering of the live vertices (the surface may hold removed ones until garbage
    // collection).
    TriangleMesh mesh;
    std::vector<std::int32_t> dense(surface.num_vertices(), -1);
    mesh.V.resize(static_cast<Eigen::Index>(surface.number_of_vertices()), 3);
    std::int32_t next = 0;
    for (const auto v : surface.vertices())
    {
        const CgalPoint& p = surface.point(v);
        mesh.V.row(next) << p.x(), p.y(), p.z();
        dense[v.idx()] = next++;
    }
    mesh.F.resize(static_cast<Eigen::Index>(surface.number_of_faces()), 3);
    Eigen::Index f = 0;
    for (const auto face : surface.faces())
    {
        auto h = surface.halfedge(face);
        for (int c = 0; c < 3; ++c)
        {
            mesh.F(f, c) = dense[surface.target(h).idx()];
            h = surface.next(h);
        }
        MESHMARK_ASSERT(h == surface.halfedge(face), "CGAL surface face is not a triangle");
        ++f;
    }
    return mesh;
}

}  // namespace meshmark::detail

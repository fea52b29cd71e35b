// SPDX-License-Identifier: MIT
#include "attacks/detail/cgal_mesh.h"

#include <string>
#include <vector>

#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>

#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace pmp = CGAL::Polygon_mesh_processing;

SurfaceMesh to_surface_mesh(const TriangleMesh& mesh, std::string_view attack)
{
    if (mesh.F.rows() == 0)
    {
        throw InvalidMesh(std::string(attack) +
                          ": the mesh has no faces (a point cloud); this attack needs a "
                          "triangle surface.");
    }

    // Polygon soup over the referenced vertices (variable-size polygons, so that the repair
    // can drop faces that become degenerate when coincident points are merged).
    const auto rows = referenced_vertices(mesh);
    std::vector<std::size_t> soup_index(static_cast<std::size_t>(mesh.V.rows()), 0);
    std::vector<CgalPoint> points;
    points.reserve(rows.size());
    for (const auto i : rows)
    {
        soup_index[static_cast<std::size_t>(i)] = points.size();
        points.emplace_back(mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
    }
    std::vector<std::vector<std::size_t>> polygons(static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        auto& polygon = polygons[static_cast<std::size_t>(f)];
        for (int c = 0; c < 3; ++c)
        {
            polygon.push_back(soup_index[static_cast<std::size_t>(mesh.F(f, c))]);
        }
    }

    // Repair only when needed: the check is much cheaper than the repair on clean meshes.
    if (!pmp::is_polygon_soup_a_polygon_mesh(polygons))
    {
        pmp::repair_polygon_soup(points, polygons);
        pmp::orient_polygon_soup(points, polygons);
    }
    SurfaceMesh surface;
    if (!polygons.empty())
    {
        pmp::polygon_soup_to_polygon_mesh(points, polygons, surface);
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

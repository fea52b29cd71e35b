// SPDX-License-Identifier: MIT
#include "meshmark/attacks/simplification.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

// The kernel first: Bounded_normal_change_placement.h uses CGAL::is_positive without including it.
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Bounded_normal_change_placement.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/boost/graph/Euler_operations.h>

#include "attacks/detail/cgal_mesh.h"
#include "attacks/detail/format.h"
#include "attacks/detail/simplify_meshopt.h"
#include "attacks/detail/simplify_surface.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace detail
{
namespace
{

namespace sms = CGAL::Surface_mesh_simplification;

// meshoptimizer results further than this from the target (relative) fall back to CGAL: 5% is
// inside the attacks' 10% count contract (docs/algorithms/attacks.md, "Tests"); chosen by hand.
constexpr double kMeshoptTolerance = 0.05;

// Stops the collapses when the surface is down to the target vertex count. Every collapse
// removes exactly one vertex, so the count is hit exactly (CGAL's own predicates count edges or
// faces, which only approximate a vertex target on surfaces with boundaries or several pieces).
class VertexCountStop
{
public:
    VertexCountStop(const SurfaceMesh& surface, std::size_t target)
        : surface_(&surface), target_(target)
    {
    }
    template <typename Cost, typename Profile>
    bool operator()(const Cost& /*current_cost*/, const Profile& /*profile*/,
                    std::size_t /*initial_edge_count*/, std::size_t /*current_edge_count*/) const
    {
        return surface_->number_of_vertices() <= target_;
    }

private:
    const SurfaceMesh* surface_;
    std::size_t target_;
};

// Rounds of unblocking (see simplify_surface) before accepting a count above the target; chosen
// by hand; no study on record.
constexpr int kMaxUnblockRounds = 8;

// GCC 12 reports a false -Wmaybe-uninitialized inside CGAL's Garland-Heckbert quadrics (Eigen
// 4x4 DontAlign matrices, assigned before use) once they are inlined here.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
void collapse(SurfaceMesh& surface, std::size_t target_vertices, SimplificationPolicy policy,
              double boundary_weight)
{
    const VertexCountStop stop(surface, target_vertices);
    // Both policies are wrapped in Bounded_normal_change_placement, which refuses a collapse
    // that would flip a face normal (fold-overs would make the result self-intersect).
    if (policy == SimplificationPolicy::GarlandHeckbert)
    {
        using Policies = sms::GarlandHeckbert_plane_policies<SurfaceMesh, CgalKernel>;
        const Policies policies(surface, boundary_weight);
        const sms::Bounded_normal_change_placement<Policies::Get_placement> placement(
            policies.get_placement());
        sms::edge_collapse(
            surface, stop,
            CGAL::parameters::get_cost(policies.get_cost()).get_placement(placement));
    }
    else
    {
        const sms::Bounded_normal_change_placement<sms::LindstromTurk_placement<SurfaceMesh>>
            placement;
        sms::edge_collapse(surface, stop,
                           CGAL::parameters::get_cost(sms::LindstromTurk_cost<SurfaceMesh>())
                               .get_placement(placement));
    }
}
#pragma GCC diagnostic pop

// Removes the triangles whose three edges are all on the border (loose triangles: no collapse
// can shrink them) and closes the holes bounded by three edges (collapsing any edge around one
// would pinch the surface, so each blocks its neighbourhood). Returns how many it changed.
std::size_t unblock(SurfaceMesh& surface)
{
    std::vector<SurfaceMesh::Face_index> loose;
    for (const auto f : surface.faces())
    {
        bool is_loose = true;
        for (const auto h : CGAL::halfedges_around_face(surface.halfedge(f), surface))
        {
            is_loose = is_loose && surface.is_border(surface.opposite(h));
        }
        if (is_loose)
        {
            loose.push_back(f);
        }
    }
    for (const auto f : loose)
    {
        CGAL::Euler::remove_face(surface.halfedge(f), surface);
    }
    std::vector<SurfaceMesh::Halfedge_index> holes;
    for (const auto h : surface.halfedges())
    {
        const auto third = surface.next(surface.next(h));
        // Count each triangular hole once, from its smallest halfedge.
        if (surface.is_border(h) && surface.next(third) == h && h < surface.next(h) && h < third)
        {
            holes.push_back(h);
        }
    }
    for (const auto h : holes)
    {
        CGAL::Euler::fill_hole(h, surface);
    }
    surface.collect_garbage();
    return loose.size() + holes.size();
}

}  // namespace

void simplify_surface(SurfaceMesh& surface, std::size_t target_vertices,
                      SimplificationPolicy policy, double boundary_weight)
{
    if (surface.number_of_vertices() <= target_vertices)
    {
        return;
    }
    collapse(surface, target_vertices, policy, boundary_weight);
    // When the collapses run out above the target, what stops them is topological, typically
    // slits and crumbs left by cutting a non-manifold input apart: unblock and go on.
    for (int round = 0; round < kMaxUnblockRounds && surface.number_of_vertices() > target_vertices;
         ++round)
    {
        if (unblock(surface) == 0)
        {
            break;
        }
        collapse(surface, target_vertices, policy, boundary_weight);
    }
}

}  // namespace detail

void SimplificationOptions::validate() const
{
    if (!std::isfinite(vertex_fraction) || vertex_fraction <= 0.0 || vertex_fraction > 1.0)
    {
        throw InvalidOption("simplify: fraction " + detail::format_number(vertex_fraction) +
                            " is outside (0, 1].");
    }
    if (!std::isfinite(boundary_weight) || boundary_weight <= 0.0)
    {
        throw InvalidOption("simplify: boundary weight " + detail::format_number(boundary_weight) +
                            " must be positive.");
    }
    if (boundary_weight != SimplificationOptions{}.boundary_weight &&
        (policy != SimplificationPolicy::GarlandHeckbert || method != SimplificationMethod::Cgal))
    {
        throw InvalidOption(
            "simplify: boundary= weighs the border quadrics of policy=gh with method=cgal; "
            "policy=lt and method=meshopt do not use it.");
    }
}

TriangleMesh simplify(const TriangleMesh& mesh, const SimplificationOptions& options)
{
    options.validate();
    // Target from the referenced vertices: unreferenced ones are not part of the surface.
    const auto referenced = static_cast<double>(referenced_vertices(mesh).size());
    const auto target =
        static_cast<std::size_t>(std::max(4.0, std::round(options.vertex_fraction * referenced)));
    if (options.method == SimplificationMethod::Meshoptimizer)
    {
        if (auto result = detail::simplify_meshopt(mesh, target, detail::kMeshoptTolerance))
        {
            return std::move(*result);
        }
    }
    detail::SurfaceMesh surface = detail::to_surface_mesh(mesh, "simplify");
    detail::simplify_surface(surface, target, options.policy, options.boundary_weight);
    return detail::to_triangle_mesh(surface);
}

}  // namespace meshmark

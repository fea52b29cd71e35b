// SPDX-License-Identifier: MIT
// A registered copy whose vertices are the original's again (reordered, split at seams, welded,
// with vertices added between them, or cut): each original vertex paired with the suspect
// vertex standing for it (mutual nearest), and the rules that accept the pairing.
#include "meshmark/registration/vertex_matching.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "meshmark/core/median.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/resampling.h"

namespace meshmark
{
namespace
{

// A registered suspect is read vertex for vertex when at least 10% of the original's vertices
// find a suspect vertex standing for them (the others are left out as cropped), and only on a mesh
// whose mean edge is at least kMatchSpacing mark amplitudes. Until the sixth session of 2026-11-26
// this was 99%, and a crop stayed with the resampling, which keeps only each row's normal
// component: a copy cut or bisected by deleting faces, or a faceted asset decimated by Blender
// (which deletes its lone triangles and moves no vertex), keeps the original's vertices where they
// were, and read vertex for vertex it reads the whole change (the suite's half crops of
// fandisk 7.99 -> 10.22 mean z, Blender's 20% of a faceted creature 5.69 -> 10.82:
// bench/results/2026-11-26-two-more-game-like-assets.md). The spacing and ambiguity rules below
// still send simplified and remeshed copies to the resampling.
constexpr double kMaxUnmatched = 0.9;
// Up to this share unmatched the copy is taken as the original's vertices as it stands (a
// writer's seams, a weld, a midpoint subdivision); beyond it, only when at least
// kMinOriginalTriangles of its triangles between matched vertices are the original's.
constexpr double kMaxNearlyAll = 0.01;
constexpr double kMinOriginalTriangles = 0.9;  // a crop keeps them all, a simplification few
constexpr double kMatchSpacing =
    10.0;  // below it a marked vertex can land nearer a neighbour's place
// ... and when its vertices stand for the original's unambiguously: the median, over the
// matched vertices, of the distance to the matched suspect vertex over the distance to the
// next suspect position is at most this. A copy of the original's vertices puts one suspect
// vertex where each original vertex was and the next one an edge or half an edge away (median
// 0.08-0.16 for reorders, seam splits and midpoint subdivisions of fandisk and a game-like
// asset); a surface sampled afresh (a voxel remesh) has its vertices where the grid put them,
// the nearest and the next at similar distances (0.63-0.67 at 1/150 and 1/300 of the
// diagonal), and read vertex for vertex it would take their offsets along the surface for a
// change (fandisk at 1/300: z 7.54 against 9.37 resampled).
constexpr double kMaxMatchAmbiguity = 0.4;
// Neighbours looked at for the next suspect position (a writer's duplicates at one position
// come first).
constexpr std::size_t kMatchNeighbours = 8;

}  // namespace

// A suspect whose vertices are the original's again, in another order, split where a writer
// duplicates them (UV seams, hard edges: Blender's PLY and OBJ writers), welded where a tool
// joins the original's duplicates, or with vertices added between them (midpoint
// subdivision), is read vertex for vertex rather than through its surface: each original
// vertex takes the suspect vertex nearest to it after registration, when that one lies within
// \p tolerance and the original vertex nearest to it is at the same position (mutual nearest
// neighbours; original vertices at one position count as one). Mutual pairs can still be
// wrong where the mark moves a vertex nearer a neighbour's place than its own: the caller
// tries this only on meshes whose spacing is large against the mark (kMatchSpacing). \p match
// gets, per original vertex, the suspect vertex or -1; \p ambiguity the median over the
// matched vertices of the distance to their suspect vertex over the distance to the next
// suspect position (kMaxMatchAmbiguity; 1 when none matched). Distances to the original only,
// never the key: the bound holds as for any correspondence. Returns the number matched.
VertexMatching match_vertices(const Positions& original, const Positions& registered,
                              double tolerance, int threads)
{
    VertexMatching out;
    std::vector<std::int32_t>& match = out.suspect_of;
    double& ambiguity = out.ambiguity;
    const Eigen::Index n = original.rows();
    match.assign(static_cast<std::size_t>(n), -1);
    ambiguity = 1.0;
    if (registered.rows() == 0 || n == 0)
    {
        return out;
    }
    const PointKdTree suspect_tree(registered);
    const PointKdTree original_tree(original);
    const double squared_tolerance = tolerance * tolerance;
    // Positions closer than this to the matched one are its duplicates, not the next position.
    const double squared_same = 1e-12 * squared_tolerance;
    std::vector<float> ratio(static_cast<std::size_t>(n), -1.0F);
    std::size_t matched = 0;
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads)) reduction(+ : matched)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        std::array<std::uint32_t, kMatchNeighbours> index{};
        std::array<double, kMatchNeighbours> squared{};
        const std::size_t found = suspect_tree.nearest(
            original.row(i).transpose(), kMatchNeighbours, index.data(), squared.data());
        const std::uint32_t j = index[0];
        if (squared[0] > squared_tolerance)
        {
            continue;
        }
        double back_squared = 0.0;
        const std::uint32_t back =
            original_tree.nearest(registered.row(j).transpose(), back_squared);
        if (original.row(back) != original.row(i))
        {
            continue;
        }
        match[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(j);
        ++matched;
        double next = 0.0;  // 0: no other position among the neighbours (ratio 0, unambiguous)
        for (std::size_t t = 1; t < found; ++t)
        {
            if ((registered.row(index[t]) - registered.row(j)).squaredNorm() > squared_same)
            {
                next = squared[t];
                break;
            }
        }
        ratio[static_cast<std::size_t>(i)] =
            next > 0.0 ? static_cast<float>(std::sqrt(squared[0] / next)) : 0.0F;
    }
    ratio.erase(std::remove(ratio.begin(), ratio.end(), -1.0F), ratio.end());
    if (!ratio.empty())
    {
        ambiguity = median_in_place(ratio);
    }
    out.matched = matched;
    return out;
}

// Of the suspect's triangles whose three corners stand for original vertices (\p match, from
// match_vertices), the share that are triangles of the original (corners compared by
// position, so that a writer's duplicates count as one vertex); -1 when they are fewer than
// half of the suspect's triangles. A copy that deletes faces and moves no vertex (a crop, a
// bisection, Blender's decimation of a faceted asset) keeps the original's triangles; a
// simplification builds new ones between the vertices it keeps and moves, and read vertex for
// vertex its moved vertices would be taken for the change (a 50% simplification of a 10K
// ellipsoid: claimed resampled, lost so).
double original_triangle_share(const TriangleMesh& original, const TriangleMesh& suspect,
                               const Positions& registered, const std::vector<std::int32_t>& match)
{
    using Key = std::array<std::int32_t, 3>;
    // One id per original position: the lowest index there.
    const auto n = static_cast<std::size_t>(original.V.rows());
    const std::vector<std::int32_t> id = position_ids(original.V);
    auto key = [](std::array<std::int32_t, 3> k)
    {
        std::sort(k.begin(), k.end());
        return k;
    };
    std::vector<Key> faces(static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        faces[static_cast<std::size_t>(f)] = key({id[static_cast<std::size_t>(original.F(f, 0))],
                                                  id[static_cast<std::size_t>(original.F(f, 1))],
                                                  id[static_cast<std::size_t>(original.F(f, 2))]});
    }
    std::sort(faces.begin(), faces.end());
    // Each suspect vertex at the position of a matched one stands for that original vertex.
    std::vector<std::pair<std::array<double, 3>, std::int32_t>> matched;
    for (std::size_t i = 0; i < n; ++i)
    {
        if (match[i] >= 0)
        {
            const auto j = static_cast<Eigen::Index>(match[i]);
            matched.push_back({{registered(j, 0), registered(j, 1), registered(j, 2)}, id[i]});
        }
    }
    std::sort(matched.begin(), matched.end());
    auto stands_for = [&](std::int32_t s)
    {
        const std::array<double, 3> p{registered(s, 0), registered(s, 1), registered(s, 2)};
        const auto it =
            std::lower_bound(matched.begin(), matched.end(), std::pair(p, std::int32_t{-1}));
        return it != matched.end() && it->first == p ? it->second : -1;
    };
    std::size_t whole = 0;
    std::size_t kept = 0;
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        Key k{};
        bool all = true;
        for (int c = 0; c < 3 && all; ++c)
        {
            k[static_cast<std::size_t>(c)] = stands_for(suspect.F(f, c));
            all = k[static_cast<std::size_t>(c)] >= 0;
        }
        if (!all)
        {
            continue;
        }
        ++whole;
        kept += std::binary_search(faces.begin(), faces.end(), key(k)) ? 1U : 0U;
    }
    // Too few such triangles say nothing (a sqrt(3) subdivision keeps a few at a border).
    if (2 * whole < static_cast<std::size_t>(suspect.F.rows()) || whole == 0)
    {
        return -1.0;
    }
    return static_cast<double>(kept) / static_cast<double>(whole);
}

// A vertex starts the renumbering below when the suspect vertex nearest to it is at most this
// share of the distance to the next one, and it is as clearly the nearest back; a triangle's

std::optional<VerticesInPlace> vertices_in_place(const TriangleMesh& original,
                                                 const TriangleMesh& suspect,
                                                 const Eigen::Matrix4d& to_original,
                                                 double amplitude, double reach, int threads)
{
    if (!(2 * suspect.vertex_count() >= original.vertex_count() && original.F.rows() > 0))
    {
        return std::nullopt;
    }
    // The mean edge (a pass over the faces) only once the cheap conditions hold.
    const double spacing = mean_edge_length(original);
    if (!(spacing >= kMatchSpacing * amplitude))
    {
        return std::nullopt;
    }
    const Positions registered = transform_points(to_original, suspect.V);
    const VertexMatching pairs =
        match_vertices(original.V, registered, std::min(reach, 0.5 * spacing), threads);
    const std::vector<std::int32_t>& match = pairs.suspect_of;
    const std::size_t matched = pairs.matched;
    const auto n = static_cast<std::size_t>(original.V.rows());
    // Nearly every vertex found, or, for a copy that lost some (a crop), the triangles
    // between the vertices found are the original's (original_triangle_share).
    const bool kept_in_place =
        static_cast<double>(matched) >= (1.0 - kMaxNearlyAll) * static_cast<double>(n) ||
        (static_cast<double>(matched) >= (1.0 - kMaxUnmatched) * static_cast<double>(n) &&
         original_triangle_share(original, suspect, registered, match) >= kMinOriginalTriangles);
    if (!kept_in_place || !(pairs.ambiguity <= kMaxMatchAmbiguity))
    {
        return std::nullopt;
    }
    // In the registered frame (a mirrored copy is already unmirrored there, which the
    // closed-form similarity could not do); rows without a suspect vertex stand at the
    // original's own position, left out of the fit and of the reading.
    VerticesInPlace out;
    out.in_order = original.V;
    out.matched_rows.assign(n, 1);
    out.matched = matched;
    for (std::size_t i = 0; i < n; ++i)
    {
        if (match[i] >= 0)
        {
            out.in_order.row(static_cast<Eigen::Index>(i)) = registered.row(match[i]);
        }
        else
        {
            out.matched_rows[i] = 0;
        }
    }
    return out;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// A copy that is the original's mesh renumbered where it stands (a re-encoded Draco primitive):
// its vertices put back in the original's order through positions beyond doubt and the
// triangles between them, or, where the positions crowd, the vertices the triangles leave no
// choice for. Positions and triangles only, never a key.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>
#include <utility>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/registration/renumbering.h"

namespace meshmark
{
namespace
{

// A vertex starts the renumbering below when the suspect vertex nearest to it is at most this
// share of the distance to the next one, and it is as clearly the nearest back; a triangle's
// third corner is taken as clearly. Closer calls are left to the triangles.
constexpr double kMaxStartRatio = 0.5;

namespace renumbering
{

// The original's triangles by edge: (edge key, third corner), sorted.
using EdgeThirds = std::vector<std::pair<std::uint64_t, std::int32_t>>;

std::uint64_t edge_key(std::int32_t a, std::int32_t b)
{
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32U) |
           static_cast<std::uint32_t>(std::max(a, b));
}

EdgeThirds edge_thirds(const TriangleMesh& original)
{
    EdgeThirds by_edge;
    by_edge.reserve(3 * static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            by_edge.emplace_back(edge_key(original.F(f, c), original.F(f, (c + 1) % 3)),
                                 original.F(f, (c + 2) % 3));
        }
    }
    std::sort(by_edge.begin(), by_edge.end());
    return by_edge;
}

// The vertices that stand for an original vertex beyond doubt: mutual nearest in place, within
// \p tolerance, the next vertex at least twice as far either way (kMaxStartRatio). Per suspect
// vertex: its original vertex or -1.
std::vector<std::int32_t> beyond_doubt(const TriangleMesh& original, const TriangleMesh& suspect,
                                       const PointKdTree& original_tree, double tolerance,
                                       int threads)
{
    const auto n = static_cast<std::size_t>(original.V.rows());
    const double squared_tolerance = tolerance * tolerance;
    const PointKdTree suspect_tree(suspect.V);
    std::vector<std::int32_t> start(
        n, -1);  // per original vertex: its suspect vertex, if beyond doubt
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads))
    for (Eigen::Index i = 0; i < original.V.rows(); ++i)
    {
        std::array<std::uint32_t, 2> index{};
        std::array<double, 2> squared{};
        if (suspect_tree.nearest(original.V.row(i).transpose(), 2, index.data(), squared.data()) <
                2 ||
            squared[0] > squared_tolerance ||
            squared[0] >= kMaxStartRatio * kMaxStartRatio * squared[1])
        {
            continue;
        }
        std::array<std::uint32_t, 2> back{};
        std::array<double, 2> back_squared{};
        if (original_tree.nearest(suspect.V.row(index[0]).transpose(), 2, back.data(),
                                  back_squared.data()) == 2 &&
            back[0] == static_cast<std::uint32_t>(i) &&
            back_squared[0] <
                kMaxStartRatio * kMaxStartRatio * back_squared[1])  // (two at one place: left)
        {
            start[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(index[0]);
        }
    }
    std::vector<std::int32_t> to_original(n, -1);
    for (std::size_t i = 0; i < n; ++i)
    {
        if (start[i] >= 0 && to_original[static_cast<std::size_t>(start[i])] < 0)
        {
            to_original[static_cast<std::size_t>(start[i])] = static_cast<std::int32_t>(i);
        }
    }
    return to_original;
}

// For each suspect vertex, its kCandidates nearest original vertices, nearest first, with their
// squared distances: the choices left_no_choice narrows, found once for every reach.
constexpr std::size_t kCandidates = 32;
struct NearestOriginals
{
    std::vector<std::uint32_t> index;  // kCandidates per suspect vertex
    std::vector<double> squared;
    std::vector<std::size_t> found;  // how many of them there are
};

NearestOriginals nearest_originals(const TriangleMesh& suspect, const PointKdTree& original_tree)
{
    const auto n = static_cast<std::size_t>(suspect.V.rows());
    NearestOriginals nearest{std::vector<std::uint32_t>(n * kCandidates),
                             std::vector<double>(n * kCandidates), std::vector<std::size_t>(n)};
    for (std::size_t j = 0; j < n; ++j)
    {
        nearest.found[j] = original_tree.nearest(
            suspect.V.row(static_cast<Eigen::Index>(j)).transpose(), kCandidates,
            nearest.index.data() + j * kCandidates, nearest.squared.data() + j * kCandidates);
    }
    return nearest;
}

// The vertices whose original vertex the triangles leave no choice for, when the positions
// alone do not tell (vertices nearer each other than the mark moves them, everywhere: a CAD
// plate whose vertices crowd on its outline's arcs). Each suspect vertex may stand for the
// original vertices within \p tolerance of it; a candidate goes when some neighbour of the
// vertex has no candidate it is a neighbour of in the original (arc consistency), until nothing
// changes; the kCandidates nearest within reach are a vertex's choices (one moved further than
// that many others only makes this fail). Per suspect vertex: its original vertex when one
// candidate is left, else -1; nullopt when a vertex has none left or two claim one original
// vertex (the copy is not the original renumbered, or not one this can follow).
std::optional<std::vector<std::int32_t>> left_no_choice(const NearestOriginals& nearest,
                                                        const VertexAdjacency& original_adjacency,
                                                        const VertexAdjacency& suspect_adjacency,
                                                        double tolerance)
{
    const std::size_t n = nearest.found.size();
    const double squared_tolerance = tolerance * tolerance;
    std::vector<std::vector<std::int32_t>> candidates(n);
    for (std::size_t j = 0; j < n; ++j)
    {
        for (std::size_t t = 0;
             t < nearest.found[j] && nearest.squared[j * kCandidates + t] <= squared_tolerance; ++t)
        {
            candidates[j].push_back(static_cast<std::int32_t>(nearest.index[j * kCandidates + t]));
        }
        if (candidates[j].empty())
        {
            return std::nullopt;
        }
    }
    auto adjacent = [&](std::int32_t x, std::int32_t y)
    {
        const auto around = original_adjacency.of(static_cast<std::size_t>(x));
        return std::binary_search(around.begin(), around.end(), y);
    };
    std::vector<std::size_t> queue(n);
    std::iota(queue.begin(), queue.end(), std::size_t{0});
    std::vector<char> queued(n, 1);
    while (!queue.empty())
    {
        const std::size_t a = queue.back();
        queue.pop_back();
        queued[a] = 0;
        for (const auto neighbour : suspect_adjacency.of(a))
        {
            const auto b = static_cast<std::size_t>(neighbour);
            auto& of_b = candidates[b];
            const auto kept_end = std::remove_if(
                of_b.begin(), of_b.end(),
                [&](std::int32_t y)
                {
                    return std::none_of(candidates[a].begin(), candidates[a].end(),
                                        [&](std::int32_t x) { return adjacent(x, y); });
                });
            if (kept_end == of_b.end())
            {
                continue;
            }
            of_b.erase(kept_end, of_b.end());
            if (of_b.empty())
            {
                return std::nullopt;
            }
            if (queued[b] == 0)
            {
                queued[b] = 1;
                queue.push_back(b);
            }
        }
    }
    std::vector<std::int32_t> to_original(n, -1);
    std::vector<char> taken(original_adjacency.vertex_count(), 0);
    for (std::size_t j = 0; j < n; ++j)
    {
        if (candidates[j].size() == 1)
        {
            const auto x = static_cast<std::size_t>(candidates[j].front());
            if (taken[x] != 0)
            {
                return std::nullopt;
            }
            taken[x] = 1;
            to_original[j] = candidates[j].front();
        }
    }
    return to_original;
}

// From the suspect vertices known in \p to_original, through the triangles to the others (a
// suspect triangle with two corners known is the original's triangle on their edge whose third
// corner is clearly the nearest untaken one); the suspect's positions in the original's order
// when every vertex is reached, each original vertex once, and every suspect triangle is a
// triangle of the original.
std::optional<Positions> propagated(const TriangleMesh& original, const TriangleMesh& suspect,
                                    const EdgeThirds& by_edge, const VertexFaces& faces_of,
                                    std::vector<std::int32_t> to_original, double tolerance)
{
    const auto n = static_cast<std::size_t>(original.V.rows());
    const double squared_tolerance = tolerance * tolerance;
    std::vector<char> taken(n, 0);  // per original vertex
    for (const auto x : to_original)
    {
        if (x >= 0)
        {
            taken[static_cast<std::size_t>(x)] = 1;
        }
    }
    // A triangle with two corners known is the original's triangle on their edge whose third
    // corner is the nearest untaken one, when the next is at least twice as far (else another
    // of its triangles decides later).
    std::vector<Eigen::Index> queue(static_cast<std::size_t>(suspect.F.rows()));
    std::iota(queue.begin(), queue.end(), Eigen::Index{0});
    while (!queue.empty())
    {
        const Eigen::Index f = queue.back();
        queue.pop_back();
        int unknown = -1;
        int known = 0;
        for (int c = 0; c < 3; ++c)
        {
            if (to_original[static_cast<std::size_t>(suspect.F(f, c))] >= 0)
            {
                ++known;
            }
            else
            {
                unknown = c;
            }
        }
        if (known != 2)
        {
            continue;
        }
        const std::int32_t v = suspect.F(f, unknown);
        const std::uint64_t key =
            edge_key(to_original[static_cast<std::size_t>(suspect.F(f, (unknown + 1) % 3))],
                     to_original[static_cast<std::size_t>(suspect.F(f, (unknown + 2) % 3))]);
        std::int32_t best = -1;
        double best_squared = std::numeric_limits<double>::infinity();
        double next_squared = std::numeric_limits<double>::infinity();
        for (auto it =
                 std::lower_bound(by_edge.begin(), by_edge.end(), std::pair(key, std::int32_t{-1}));
             it != by_edge.end() && it->first == key; ++it)
        {
            if (taken[static_cast<std::size_t>(it->second)] != 0 || it->second == best)
            {
                continue;
            }
            const double squared = (original.V.row(it->second) - suspect.V.row(v)).squaredNorm();
            if (squared < best_squared)
            {
                next_squared = best_squared;
                best = it->second;
                best_squared = squared;
            }
            else
            {
                next_squared = std::min(next_squared, squared);
            }
        }
        if (best >= 0 && best_squared <= squared_tolerance &&
            best_squared <= kMaxStartRatio * kMaxStartRatio * next_squared)
        {
            to_original[static_cast<std::size_t>(v)] = best;
            taken[static_cast<std::size_t>(best)] = 1;
            const auto around = faces_of.of(static_cast<std::size_t>(v));
            queue.insert(queue.end(), around.begin(), around.end());
        }
    }
    // Every vertex reached, and every triangle the original's.
    Positions in_order(original.V.rows(), 3);
    for (std::size_t j = 0; j < n; ++j)
    {
        if (to_original[j] < 0)
        {
            return std::nullopt;
        }
        in_order.row(to_original[j]) = suspect.V.row(static_cast<Eigen::Index>(j));
    }
    std::vector<std::array<std::int32_t, 3>> triangles(static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        auto& t = triangles[static_cast<std::size_t>(f)];
        t = {original.F(f, 0), original.F(f, 1), original.F(f, 2)};
        std::sort(t.begin(), t.end());
    }
    std::sort(triangles.begin(), triangles.end());
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        std::array<std::int32_t, 3> t{to_original[static_cast<std::size_t>(suspect.F(f, 0))],
                                      to_original[static_cast<std::size_t>(suspect.F(f, 1))],
                                      to_original[static_cast<std::size_t>(suspect.F(f, 2))]};
        std::sort(t.begin(), t.end());
        if (!std::binary_search(triangles.begin(), triangles.end(), t))
        {
            return std::nullopt;
        }
    }
    return in_order;
}

}  // namespace renumbering

// Up to this many vertices, a copy whose vertices the positions alone do not tell apart is
// tried again with the vertices its triangles leave no choice for (renumbering::left_no_choice;
// a printer bed's reorder: 0.01-0.09 s in all; where it fails, about 13 microseconds per vertex:
// a reorder of dragon_vrip_res3.ply, 23K vertices, 0.44 -> 0.74 s); a larger one goes to the
// registration as before.
constexpr Eigen::Index kMaxConsistencyVertices = 10'000;
// ... as far from its original vertex as these shares of the tolerance, tried in turn: the
// triangles, not the distances, decide.
constexpr std::array<double, 4> kConsistencyReaches{0.2, 0.4, 0.8, 2.0};

}  // namespace

// The suspect's positions in the original's vertex order, when it is the original's mesh
// renumbered where it stands: a writer that numbers the vertices its own way and moves nothing
// but the mark (a Draco re-encoding, whose edgebreaker numbers the points in its traversal
// order: every marked Draco file) keeps every triangle between the same vertices. Such a copy
// read through registration depended on the registration finding the one right pose, which an
// assembly of like parts (a Collada grid of 64 cubes: its marked Draco file z 2.18, reordered
// copies 4.47 in 2 of 5 orders) or an instanced mesh (registered onto its other instance, z
// 0.41) can miss, and it cost a registration (the converted DirectX character's marked Draco
// file: 0.19 s, now 0.02 s). The vertices that stand for an original vertex beyond doubt
// (mutual nearest in place, within \p tolerance, the next vertex at least twice as far either
// way: kMaxStartRatio) start the correspondence; through the triangles it reaches the others
// (a suspect triangle with two corners known is the original's triangle on their edge whose
// third corner is clearly the nearest), so vertices nearer each other than the mark moves them
// (the character's: 0.02% of the diagonal apart) are told apart. It holds when every vertex is
// reached, each original vertex once, and every suspect triangle is a triangle of the
// original. Where no vertex is beyond doubt (a CAD plate whose vertices crowd on the arcs of its
// outline, 0.2 mm apart where the mark moves them 0.3 mm), the vertices the triangles leave no
// choice for start it instead (renumbering::left_no_choice; a reordered printer bed: z 2.61 ->
// 9.8). Else the copy is registered as before (a dense scan, whose vertices the mark moves by a
// good part of their spacing, is). Positions and triangles only, never the key.
std::optional<Positions> renumbered_in_place(const TriangleMesh& original,
                                             const TriangleMesh& suspect, double tolerance,
                                             int threads)
{
    if (suspect.V.rows() != original.V.rows() || suspect.F.rows() != original.F.rows() ||
        original.F.rows() == 0)
    {
        return std::nullopt;
    }
    // No vertex moves further than \p tolerance, so no side of the bounding box does: a copy
    // moved elsewhere is turned away before the kd-trees and the queries (the generated 1M
    // mesh moved and reordered: 4.2 s of its 7.4 s detection went here).
    const BoundingBox in_original = bounding_box(original.V);
    const BoundingBox in_suspect = bounding_box(suspect.V);
    if ((in_original.min - in_suspect.min).cwiseAbs().maxCoeff() > tolerance ||
        (in_original.max - in_suspect.max).cwiseAbs().maxCoeff() > tolerance)
    {
        return std::nullopt;
    }
    const PointKdTree original_tree(original.V);
    const renumbering::EdgeThirds by_edge = renumbering::edge_thirds(original);
    const VertexFaces faces_of = vertex_faces(suspect);  // the suspect's triangles by vertex
    if (auto in_order = renumbering::propagated(
            original, suspect, by_edge, faces_of,
            renumbering::beyond_doubt(original, suspect, original_tree, tolerance, threads),
            tolerance))
    {
        return in_order;
    }
    if (original.V.rows() > kMaxConsistencyVertices)
    {
        return std::nullopt;
    }
    const renumbering::NearestOriginals nearest =
        renumbering::nearest_originals(suspect, original_tree);
    const VertexAdjacency original_adjacency = vertex_adjacency(original);
    const VertexAdjacency suspect_adjacency = vertex_adjacency(suspect);
    // The reach grows until the triangles leave some vertices no choice: a small one keeps
    // few choices per vertex (the arcs of a printer bed put 25 vertices within 5 mm), a vertex
    // the mark moved beyond it has none, and where vertices crowd the mark moves some far (13
    // amplitudes on PrusaSlicer's Ender 2 bed: its 200 vertices carry a mark whose surface
    // distance is what the plate's faces show).
    for (const double reach : kConsistencyReaches)
    {
        const double r = reach * tolerance;
        if (const auto starts =
                renumbering::left_no_choice(nearest, original_adjacency, suspect_adjacency, r))
        {
            if (std::none_of(starts->begin(), starts->end(), [](std::int32_t x) { return x >= 0; }))
            {
                break;  // a larger reach leaves more choices, never fewer
            }
            if (auto in_order =
                    renumbering::propagated(original, suspect, by_edge, faces_of, *starts, r))
            {
                return in_order;
            }
        }
    }
    return std::nullopt;
}

}  // namespace meshmark

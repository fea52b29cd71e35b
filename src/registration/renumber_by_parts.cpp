// SPDX-License-Identifier: MIT
// A copy made of the original's parts, each with its triangles in the original's order, the
// parts in an order of the tool's own (Blender joins a model's objects so): the renumbering read
// off each part's triangles, parts that look alike told apart by where they stand.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

#include <Eigen/Geometry>
#include <boost/pending/disjoint_sets.hpp>

#include "meshmark/registration/renumbering.h"
#include "meshmark/registration/similarity_fit.h"

namespace meshmark
{
namespace
{

// Original vertices the parts must reach for the copy to be taken as the original's parts
// renumbered: the rest (parts a tool changed, dropped or merged with another) are left out as a
// crop is. Chosen by hand, as the cropped share above which a copy is rather registered; no
// study on record.
constexpr double kMinReached = 0.9;
// Parts of one shape beyond this count on either side are left unmatched (their matching by
// position costs the product of the counts). Chosen by hand; no study on record.
constexpr std::size_t kMaxAlike = 512;

// A part: its triangles in the mesh's order, its vertices in the order its triangles first use
// them, and its triangles written over those local numbers (the same for the same part
// numbered another way).
struct Part
{
    std::vector<std::int32_t> vertices;
    std::vector<std::int32_t> shape;  // 3 local corners per triangle
    std::uint64_t hash = 0;
};

bool is_degenerate(const TriangleMesh& mesh, Eigen::Index f)
{
    return mesh.F(f, 0) == mesh.F(f, 1) || mesh.F(f, 1) == mesh.F(f, 2) ||
           mesh.F(f, 2) == mesh.F(f, 0);
}

// The parts of \p mesh connected by its triangles (triangles with a repeated corner left out:
// Blender's import drops them), in the order of their first triangle.
std::vector<Part> parts_of(const TriangleMesh& mesh)
{
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    boost::disjoint_sets_with_storage<> sets(n);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        if (!is_degenerate(mesh, f))
        {
            sets.union_set(mesh.F(f, 0), mesh.F(f, 1));
            sets.union_set(mesh.F(f, 1), mesh.F(f, 2));
        }
    }
    std::vector<Part> parts;
    std::unordered_map<std::size_t, std::size_t> part_of_root;
    std::vector<std::int32_t> local(n, -1);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        if (is_degenerate(mesh, f))
        {
            continue;
        }
        const std::size_t root = sets.find_set(static_cast<std::size_t>(mesh.F(f, 0)));
        const auto [it, is_new] = part_of_root.try_emplace(root, parts.size());
        if (is_new)
        {
            parts.emplace_back();
        }
        Part& part = parts[it->second];
        for (Eigen::Index k = 0; k < 3; ++k)
        {
            const auto v = static_cast<std::size_t>(mesh.F(f, k));
            if (local[v] < 0)
            {
                local[v] = static_cast<std::int32_t>(part.vertices.size());
                part.vertices.push_back(mesh.F(f, k));
            }
            part.shape.push_back(local[v]);
        }
    }
    for (Part& part : parts)
    {
        std::uint64_t h = 0xcbf29ce484222325ULL;  // FNV-1a over the local corners
        for (const std::int32_t c : part.shape)
        {
            h = (h ^ static_cast<std::uint32_t>(c)) * 0x100000001b3ULL;
        }
        part.hash = h;
    }
    return parts;
}

Eigen::Vector3d centroid(const Positions& V, const Part& part)
{
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const std::int32_t v : part.vertices)
    {
        sum += V.row(v).transpose();
    }
    return sum / static_cast<double>(part.vertices.size());
}

// Parts of one shape: the suspect's and the original's.
struct Alike
{
    std::vector<std::size_t> suspect;
    std::vector<std::size_t> original;
};

}  // namespace

std::optional<TriangleRenumbering> renumbered_by_parts(const TriangleMesh& original,
                                                       const TriangleMesh& suspect)
{
    const auto n = static_cast<std::size_t>(original.V.rows());
    // Parts that reach kMinReached of the vertices bring about as large a share of the
    // triangles: a copy with under half of them (a simplification) is not looked at.
    if (n == 0 || original.F.rows() == 0 || 2 * suspect.F.rows() < original.F.rows())
    {
        return std::nullopt;
    }
    const std::vector<Part> original_parts = parts_of(original);
    const std::vector<Part> suspect_parts = parts_of(suspect);
    // Parts grouped by shape (the hash, then the shape itself against collisions).
    std::vector<Alike> groups;
    std::unordered_multimap<std::uint64_t, std::size_t> group_of_hash;
    const auto group_of = [&](const std::vector<Part>& parts, std::size_t i) -> Alike&
    {
        const auto [first, last] = group_of_hash.equal_range(parts[i].hash);
        for (auto it = first; it != last; ++it)
        {
            const Alike& g = groups[it->second];
            const Part& member = g.original.empty() ? suspect_parts[g.suspect.front()]
                                                    : original_parts[g.original.front()];
            if (member.shape == parts[i].shape)
            {
                return groups[it->second];
            }
        }
        group_of_hash.emplace(parts[i].hash, groups.size());
        return groups.emplace_back();
    };
    for (std::size_t i = 0; i < original_parts.size(); ++i)
    {
        group_of(original_parts, i).original.push_back(i);
    }
    for (std::size_t i = 0; i < suspect_parts.size(); ++i)
    {
        group_of(suspect_parts, i).suspect.push_back(i);
    }

    TriangleRenumbering found;
    std::vector<std::int32_t> suspect_of(n, -1);
    std::size_t reached = 0;
    const auto take = [&](const Part& s, const Part& o)
    {
        for (std::size_t k = 0; k < o.vertices.size(); ++k)
        {
            suspect_of[static_cast<std::size_t>(o.vertices[k])] = s.vertices[k];
        }
        reached += o.vertices.size();
    };
    // Parts with a shape of their own on both sides first; they place the copy.
    std::vector<const Alike*> alike;
    for (const Alike& g : groups)
    {
        if (g.suspect.size() == 1 && g.original.size() == 1)
        {
            take(suspect_parts[g.suspect[0]], original_parts[g.original[0]]);
        }
        else if (!g.suspect.empty() && !g.original.empty() && g.suspect.size() <= kMaxAlike &&
                 g.original.size() <= kMaxAlike)
        {
            alike.push_back(&g);
        }
    }
    if (!alike.empty() && reached >= 4)
    {
        // Parts of one shape go, nearest first, to the original's after the similarity that the
        // parts of their own shape give (suspect -> original).
        Eigen::Matrix3Xd from(3, static_cast<Eigen::Index>(reached));
        Eigen::Matrix3Xd to(3, static_cast<Eigen::Index>(reached));
        Eigen::Index c = 0;
        for (std::size_t i = 0; i < n; ++i)
        {
            if (suspect_of[i] >= 0)
            {
                from.col(c) = suspect.V.row(suspect_of[i]).transpose();
                to.col(c) = original.V.row(static_cast<Eigen::Index>(i)).transpose();
                ++c;
            }
        }
        const Eigen::Matrix4d T = fit_similarity(from, to);
        if (T.allFinite())
        {
            for (const Alike* g : alike)
            {
                struct Pair
                {
                    double distance;
                    std::size_t s, o;
                };
                std::vector<Pair> pairs;
                pairs.reserve(g->suspect.size() * g->original.size());
                for (const std::size_t s : g->suspect)
                {
                    const Eigen::Vector3d at =
                        (T * centroid(suspect.V, suspect_parts[s]).homogeneous()).head<3>();
                    for (const std::size_t o : g->original)
                    {
                        pairs.push_back(
                            {(at - centroid(original.V, original_parts[o])).norm(), s, o});
                    }
                }
                std::sort(pairs.begin(), pairs.end(),
                          [](const Pair& a, const Pair& b) { return a.distance < b.distance; });
                std::vector<std::uint8_t> suspect_taken(suspect_parts.size(), 0);
                std::vector<std::uint8_t> original_taken(original_parts.size(), 0);
                for (const Pair& p : pairs)
                {
                    if (suspect_taken[p.s] == 0 && original_taken[p.o] == 0)
                    {
                        suspect_taken[p.s] = original_taken[p.o] = 1;
                        take(suspect_parts[p.s], original_parts[p.o]);
                    }
                }
            }
        }
    }
    if (static_cast<double>(reached) < kMinReached * static_cast<double>(n))
    {
        return std::nullopt;
    }
    // Rows no part reached: the suspect's centroid, left out by the mask.
    const Eigen::RowVector3d middle = suspect.V.colwise().mean();
    found.in_order.resize(original.V.rows(), 3);
    if (reached < n)
    {
        found.reached.assign(n, 0);
    }
    for (std::size_t i = 0; i < n; ++i)
    {
        const bool is_reached = suspect_of[i] >= 0;
        found.in_order.row(static_cast<Eigen::Index>(i)) =
            is_reached ? suspect.V.row(suspect_of[i]) : middle;
        if (reached < n)
        {
            found.reached[i] = is_reached ? 1 : 0;
        }
    }
    found.unreached = n - reached;
    return found;
}

}  // namespace meshmark

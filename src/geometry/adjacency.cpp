// SPDX-License-Identifier: MIT
#include "meshmark/geometry/adjacency.h"

#include <algorithm>
#include <array>
#include <numeric>
#include <utility>

namespace meshmark
{
namespace
{

// Calls visit(a, b) once for each of the three corner pairs (edges) of every face whose two
// ends differ, in face order.
template <typename Visit>
void for_each_face_edge(const TriangleMesh& mesh, Visit&& visit)
{
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            const std::int32_t a = mesh.F(f, c);
            const std::int32_t b = mesh.F(f, (c + 1) % 3);
            if (a != b)
            {
                visit(a, b);
            }
        }
    }
}

// Prefix sums of per-row counts: offsets[v] = sum of counts[0..v).
std::vector<std::size_t> row_offsets(const std::vector<std::size_t>& counts)
{
    std::vector<std::size_t> offsets(counts.size() + 1, 0);
    for (std::size_t v = 0; v < counts.size(); ++v)
    {
        offsets[v + 1] = offsets[v] + counts[v];
    }
    return offsets;
}

}  // namespace

namespace
{

// The adjacency of the edges for_each_edge(visit) visits (each as visit(a, b), a != b, in any
// number of repeats): a counting sort into rows (O(#F)), then each short row sorted and
// deduplicated, far cheaper than sorting all 6 #F half-edges globally on large meshes.
template <typename ForEachEdge>
VertexAdjacency adjacency_of_edges(std::size_t n, ForEachEdge&& for_each_edge)
{
    std::vector<std::size_t> counts(n, 0);
    for_each_edge(
        [&](std::int32_t a, std::int32_t b)
        {
            ++counts[static_cast<std::size_t>(a)];
            ++counts[static_cast<std::size_t>(b)];
        });
    std::vector<std::size_t> cursor = row_offsets(counts);
    std::vector<std::int32_t> raw(cursor.back());
    for_each_edge(
        [&](std::int32_t a, std::int32_t b)
        {
            raw[cursor[static_cast<std::size_t>(a)]++] = b;
            raw[cursor[static_cast<std::size_t>(b)]++] = a;
        });

    VertexAdjacency adjacency;
    adjacency.offsets.assign(n + 1, 0);
    adjacency.neighbors.reserve(raw.size() / 2);
    std::size_t begin = 0;
    for (std::size_t v = 0; v < n; ++v)
    {
        const auto row_begin = raw.begin() + static_cast<std::ptrdiff_t>(begin);
        const auto row_end = row_begin + static_cast<std::ptrdiff_t>(counts[v]);
        std::sort(row_begin, row_end);
        const auto unique_end = std::unique(row_begin, row_end);
        adjacency.neighbors.insert(adjacency.neighbors.end(), row_begin, unique_end);
        adjacency.offsets[v + 1] = adjacency.neighbors.size();
        begin += counts[v];
    }
    return adjacency;
}

// Per face, bit c set when its edge (c, c + 1) lies inside one of mesh.polygons: an edge two
// of the polygon's triangles share. A polygon whose rows are not all in range (a mesh changed
// after it was read) marks nothing.
std::vector<std::uint8_t> inner_polygon_edges(const TriangleMesh& mesh)
{
    std::vector<std::uint8_t> inner(static_cast<std::size_t>(mesh.F.rows()), 0);
    std::vector<std::array<std::int32_t, 4>> edges;  // the smaller end, the larger, row, corner
    for (const PolygonRows& polygon : mesh.polygons)
    {
        const Eigen::Index first = polygon.first;
        const Eigen::Index end = first + static_cast<Eigen::Index>(polygon.corners) - 2;
        if (polygon.corners < 4 || end > mesh.F.rows())
        {
            continue;
        }
        edges.clear();
        for (Eigen::Index f = first; f < end; ++f)
        {
            for (int c = 0; c < 3; ++c)
            {
                const std::int32_t a = mesh.F(f, c);
                const std::int32_t b = mesh.F(f, (c + 1) % 3);
                edges.push_back(
                    {std::min(a, b), std::max(a, b), static_cast<std::int32_t>(f - first), c});
            }
        }
        std::sort(edges.begin(), edges.end());
        for (std::size_t i = 0; i + 1 < edges.size(); ++i)
        {
            if (edges[i][0] == edges[i + 1][0] && edges[i][1] == edges[i + 1][1])
            {
                for (const std::size_t k : {i, i + 1})
                {
                    inner[static_cast<std::size_t>(first + edges[k][2])] |=
                        static_cast<std::uint8_t>(1U << edges[k][3]);
                }
            }
        }
    }
    return inner;
}

}  // namespace

VertexAdjacency vertex_adjacency(const TriangleMesh& mesh)
{
    return adjacency_of_edges(static_cast<std::size_t>(mesh.V.rows()),
                              [&](auto&& visit) { for_each_face_edge(mesh, visit); });
}

VertexAdjacency polygon_adjacency(const TriangleMesh& mesh)
{
    if (mesh.polygons.empty())
    {
        return vertex_adjacency(mesh);
    }
    const std::vector<std::uint8_t> inner = inner_polygon_edges(mesh);
    return adjacency_of_edges(
        static_cast<std::size_t>(mesh.V.rows()),
        [&](auto&& visit)
        {
            for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
            {
                for (int c = 0; c < 3; ++c)
                {
                    const std::int32_t a = mesh.F(f, c);
                    const std::int32_t b = mesh.F(f, (c + 1) % 3);
                    if (a != b && (inner[static_cast<std::size_t>(f)] & (1U << c)) == 0)
                    {
                        visit(a, b);
                    }
                }
            }
        });
}

VertexFaces vertex_faces(const TriangleMesh& mesh)
{
    std::vector<std::size_t> counts(static_cast<std::size_t>(mesh.V.rows()), 0);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            ++counts[static_cast<std::size_t>(mesh.F(f, c))];
        }
    }
    VertexFaces incidence;
    incidence.offsets = row_offsets(counts);
    incidence.faces.resize(incidence.offsets.back());
    std::vector<std::size_t> cursor(incidence.offsets.begin(), incidence.offsets.end() - 1);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            incidence.faces[cursor[static_cast<std::size_t>(mesh.F(f, c))]++] = f;
        }
    }
    return incidence;
}

EdgeStatistics edge_statistics(const TriangleMesh& mesh)
{
    // Bucket every face edge under its smaller end, remembering the larger end and whether the
    // face runs along it from small to large (+1) or back (-1).
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    std::vector<std::size_t> counts(n, 0);
    for_each_face_edge(mesh, [&](std::int32_t a, std::int32_t b)
                       { ++counts[static_cast<std::size_t>(std::min(a, b))]; });
    std::vector<std::size_t> cursor = row_offsets(counts);
    std::vector<std::pair<std::int32_t, int>> entries(cursor.back());
    for_each_face_edge(mesh,
                       [&](std::int32_t a, std::int32_t b)
                       {
                           entries[cursor[static_cast<std::size_t>(std::min(a, b))]++] = {
                               std::max(a, b), a < b ? 1 : -1};
                       });

    // Within a row, equal larger ends form one undirected edge; count its faces and directions.
    EdgeStatistics stats;
    std::size_t begin = 0;
    for (std::size_t v = 0; v < n; ++v)
    {
        const auto row_begin = entries.begin() + static_cast<std::ptrdiff_t>(begin);
        const auto row_end = row_begin + static_cast<std::ptrdiff_t>(counts[v]);
        std::sort(row_begin, row_end);
        for (auto it = row_begin; it != row_end;)
        {
            auto next = it;
            int direction_sum = 0;
            while (next != row_end && next->first == it->first)
            {
                direction_sum += next->second;
                ++next;
            }
            const auto uses = static_cast<std::size_t>(next - it);
            ++stats.edge_count;
            if (uses == 1)
            {
                ++stats.boundary_edge_count;
            }
            else if (uses > 2)
            {
                ++stats.non_manifold_edge_count;
            }
            else if (direction_sum != 0)
            {
                ++stats.inconsistent_edge_count;
            }
            it = next;
        }
        begin += counts[v];
    }
    return stats;
}

std::vector<std::int32_t> position_ids(const Positions& V)
{
    const auto n = static_cast<std::size_t>(V.rows());
    std::vector<std::int32_t> order(n);
    std::iota(order.begin(), order.end(), 0);
    auto position = [&](std::int32_t v) {
        return std::array<double, 3>{V(v, 0), V(v, 1), V(v, 2)};
    };
    std::sort(order.begin(), order.end(),
              [&](std::int32_t a, std::int32_t b)
              { return std::pair(position(a), a) < std::pair(position(b), b); });
    std::vector<std::int32_t> id(n);
    for (std::size_t k = 0; k < n; ++k)
    {
        const std::int32_t v = order[k];
        id[static_cast<std::size_t>(v)] = k > 0 && position(order[k - 1]) == position(v)
                                              ? id[static_cast<std::size_t>(order[k - 1])]
                                              : v;
    }
    return id;
}

}  // namespace meshmark

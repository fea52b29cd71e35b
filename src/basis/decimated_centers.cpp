// SPDX-License-Identifier: MIT
#include "meshmark/basis/decimated_centers.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include <meshoptimizer.h>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

// Relative error bound handed to meshoptimizer: far above any mesh's extent, so only the
// index target stops it (as in attacks/simplification_meshopt.cpp).
constexpr float kUnboundedError = 1.0e3F;
// Below this excess over k, passes collapse one edge at a time (one vertex each); chosen by
// hand; no study on record.
constexpr std::size_t kSingleStepExcess = 16;
// A bound on the passes against a decimation that stops making progress; chosen by hand; no
// study on record.
constexpr int kMaxPasses = 10000;

// A decimation state: triangles over a compact vertex set, and each vertex's mesh row.
struct Piece
{
    std::vector<unsigned int> indices;
    std::vector<float> positions;   // 3 per vertex
    std::vector<std::int32_t> row;  // mesh row of each vertex
    [[nodiscard]] std::size_t vertex_count() const { return row.size(); }
};

// Drops the vertices no triangle uses (keeping the others in order).
Piece compact(const std::vector<unsigned int>& indices, const Piece& from)
{
    std::vector<std::int64_t> slot(from.vertex_count(), -1);
    for (const auto i : indices)
    {
        slot[i] = 0;
    }
    Piece out;
    for (std::size_t v = 0; v < from.vertex_count(); ++v)
    {
        if (slot[v] == 0)
        {
            slot[v] = static_cast<std::int64_t>(out.row.size());
            out.row.push_back(from.row[v]);
            out.positions.insert(out.positions.end(),
                                 from.positions.begin() + static_cast<std::ptrdiff_t>(3 * v),
                                 from.positions.begin() + static_cast<std::ptrdiff_t>(3 * v + 3));
        }
    }
    out.indices.reserve(indices.size());
    for (const auto i : indices)
    {
        out.indices.push_back(static_cast<unsigned int>(slot[i]));
    }
    return out;
}

// The active rows welded by exact position (first row of each position wins), as triangles
// without degenerate ones, positions relative to the centroid.
Piece welded_piece(const TriangleMesh& mesh, const std::vector<std::int32_t>& active)
{
    Eigen::RowVector3d centroid = Eigen::RowVector3d::Zero();
    for (const auto i : active)
    {
        centroid += mesh.V.row(i);
    }
    centroid /= static_cast<double>(active.size());
    std::map<std::array<double, 3>, unsigned int> first;
    std::vector<std::int64_t> slot(static_cast<std::size_t>(mesh.V.rows()), -1);
    Piece all;
    for (const auto i : active)
    {
        const std::array<double, 3> p = {mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2)};
        const auto [it, is_new] = first.emplace(p, static_cast<unsigned int>(all.row.size()));
        if (is_new)
        {
            all.row.push_back(i);
            for (int d = 0; d < 3; ++d)
            {
                all.positions.push_back(
                    static_cast<float>(p[static_cast<std::size_t>(d)] - centroid(d)));
            }
        }
        slot[static_cast<std::size_t>(i)] = it->second;
    }
    std::vector<unsigned int> indices;
    indices.reserve(3 * static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const auto a = slot[static_cast<std::size_t>(mesh.F(f, 0))];
        const auto b = slot[static_cast<std::size_t>(mesh.F(f, 1))];
        const auto c = slot[static_cast<std::size_t>(mesh.F(f, 2))];
        if (a >= 0 && b >= 0 && c >= 0 && a != b && b != c && a != c)
        {
            indices.push_back(static_cast<unsigned int>(a));
            indices.push_back(static_cast<unsigned int>(b));
            indices.push_back(static_cast<unsigned int>(c));
        }
    }
    return compact(indices, all);
}

}  // namespace

std::vector<std::int32_t> decimated_centers(const TriangleMesh& mesh,
                                            const std::vector<std::int32_t>& active, int k)
{
    if (k < 1)
    {
        throw InvalidOption("basis size must be positive, got " + std::to_string(k) + ".");
    }
    if (mesh.is_point_cloud())
    {
        throw InvalidMesh(
            "decimated centers need triangles, but the mesh is a point cloud (no faces); "
            "use random centers (--centers random).");
    }
    const auto goal = static_cast<std::size_t>(k);
    Piece piece = welded_piece(mesh, active);
    if (piece.vertex_count() < goal)
    {
        throw InvalidMesh("the mesh has only " + std::to_string(piece.vertex_count()) +
                          " distinct vertex positions on its triangles, fewer than the " +
                          std::to_string(k) +
                          " basis functions requested (use a smaller --basis-size).");
    }
    // Each pass removes about half of the excess (one collapse at a time near the goal); a
    // pass that overshoots is undone and retried one collapse at a time.
    bool single_step = false;
    std::vector<unsigned int> destination;
    for (int pass = 0; pass < kMaxPasses && piece.vertex_count() > goal; ++pass)
    {
        const std::size_t excess = piece.vertex_count() - goal;
        const std::size_t triangles = piece.indices.size() / 3;
        std::size_t target_triangles = triangles - 1;
        if (!single_step && excess > kSingleStepExcess)
        {
            const double keep =
                static_cast<double>(goal + excess / 2) / static_cast<double>(piece.vertex_count());
            target_triangles = std::min(
                triangles - 1,
                static_cast<std::size_t>(std::llround(keep * static_cast<double>(triangles))));
        }
        destination.resize(piece.indices.size());
        const std::size_t kept =
            meshopt_simplify(destination.data(), piece.indices.data(), piece.indices.size(),
                             piece.positions.data(), piece.vertex_count(), 3 * sizeof(float),
                             3 * target_triangles, kUnboundedError, 0, nullptr);
        if (kept == piece.indices.size())
        {
            break;  // no collapse left
        }
        destination.resize(kept);
        Piece next = compact(destination, piece);
        if (next.vertex_count() < goal)
        {
            if (single_step)
            {
                break;  // one collapse removed more than one vertex: keep the state above k
            }
            single_step = true;
            continue;
        }
        piece = std::move(next);
    }
    if (piece.vertex_count() > goal + kSingleStepExcess)
    {
        throw InvalidMesh("the decimation stopped at " + std::to_string(piece.vertex_count()) +
                          " vertices, above the " + std::to_string(k) +
                          " centers requested (too many separate pieces?); use random centers "
                          "(--centers random).");
    }
    // Survivors in increasing row order; a few left over by a blocked collapse are dropped
    // from the end (deterministic).
    std::vector<std::int32_t> centers = piece.row;
    std::sort(centers.begin(), centers.end());
    centers.resize(goal);
    return centers;
}

}  // namespace meshmark

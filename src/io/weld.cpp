// SPDX-License-Identifier: MIT
// Welding of world-space positions gathered from several parts (glTF primitives, 3MF objects).
#include "io/detail/weld.h"

#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Core>

namespace meshmark::detail
{

std::vector<std::int32_t> weld_world_positions(const std::vector<double>& world,
                                               const std::vector<std::int32_t>& group,
                                               std::size_t group_count, double tolerance_rel,
                                               std::vector<double>& xyz)
{
    const std::size_t n = group.size();
    std::vector<std::int32_t> welded(n, -1);
    xyz.clear();
    xyz.reserve(3 * n);

    // Exact welding of bit-identical world positions (seams, parts sharing a transform).
    struct Key
    {
        std::array<std::uint64_t, 3> bits;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash
    {
        std::size_t operator()(const Key& k) const noexcept
        {
            std::uint64_t h = 0x9e3779b97f4a7c15ULL;
            for (const auto b : k.bits)
            {
                h ^= b + 0x9e3779b97f4a7c15ULL + (h << 6U) + (h >> 2U);
            }
            return static_cast<std::size_t>(h);
        }
    };
    const auto key_of = [&](std::size_t i)
    {
        Key k{};
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double v = world[3 * i + d] == 0.0 ? 0.0 : world[3 * i + d];  // -0 == +0
            std::memcpy(&k.bits[d], &v, sizeof(double));
        }
        return k;
    };
    std::unordered_map<Key, std::int32_t, KeyHash> exact;
    exact.reserve(n);

    // Tolerance welding across different transforms: a hash grid of cell = tolerance, the
    // 27 cells around a vertex hold every candidate (hand-written: io depends on core only).
    const bool use_tolerance = group_count > 1;
    double tolerance = 0.0;
    if (use_tolerance && n > 0)
    {
        Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
        Eigen::Vector3d hi = -lo;
        for (std::size_t i = 0; i < n; ++i)
        {
            const Eigen::Vector3d p(world[3 * i], world[3 * i + 1], world[3 * i + 2]);
            lo = lo.cwiseMin(p);
            hi = hi.cwiseMax(p);
        }
        tolerance = tolerance_rel * (hi - lo).norm();
    }
    const bool use_grid = use_tolerance && tolerance > 0.0;
    const auto cell_of = [&](const double* p)
    {
        std::array<std::int64_t, 3> c{};
        for (std::size_t d = 0; d < 3; ++d)
        {
            c[d] = static_cast<std::int64_t>(std::floor(p[d] / tolerance));
        }
        return c;
    };
    struct CellHash
    {
        std::size_t operator()(const std::array<std::int64_t, 3>& c) const noexcept
        {
            return static_cast<std::size_t>(static_cast<std::uint64_t>(c[0]) * 73856093ULL ^
                                            static_cast<std::uint64_t>(c[1]) * 19349663ULL ^
                                            static_cast<std::uint64_t>(c[2]) * 83492791ULL);
        }
    };
    std::unordered_map<std::array<std::int64_t, 3>, std::vector<std::int32_t>, CellHash> grid;
    std::unordered_set<std::uint64_t> members;  // welded * groups + group
    const auto member_key = [&](std::int32_t w, std::int32_t g)
    { return static_cast<std::uint64_t>(w) * group_count + static_cast<std::uint64_t>(g); };

    for (std::size_t i = 0; i < n; ++i)
    {
        const Key key = key_of(i);
        const double* p = world.data() + 3 * i;
        const std::int32_t g = group[i];
        if (const auto found = exact.find(key); found != exact.end())
        {
            welded[i] = found->second;
            if (use_grid)
            {
                members.insert(member_key(found->second, g));
            }
            continue;
        }
        std::int32_t best = -1;
        if (use_grid)
        {
            // The nearest welded vertex within tolerance that no vertex of this group joined.
            const auto c = cell_of(p);
            double best_d2 = tolerance * tolerance;
            for (std::int64_t dx = -1; dx <= 1; ++dx)
            {
                for (std::int64_t dy = -1; dy <= 1; ++dy)
                {
                    for (std::int64_t dz = -1; dz <= 1; ++dz)
                    {
                        const auto cell = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
                        if (cell == grid.end())
                        {
                            continue;
                        }
                        for (const auto w : cell->second)
                        {
                            const double* q = xyz.data() + 3 * static_cast<std::size_t>(w);
                            const double d2 = (p[0] - q[0]) * (p[0] - q[0]) +
                                              (p[1] - q[1]) * (p[1] - q[1]) +
                                              (p[2] - q[2]) * (p[2] - q[2]);
                            if ((d2 < best_d2 || (d2 == best_d2 && w < best)) &&
                                members.count(member_key(w, g)) == 0)
                            {
                                best = w;
                                best_d2 = d2;
                            }
                        }
                    }
                }
            }
        }
        if (best < 0)
        {
            best = static_cast<std::int32_t>(xyz.size() / 3);
            xyz.insert(xyz.end(), {p[0], p[1], p[2]});
            if (use_grid)
            {
                grid[cell_of(p)].push_back(best);
            }
        }
        welded[i] = best;
        exact.emplace(key, best);
        if (use_grid)
        {
            members.insert(member_key(best, g));
        }
    }
    return welded;
}

}  // namespace meshmark::detail

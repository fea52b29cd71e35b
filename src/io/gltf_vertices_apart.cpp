// SPDX-License-Identifier: MIT
// The preserving glTF writer's last step on the positions: vertices the reader told apart stay
// apart once their new values are rounded to float32 (GltfWriter::keep_vertices_apart).
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <limits>
#include <set>
#include <tuple>
#include <vector>

#include "io/detail/gltf_writer.h"

namespace meshmark::detail
{
namespace
{

// Whether two of \p entries (each with .key, three finite floats without -0, and .vertex >= 0)
// of different vertices have equal keys: one pass over an open-addressing table of key bits
// to the first vertex seen with them, so the usual case (no such pair) costs no sort.
template <typename Entry>
bool has_shared_key(const std::vector<Entry>& entries)
{
    // 8-byte slots (a 32-bit hash of the key and the entry's index + 1), so the table of a
    // 50K-vertex asset is 1 MiB and mostly stays in the second-level cache.
    struct Slot
    {
        std::uint32_t hash = 0;
        std::uint32_t entry = 0;  // 0: empty
    };
    std::size_t capacity = 16;
    while (capacity < 2 * entries.size())
    {
        capacity *= 2;
    }
    std::vector<Slot> table(capacity);
    const std::size_t mask = capacity - 1;
    for (std::size_t index = 0; index < entries.size(); ++index)
    {
        const Entry& entry = entries[index];
        std::array<std::uint32_t, 3> bits{};
        std::memcpy(bits.data(), entry.key.data(), sizeof(bits));
        std::uint64_t h = bits[0];
        h = h * 0x9E3779B97F4A7C15ULL ^ bits[1];
        h = h * 0xC2B2AE3D27D4EB4FULL ^ bits[2];
        h ^= h >> 31U;
        h *= 0x94D049BB133111EBULL;
        h ^= h >> 29U;
        const auto hash = static_cast<std::uint32_t>(h >> 32U);
        for (std::size_t i = static_cast<std::size_t>(h) & mask;; i = (i + 1) & mask)
        {
            Slot& slot = table[i];
            if (slot.entry == 0)
            {
                slot = {hash, static_cast<std::uint32_t>(index + 1)};
                break;
            }
            if (slot.hash == hash)
            {
                const Entry& seen = entries[slot.entry - 1];
                if (seen.key == entry.key)
                {
                    if (seen.vertex != entry.vertex)
                    {
                        return true;
                    }
                    break;
                }
            }
        }
    }
    return false;
}

}  // namespace

// Vertices the reader told apart must stay apart: two welded vertices whose new float32
// positions under one transform round to the same three floats are one vertex when the file is
// read again (an IFC model's corners a float32 step apart, both moved by the mark: the
// building of the real-assets tests lost 182 of its 16,942 vertices so, and its marked copy was
// no longer read vertex for vertex). The later of the two moves by float32 steps along x until
// it is alone, all its elements alike. Float32 accessors placed by a node transform only (the
// others' values are integers on a grid, or per-vertex skinned).
void GltfWriter::keep_vertices_apart(std::vector<Plan>& plans) const
{
    using Key = std::array<float, 3>;
    const auto key_of = [](const double* xyz)
    {
        Key k{};
        for (std::size_t d = 0; d < 3; ++d)
        {
            k[d] = static_cast<float>(xyz[d]) + 0.0F;  // -0 reads as +0
        }
        return k;
    };
    // The eligible plans, grouped by their transform (groups in order of first appearance).
    std::vector<Eigen::Matrix4d> transforms;
    std::vector<std::vector<std::size_t>> members;
    std::int32_t vertex_count = 0;
    for (std::size_t p = 0; p < plans.size(); ++p)
    {
        const Plan& plan = plans[p];
        if (plan.is_draco || plan.as_float || plan.component != GltfComponent::Float32)
        {
            continue;
        }
        const auto& record = asset_.accessors[plan.record];
        if (!record.skinning.empty())
        {
            continue;
        }
        for (const auto w : record.welded)
        {
            vertex_count = std::max(vertex_count, w + 1);
        }
        std::size_t g = 0;
        while (g < transforms.size() && transforms[g] != record.to_world)
        {
            ++g;
        }
        if (g == transforms.size())
        {
            transforms.push_back(record.to_world);
            members.emplace_back();
        }
        members[g].push_back(p);
    }
    struct Entry
    {
        Key key;
        std::int32_t vertex;
        bool is_fixed;  // left where it was: it keeps its place
    };
    std::vector<std::uint32_t> last_group(static_cast<std::size_t>(vertex_count),
                                          std::numeric_limits<std::uint32_t>::max());
    for (std::size_t g = 0; g < transforms.size(); ++g)
    {
        // One entry per vertex that moved (all its elements under this transform have the
        // same new coordinates) and one per element left in place; sorted, equal neighbours of
        // different vertices are the collisions (none, almost always).
        std::vector<Entry> entries;
        for (const std::size_t p : members[g])
        {
            const auto& record = asset_.accessors[plans[p].record];
            for (std::size_t e = 0; e < record.elements.size(); ++e)
            {
                const std::int32_t w = record.welded[e];
                if (plans[p].rewrite[e] == 0)
                {
                    if (record.elements[e].buffer >= 0)
                    {
                        entries.push_back({key_of(&plans[p].stored[3 * e]), w, true});
                    }
                }
                else if (last_group[static_cast<std::size_t>(w)] != g)
                {
                    last_group[static_cast<std::size_t>(w)] = static_cast<std::uint32_t>(g);
                    entries.push_back({key_of(&plans[p].stored[3 * e]), w, false});
                }
            }
        }
        if (!has_shared_key(entries))
        {
            continue;  // no collision to sort out
        }
        const auto by_key = [](const Entry& x, const Entry& y)
        { return std::tie(x.key, y.is_fixed, x.vertex) < std::tie(y.key, x.is_fixed, y.vertex); };
        std::sort(entries.begin(), entries.end(), by_key);
        std::vector<Entry>
            crowded;  // moved vertices that land on another's floats (one entry each)
        for (std::size_t i = 1; i < entries.size(); ++i)
        {
            if (entries[i].key == entries[i - 1].key &&
                entries[i].vertex != entries[i - 1].vertex && !entries[i].is_fixed)
            {
                crowded.push_back(entries[i]);
            }
        }
        if (crowded.empty())
        {
            continue;
        }
        std::set<Key> used;
        for (const Entry& entry : entries)
        {
            used.insert(entry.key);
        }
        std::map<std::int32_t, Key> moved_on;
        for (const Entry& entry : crowded)
        {
            Key k = entry.key;
            while (used.count(k) != 0)
            {
                k[0] = std::nextafter(k[0], std::numeric_limits<float>::infinity());
            }
            used.insert(k);
            moved_on.emplace(entry.vertex, k);
        }
        for (const std::size_t p : members[g])
        {
            const auto& record = asset_.accessors[plans[p].record];
            for (std::size_t e = 0; e < record.elements.size(); ++e)
            {
                const auto found =
                    plans[p].rewrite[e] != 0 ? moved_on.find(record.welded[e]) : moved_on.end();
                if (found != moved_on.end())
                {
                    for (std::size_t d = 0; d < 3; ++d)
                    {
                        plans[p].stored[3 * e + d] = static_cast<double>(found->second[d]);
                    }
                }
            }
        }
    }
}

}  // namespace meshmark::detail

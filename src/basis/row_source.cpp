// SPDX-License-Identifier: MIT
#include "meshmark/basis/row_source.h"

#include <algorithm>
#include <set>
#include <string>
#include <unordered_map>

#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"

namespace meshmark
{
namespace
{

class PositionCursor final : public RowPositionCursor
{
public:
    PositionCursor(const PositionRows& rows, std::size_t begin)
        : V_(rows.positions()), active_(rows.active()), next_(begin)
    {
    }

    void read(std::size_t count, double* xyz, std::int32_t* rows) override
    {
        for (std::size_t i = 0; i < count; ++i, ++next_)
        {
            copy_row(active_[next_], xyz + 3 * i, rows + i);
        }
    }

    void read_at(std::span<const std::size_t> indices, double* xyz, std::int32_t* rows) override
    {
        for (std::size_t i = 0; i < indices.size(); ++i)
        {
            copy_row(active_[indices[i]], xyz + 3 * i, rows + i);
        }
        if (!indices.empty())
        {
            next_ = indices.back() + 1;
        }
    }

private:
    void copy_row(std::int32_t row, double* xyz, std::int32_t* out) const noexcept
    {
        xyz[0] = V_(row, 0);
        xyz[1] = V_(row, 1);
        xyz[2] = V_(row, 2);
        *out = row;
    }

    const Positions& V_;
    const std::vector<std::int32_t>& active_;
    std::size_t next_;
};

}  // namespace

PositionRows::PositionRows(const Positions& V, std::vector<std::int32_t> active)
    : V_(&V), active_(std::move(active))
{
}

std::array<double, 3> PositionRows::position(std::int32_t row) const
{
    return {(*V_)(row, 0), (*V_)(row, 1), (*V_)(row, 2)};
}

std::unique_ptr<RowPositionCursor> PositionRows::cursor(std::size_t begin) const
{
    return std::make_unique<PositionCursor>(*this, begin);
}

std::shared_ptr<const PositionRows> position_rows(const Positions& V,
                                                  std::vector<std::int32_t> active)
{
    return std::make_shared<const PositionRows>(V, std::move(active));
}

std::vector<std::int32_t> random_centers(const Positions& V,
                                         const std::vector<std::int32_t>& active, int k,
                                         std::uint64_t seed)
{
    return random_centers(PositionRows(V, active), k, seed);
}

std::vector<std::int32_t> random_centers(const RowPositionSource& rows, int k, std::uint64_t seed)
{
    if (k <= 0)
    {
        throw InvalidOption("basis size must be positive, got " + std::to_string(k) + ".");
    }
    const std::size_t count = rows.size();
    // The pool is rows.row(0..count-1) with the swaps done so far recorded sparsely.
    std::unordered_map<std::size_t, std::int32_t> swapped;
    const auto pool = [&](std::size_t i)
    {
        const auto found = swapped.find(i);
        return found == swapped.end() ? rows.row(i) : found->second;
    };
    std::vector<std::int32_t> centers;
    centers.reserve(static_cast<std::size_t>(k));
    std::set<std::array<double, 3>> chosen;
    Rng rng(seed);
    // Partial Fisher-Yates: position i receives a uniform pick among the not yet drawn ones.
    for (std::size_t i = 0; i < count && centers.size() < static_cast<std::size_t>(k); ++i)
    {
        const auto j = i + static_cast<std::size_t>(rng.below(count - i));
        const auto row = pool(j);
        if (j != i)
        {
            swapped[j] = pool(i);
        }
        swapped.erase(i);  // position i is never read again
        if (chosen.insert(rows.position(row)).second)
        {
            centers.push_back(row);
        }
    }
    if (centers.size() < static_cast<std::size_t>(k))
    {
        throw InvalidMesh("the mesh has only " + std::to_string(centers.size()) +
                          " distinct usable vertex positions, fewer than the " + std::to_string(k) +
                          " basis functions requested (use a smaller --basis-size).");
    }
    return centers;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief One thread's sequential reader of active-row positions (see RowPositionSource).
/// \details Reads whole blocks: the passes of a basis call it once per block of rows, never
/// once per row.
class RowPositionCursor
{
public:
    virtual ~RowPositionCursor() = default;
    /// The next \p count active rows: x, y, z (file frame) into \p xyz (3 per row) and the
    /// vertex index of each into \p rows.
    virtual void read(std::size_t count, double* xyz, std::int32_t* rows) = 0;
    /// The active rows at \p indices (ascending active-row indices, none before the cursor's
    /// position), as read() gives them; the cursor ends past the last one.
    virtual void read_at(std::span<const std::size_t> indices, double* xyz, std::int32_t* rows) = 0;
};

/// \brief The analysed (active) rows of a mesh and their positions, wherever they are: in memory
/// (PositionRows) or in a file read in chunks (the out-of-core embedding). Every RbfBasis and
/// SpectralWatermark reads positions through this interface only, so both kinds build the same
/// objects, bit for bit. Implementations must be safe to use from several threads at once
/// (each thread with its own cursor).
class RowPositionSource
{
public:
    virtual ~RowPositionSource() = default;
    /// Number of active rows.
    [[nodiscard]] virtual std::size_t size() const = 0;
    /// Number of vertices of the mesh (#V): the rows of a field over it.
    [[nodiscard]] virtual std::size_t vertex_count() const = 0;
    /// Vertex index of active row \p i (random access, for the few rows a center draw needs).
    [[nodiscard]] virtual std::int32_t row(std::size_t i) const = 0;
    /// Position of vertex \p row (random access, for the few rows a center draw needs).
    [[nodiscard]] virtual std::array<double, 3> position(std::int32_t row) const = 0;
    /// A cursor at active row \p begin, for use by one thread.
    [[nodiscard]] virtual std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const = 0;
};

/// \brief The active rows of positions in memory: #V x 3 positions and the list of active rows
/// (sorted, unique). The positions must outlive the source.
class PositionRows final : public RowPositionSource
{
public:
    PositionRows(const Positions& V, std::vector<std::int32_t> active);
    [[nodiscard]] std::size_t size() const override { return active_.size(); }
    [[nodiscard]] std::size_t vertex_count() const override
    {
        return static_cast<std::size_t>(V_->rows());
    }
    [[nodiscard]] std::int32_t row(std::size_t i) const override { return active_[i]; }
    [[nodiscard]] std::array<double, 3> position(std::int32_t row) const override;
    [[nodiscard]] std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const override;
    /// The positions and the active rows.
    [[nodiscard]] const Positions& positions() const noexcept { return *V_; }
    [[nodiscard]] const std::vector<std::int32_t>& active() const noexcept { return active_; }

private:
    const Positions* V_;
    std::vector<std::int32_t> active_;
};

/// \brief A shared PositionRows over \p V (which must outlive it) and the rows \p active.
[[nodiscard]] std::shared_ptr<const PositionRows> position_rows(const Positions& V,
                                                                std::vector<std::int32_t> active);

}  // namespace meshmark

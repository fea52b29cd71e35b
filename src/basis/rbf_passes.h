// SPDX-License-Identifier: MIT
// The row-block passes of RbfBasis (internal to the basis module): every pass reads the active
// rows' positions through cursors of the basis's RowPositionSource, one block at a time,
// evaluates B on the block and hands it to the pass's callback.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "basis/rbf_kernels.h"
#include "meshmark/basis/rbf_basis.h"

namespace meshmark
{

namespace detail
{

/// Element-wise sum of the per-chunk parts, in chunk order (each part the same size).
[[nodiscard]] inline std::vector<double> sum_parts(const std::vector<std::vector<double>>& parts)
{
    std::vector<double> total(parts.empty() ? 0 : parts.front().size(), 0.0);
    for (const auto& part : parts)
    {
        for (std::size_t i = 0; i < total.size(); ++i)
        {
            total[i] += part[i];
        }
    }
    return total;
}

}  // namespace detail

template <class BlockFn>
void RbfBasis::for_each_block(const BlockFn& fn, std::size_t first_chunk, std::size_t last_chunk,
                              bool sampled) const
{
    const std::vector<Chunk>& chunks = sampled ? gram_chunks_ : chunks_;
    last_chunk = std::min(last_chunk, chunks.size());
    const auto chunk_count =
        static_cast<std::ptrdiff_t>(last_chunk - std::min(first_chunk, last_chunk));
    const auto k = center_positions_.rows();
    const double inv_sigma = 1.0 / sigma_;
#pragma omp parallel num_threads(threads_)
    {
        // Per thread: the B block, the positions of its rows (minus the origin), their vertex
        // indices, the active-row indices of a sampled block and a spare block for the callbacks.
        std::vector<double> B(kBasisBlockRows * stride_);
        std::vector<double> P(kBasisBlockRows * 3);
        std::vector<std::int32_t> vertices(kBasisBlockRows);
        std::vector<std::size_t> sample(sampled ? kBasisBlockRows : 0);
        std::vector<double> spare(kBasisBlockRows * stride_);
#pragma omp for schedule(dynamic, 1)
        for (std::ptrdiff_t c = 0; c < chunk_count; ++c)
        {
            const std::size_t index = first_chunk + static_cast<std::size_t>(c);
            const auto& chunk = chunks[index];
            const std::unique_ptr<RowPositionCursor> cursor =
                rows_->cursor(sampled ? gram_row(chunk.begin) : chunk.begin);
            for (std::size_t begin = chunk.begin; begin < chunk.end; begin += kBasisBlockRows)
            {
                const std::size_t end = std::min(chunk.end, begin + kBasisBlockRows);
                const std::size_t rows = end - begin;
                if (sampled)
                {
                    for (std::size_t i = 0; i < rows; ++i)
                    {
                        sample[i] = gram_row(begin + i);
                    }
                    cursor->read_at(std::span<const std::size_t>(sample.data(), rows), P.data(),
                                    vertices.data());
                }
                else
                {
                    cursor->read(rows, P.data(), vertices.data());
                }
                for (std::size_t i = 0; i < rows; ++i)
                {
                    for (Eigen::Index d = 0; d < 3; ++d)
                    {
                        P[3 * i + static_cast<std::size_t>(d)] -= origin_(d);
                    }
                }
                kernels_->evaluate(P.data(), rows, centers_soa_.data(), static_cast<std::size_t>(k),
                                   stride_, inv_sigma, B.data());
                fn(index, B.data(), P.data(), vertices.data(), rows, begin, spare.data());
            }
        }
    }
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// RbfBasis: construction (pass 1 and the eigen-decomposition) and the small k x k queries. The
// row-block passes over the positions are in rbf_passes.h, the projections and syntheses in
// rbf_queries.cpp.
#include "meshmark/basis/rbf_basis.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>
#include <omp.h>

#include "basis/rbf_kernels.h"
#include "basis/rbf_passes.h"
#include "meshmark/core/error.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/threads.h"

namespace meshmark
{
namespace
{

// At most this many chunks; each owns a k x k accumulator, so memory stays O(k^2).
constexpr std::size_t kMaxChunks = 64;
// Fewest row blocks per chunk, so that a chunk's k x k accumulator is worth its reduction;
// chosen by hand; no study on record.
constexpr std::size_t kMinChunkBlocks = 16;

// Relative eigenvalue below which a mode of G is numerically absent (G is accumulated in
// double; condition numbers of 1e8-1e10 are normal for k = 100, docs/algorithms/basis.md).
constexpr double kGramRankTolerance = SpectralBasis::kDegenerateModeTolerance;

// Column of each center in the B blocks: the centers in Morton order of their positions (10
// bits per axis), so that neighbouring columns hold nearby centers and the evaluation's test
// "all four centers out of reach" succeeds for whole groups. Only the layout changes: every
// entry of G, B^T P and the products is the same sum in the same order wherever its column sits.
std::vector<std::size_t> spatial_columns(const Positions& Q)
{
    const std::vector<std::size_t> order = morton_order(Q, 10);
    std::vector<std::size_t> column(order.size());
    for (std::size_t slot = 0; slot < order.size(); ++slot)
    {
        column[order[slot]] = slot;
    }
    return column;
}

}  // namespace

RbfBasis::RbfBasis(std::shared_ptr<const RowPositionSource> rows,
                   const std::vector<std::int32_t>& centers, double sigma,
                   const Eigen::Vector3d& origin, int threads, std::size_t gram_rows)
    : rows_(std::move(rows)),
      kernels_(&detail::selected_kernels()),
      sigma_(sigma),
      origin_(origin),
      threads_(resolve_threads(threads))
{
    row_count_ = rows_ ? rows_->size() : 0;
    if (row_count_ == 0 || centers.empty())
    {
        throw InvalidOption("the RBF basis needs at least one vertex and one center.");
    }
    if (!(sigma_ > 0.0) || !std::isfinite(sigma_))
    {
        throw InvalidOption("the RBF support radius must be positive and finite, got " +
                            std::to_string(sigma_) + ".");
    }
    const auto k = static_cast<Eigen::Index>(centers.size());
    center_positions_.resize(k, 3);
    for (Eigen::Index j = 0; j < k; ++j)
    {
        const std::array<double, 3> q = rows_->position(centers[static_cast<std::size_t>(j)]);
        for (Eigen::Index d = 0; d < 3; ++d)
        {
            center_positions_(j, d) = q[static_cast<std::size_t>(d)] - origin_(d);
        }
    }
    build(gram_rows);
}

std::size_t RbfBasis::gram_row(std::size_t i) const noexcept
{
    if (gram_sample_rows_ == row_count_)
    {
        return i;
    }
    // Midpoints of n / m strides; (2i + 1) n < 2^64 for any n, m < 2^31.
    return static_cast<std::size_t>((2 * static_cast<std::uint64_t>(i) + 1) * row_count_ /
                                    (2 * static_cast<std::uint64_t>(gram_sample_rows_)));
}

void RbfBasis::build(std::size_t gram_rows)
{
    const auto k = center_positions_.rows();
    const auto ku = static_cast<std::size_t>(k);
    padded_k_ = (ku + 3) / 4 * 4;
    stride_ = padded_k_ + 4;
    column_ = spatial_columns(center_positions_);
    centers_soa_.assign(3 * stride_, 0.0);
    for (std::size_t j = 0; j < ku; ++j)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            centers_soa_[d * stride_ + column_[j]] =
                center_positions_(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(d));
        }
    }

    // Fixed chunking: depends on the number of rows only, never on the thread count.
    const auto fixed_chunks = [](std::size_t n)
    {
        const std::size_t min_rows = kMinChunkBlocks * kBasisBlockRows;
        std::size_t chunk_rows = std::max(min_rows, (n + kMaxChunks - 1) / kMaxChunks);
        chunk_rows = (chunk_rows + kBasisBlockRows - 1) / kBasisBlockRows * kBasisBlockRows;
        std::vector<Chunk> chunks;
        for (std::size_t begin = 0; begin < n; begin += chunk_rows)
        {
            chunks.push_back({begin, std::min(n, begin + chunk_rows)});
        }
        return chunks;
    };
    chunks_ = fixed_chunks(row_count_);
    const bool sampled = gram_rows > 0 && gram_rows < row_count_;
    gram_sample_rows_ = sampled ? gram_rows : row_count_;
    if (sampled)
    {
        gram_chunks_ = fixed_chunks(gram_sample_rows_);
    }

    // Pass 1: one symmetric rank update per block of the extended block [B, P - o, 1, 0...]:
    // its lower triangle holds G = B^T B, and the rows past the padded k hold (B^T (P - o))^T
    // and (B^T 1)^T. Per chunk, reduced in chunk order.
    const std::size_t ld = stride_;
    const std::size_t kp = padded_k_;
    std::vector<std::vector<double>> parts((sampled ? gram_chunks_ : chunks_).size(),
                                           std::vector<double>(ld * ld, 0.0));
    for_each_block(
        [&](std::size_t chunk, double* B, const double* P, const std::int32_t* /*vertices*/,
            std::size_t rows, std::size_t /*begin*/, double* /*spare*/)
        {
            for (std::size_t r = 0; r < rows; ++r)
            {
                double* extra = B + r * ld + kp;
                extra[0] = P[3 * r];
                extra[1] = P[3 * r + 1];
                extra[2] = P[3 * r + 2];
                extra[3] = 1.0;
            }
            kernels_->gram(B, rows, ld, parts[chunk].data());
        },
        0, SIZE_MAX, sampled);
    std::vector<double> total = detail::sum_parts(parts);
    if (sampled)
    {
        // Sums over m evenly spaced rows, scaled to the n rows they stand for.
        const double scale =
            static_cast<double>(row_count_) / static_cast<double>(gram_sample_rows_);
        for (double& value : total)
        {
            value *= scale;
        }
    }
    gram_ = unpack_gram(total);
    bt_positions_.resize(k, 3);
    bt_ones_.resize(k);
    for (std::size_t j = 0; j < ku; ++j)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            bt_positions_(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(d)) =
                total[(kp + d) * ld + column_[j]];
        }
        bt_ones_(static_cast<Eigen::Index>(j)) = total[(kp + 3) * ld + column_[j]];
    }

    // G = V W^2 V^T, sorted descending, with the sign convention of the header.
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(gram_);
    if (solver.info() != Eigen::Success)
    {
        throw NumericalError("the eigen-decomposition of the RBF Gram matrix failed to converge.");
    }
    // A sign test whose sum is within this of its scale is rounding: the largest component
    // decides instead. Chosen by hand; no study on record.
    constexpr double kSignTieTolerance = 1e-12;
    singular_values_.resize(k);
    eigenvectors_.resize(k, k);
    for (Eigen::Index j = 0; j < k; ++j)
    {
        const Eigen::Index source = k - 1 - j;
        singular_values_(j) = std::sqrt(std::max(0.0, solver.eigenvalues()(source)));
        Eigen::VectorXd v = solver.eigenvectors().col(source);
        const double sum = bt_ones_.dot(v);
        double sign = sum;
        if (std::abs(sum) <= kSignTieTolerance * bt_ones_.norm())
        {
            Eigen::Index largest = 0;
            v.cwiseAbs().maxCoeff(&largest);
            sign = v(largest);
        }
        eigenvectors_.col(j) = sign < 0.0 ? Eigen::VectorXd(-v) : v;
    }
}

std::string_view RbfBasis::kernel_name() const noexcept
{
    return kernels_->name;
}

Eigen::MatrixXd RbfBasis::unpack_gram(const std::vector<double>& total) const
{
    const auto k = static_cast<Eigen::Index>(size());
    Eigen::MatrixXd G(k, k);
    for (Eigen::Index i = 0; i < k; ++i)
    {
        for (Eigen::Index j = 0; j <= i; ++j)
        {
            const std::size_t a = column_[static_cast<std::size_t>(i)];
            const std::size_t b = column_[static_cast<std::size_t>(j)];
            const double g = a >= b ? total[a * stride_ + b] : total[b * stride_ + a];
            G(i, j) = g;
            G(j, i) = g;
        }
    }
    return G;
}

std::vector<double> RbfBasis::columns_transposed(const Eigen::MatrixXd& M) const
{
    std::vector<double> out(static_cast<std::size_t>(M.cols()) * stride_, 0.0);
    for (Eigen::Index c = 0; c < M.cols(); ++c)
    {
        for (Eigen::Index j = 0; j < M.rows(); ++j)
        {
            out[static_cast<std::size_t>(c) * stride_ + column_[static_cast<std::size_t>(j)]] =
                M(j, c);
        }
    }
    return out;
}

Eigen::MatrixXd RbfBasis::reduce_columns(const std::vector<std::vector<double>>& parts,
                                         std::size_t width) const
{
    const auto k = static_cast<Eigen::Index>(size());
    Eigen::MatrixXd bt_x = Eigen::MatrixXd::Zero(k, static_cast<Eigen::Index>(width));
    for (const auto& part : parts)
    {
        for (std::size_t col = 0; col < width; ++col)
        {
            for (Eigen::Index j = 0; j < k; ++j)
            {
                bt_x(j, static_cast<Eigen::Index>(col)) +=
                    part[col * stride_ + column_[static_cast<std::size_t>(j)]];
            }
        }
    }
    return bt_x;
}

std::size_t RbfBasis::max_chunk_rows() const noexcept
{
    return chunks_.empty() ? 0 : chunks_.front().end - chunks_.front().begin;
}

Eigen::MatrixXd RbfBasis::mode_transform(int modes) const
{
    const auto k = static_cast<Eigen::Index>(size());
    if (modes <= 0 || modes > k)
    {
        throw InvalidOption("the number of modes must be in 1.." + std::to_string(k) + ", got " +
                            std::to_string(modes) + ".");
    }
    const double largest = singular_values_(0) * singular_values_(0);
    for (Eigen::Index j = 0; j < modes; ++j)
    {
        const double w2 = singular_values_(j) * singular_values_(j);
        if (!(largest > 0.0) || w2 <= kGramRankTolerance * largest)
        {
            throw NumericalError("the RBF Gram matrix is degenerate: mode " +
                                 std::to_string(j + 1) + " of the " + std::to_string(modes) +
                                 " needed has relative eigenvalue " + std::to_string(w2 / largest) +
                                 " (are the vertices collinear, coplanar in a tiny patch, or "
                                 "too few?).");
        }
    }
    return eigenvectors_.leftCols(modes) * singular_values_.head(modes).cwiseInverse().asDiagonal();
}

Eigen::MatrixX3d RbfBasis::position_coefficients() const
{
    // Every mode that is numerically present; the rest are reported as zero.
    const double largest = singular_values_(0) * singular_values_(0);
    int present = 0;
    while (present < size() &&
           singular_values_(present) * singular_values_(present) > kGramRankTolerance * largest)
    {
        ++present;
    }
    Eigen::MatrixX3d alpha = Eigen::MatrixX3d::Zero(size(), 3);
    if (present > 0)
    {
        alpha.topRows(present) = mode_transform(present).transpose() * bt_positions_;
    }
    return alpha;
}

int RbfBasis::well_conditioned_modes(double relative_tolerance) const
{
    const double largest = singular_values_(0) * singular_values_(0);
    int count = 0;
    while (count < size() &&
           singular_values_(count) * singular_values_(count) > relative_tolerance * largest)
    {
        ++count;
    }
    return count;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/basis/rbf_basis.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <future>
#include <optional>
#include <set>
#include <unordered_map>
#include <string>

#include <Eigen/Eigenvalues>

#include "basis/rbf_kernels.h"
#include "meshmark/core/error.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/threads.h"
#include "meshmark/core/rng.h"

namespace meshmark {
namespace {

// At most this many chunks; each owns a k x k accumulator, so memory stays O(k^2).
constexpr std::size_t kMaxChunks = 64;
constexpr std::size_t kMinChunkBlocks = 16;

// Relative eigenvalue below which a mode of G is numerically absent (G is accumulated in
// double; condition numbers of 1e8-1e10 are normal for k = 100, docs/algorithms/basis.md).
constexpr double kGramRankTolerance = 1e-14;

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

BasisKernel kernel_from_environment() noexcept
{
    const char* value = std::getenv("MESHMARK_BASIS_KERNEL");
    if (value == nullptr)
    {
        return BasisKernel::Automatic;
    }
    const std::string_view text(value);
    if (text == "portable")
    {
        return BasisKernel::Portable;
    }
    if (text == "avx2")
    {
        return BasisKernel::Avx2;
    }
    return text == "avx512" ? BasisKernel::Avx512 : BasisKernel::Automatic;
}

std::atomic<BasisKernel>& kernel_choice() noexcept
{
    static std::atomic<BasisKernel> choice{kernel_from_environment()};
    return choice;
}

const detail::BlockKernels& selected_kernels() noexcept
{
    const BasisKernel choice = kernel_choice().load();
    if (choice == BasisKernel::Automatic || choice == BasisKernel::Avx512)
    {
        if (const auto* fastest = detail::avx512_kernels())
        {
            return *fastest;
        }
    }
    if (choice != BasisKernel::Portable)
    {
        if (const auto* fast = detail::avx2_kernels())
        {
            return *fast;
        }
    }
    return detail::portable_kernels();
}

}  // namespace

void set_basis_kernel(BasisKernel kernel) noexcept { kernel_choice().store(kernel); }

std::string_view basis_kernel_name() noexcept { return selected_kernels().name; }

std::vector<std::int32_t> random_centers(const Positions& V, const std::vector<std::int32_t>& active,
                                         int k, std::uint64_t seed)
{
    return random_centers(
        active.size(), [&](std::size_t i) { return active[i]; },
        [&](std::int32_t row) { return std::array<double, 3>{V(row, 0), V(row, 1), V(row, 2)}; }, k, seed);
}

std::vector<std::int32_t> random_centers(
    std::size_t count, const std::function<std::int32_t(std::size_t)>& row_at,
    const std::function<std::array<double, 3>(std::int32_t)>& position_of, int k, std::uint64_t seed)
{
    if (k <= 0)
    {
        throw InvalidOption("basis size must be positive, got " + std::to_string(k) + ".");
    }
    // The pool is row_at(0..count-1) with the swaps done so far recorded sparsely.
    std::unordered_map<std::size_t, std::int32_t> swapped;
    const auto pool = [&](std::size_t i) {
        const auto found = swapped.find(i);
        return found == swapped.end() ? row_at(i) : found->second;
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
        if (chosen.insert(position_of(row)).second)
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

RbfBasis::RbfBasis(const Positions& V, std::vector<std::int32_t> active,
                   std::vector<std::int32_t> centers, double sigma, const Eigen::Vector3d& origin,
                   int threads, std::size_t gram_rows)
    : V_(&V), active_(std::move(active)), kernels_(&selected_kernels()), sigma_(sigma), origin_(origin),
      threads_(resolve_threads(threads))
{
    row_count_ = active_.size();
    if (active_.empty() || centers.empty())
    {
        throw InvalidOption("the RBF basis needs at least one vertex and one center.");
    }
    if (!(sigma_ > 0.0) || !std::isfinite(sigma_))
    {
        throw InvalidOption("the RBF support radius must be positive and finite, got " +
                            std::to_string(sigma_) + ".");
    }
    Eigen::MatrixX3d center_positions(static_cast<Eigen::Index>(centers.size()), 3);
    for (Eigen::Index j = 0; j < center_positions.rows(); ++j)
    {
        center_positions.row(j) = V.row(centers[static_cast<std::size_t>(j)]);
    }
    build(center_positions, nullptr, gram_rows);
}

RbfBasis::RbfBasis(const RowPositionSource& source, const Eigen::MatrixX3d& center_positions,
                   double sigma, const Eigen::Vector3d& origin, int threads, std::size_t gram_rows)
    : V_(nullptr), row_count_(source.size()), kernels_(&selected_kernels()), sigma_(sigma), origin_(origin),
      threads_(resolve_threads(threads))
{
    if (row_count_ == 0 || center_positions.rows() == 0)
    {
        throw InvalidOption("the RBF basis needs at least one vertex and one center.");
    }
    if (!(sigma_ > 0.0) || !std::isfinite(sigma_))
    {
        throw InvalidOption("the RBF support radius must be positive and finite, got " +
                            std::to_string(sigma_) + ".");
    }
    build(center_positions, &source, gram_rows);
}

void RowPositionCursor::skip(std::size_t count)
{
    std::vector<double> dropped(3 * std::min<std::size_t>(count, 4096));
    for (std::size_t done = 0; done < count;)
    {
        const std::size_t n = std::min(count - done, dropped.size() / 3);
        read(n, dropped.data());
        done += n;
    }
}

// The rows of a sampled pass 1 out of a source of all active rows: one underlying cursor read
// sequentially, the rows between two sampled ones skipped.
class RbfBasis::SampledRows final : public RowPositionSource
{
public:
    SampledRows(const RbfBasis& basis, const RowPositionSource& all) : basis_(basis), all_(all) {}
    [[nodiscard]] std::size_t size() const override { return basis_.gram_sample_rows_; }
    [[nodiscard]] std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const override
    {
        return std::make_unique<Cursor>(basis_, all_, begin);
    }

private:
    class Cursor final : public RowPositionCursor
    {
    public:
        Cursor(const RbfBasis& basis, const RowPositionSource& all, std::size_t begin)
            : basis_(basis), next_(begin), row_(basis.gram_row(begin)), all_(all.cursor(row_))
        {
        }
        void read(std::size_t count, double* xyz) override
        {
            for (std::size_t i = 0; i < count; ++i, ++next_)
            {
                const std::size_t row = basis_.gram_row(next_);
                if (row > row_)
                {
                    all_->skip(row - row_);
                }
                all_->read(1, xyz + 3 * i);
                row_ = row + 1;
            }
        }

    private:
        const RbfBasis& basis_;
        std::size_t next_;  // sample index of the next read
        std::size_t row_;   // active row the underlying cursor is at
        std::unique_ptr<RowPositionCursor> all_;
    };

    const RbfBasis& basis_;
    const RowPositionSource& all_;
};

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

void RbfBasis::build(const Eigen::MatrixX3d& centers, const RowPositionSource* rows_source,
                     std::size_t gram_rows)
{
    const auto k = static_cast<Eigen::Index>(centers.rows());
    const auto ku = static_cast<std::size_t>(k);
    padded_k_ = (ku + 3) / 4 * 4;
    stride_ = padded_k_ + 4;
    center_positions_.resize(k, 3);
    for (Eigen::Index j = 0; j < k; ++j)
    {
        center_positions_.row(j) = centers.row(j) - origin_.transpose();
    }
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
    const auto fixed_chunks = [](std::size_t n) {
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
    std::optional<SampledRows> sampled_source;
    if (sampled && rows_source != nullptr)
    {
        sampled_source.emplace(*this, *rows_source);
        rows_source = &*sampled_source;
    }

    // Pass 1: one symmetric rank update per block of the extended block [B, P - o, 1, 0...]:
    // its lower triangle holds G = B^T B, and the rows past the padded k hold (B^T (P - o))^T
    // and (B^T 1)^T. Per chunk, reduced in chunk order.
    const std::size_t ld = stride_;
    const std::size_t kp = padded_k_;
    std::vector<std::vector<double>> parts((sampled ? gram_chunks_ : chunks_).size(),
                                           std::vector<double>(ld * ld, 0.0));
    for_each_block([&](std::size_t chunk, double* B, const double* P, std::size_t rows,
                       std::size_t /*begin*/, double* /*spare*/) {
        for (std::size_t r = 0; r < rows; ++r)
        {
            double* extra = B + r * ld + kp;
            extra[0] = P[3 * r];
            extra[1] = P[3 * r + 1];
            extra[2] = P[3 * r + 2];
            extra[3] = 1.0;
        }
        kernels_->gram(B, rows, ld, parts[chunk].data());
    }, rows_source, 0, SIZE_MAX, sampled);
    std::vector<double> total(ld * ld, 0.0);
    for (const auto& part : parts)
    {
        for (std::size_t i = 0; i < total.size(); ++i)
        {
            total[i] += part[i];
        }
    }
    if (sampled)
    {
        // Sums over m evenly spaced rows, scaled to the n rows they stand for.
        const double scale = static_cast<double>(row_count_) / static_cast<double>(gram_sample_rows_);
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
    singular_values_.resize(k);
    eigenvectors_.resize(k, k);
    for (Eigen::Index j = 0; j < k; ++j)
    {
        const Eigen::Index source = k - 1 - j;
        singular_values_(j) = std::sqrt(std::max(0.0, solver.eigenvalues()(source)));
        Eigen::VectorXd v = solver.eigenvectors().col(source);
        const double sum = bt_ones_.dot(v);
        double sign = sum;
        if (std::abs(sum) <= 1e-12 * bt_ones_.norm())
        {
            Eigen::Index largest = 0;
            v.cwiseAbs().maxCoeff(&largest);
            sign = v(largest);
        }
        eigenvectors_.col(j) = sign < 0.0 ? Eigen::VectorXd(-v) : v;
    }
}

std::string_view RbfBasis::kernel_name() const noexcept { return kernels_->name; }

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
            out[static_cast<std::size_t>(c) * stride_ + column_[static_cast<std::size_t>(j)]] = M(j, c);
        }
    }
    return out;
}

template <class BlockFn>
void RbfBasis::for_each_block(const BlockFn& fn, const RowPositionSource* source, std::size_t first_chunk,
                              std::size_t last_chunk, bool sampled) const
{
    const std::vector<Chunk>& chunks = sampled ? gram_chunks_ : chunks_;
    last_chunk = std::min(last_chunk, chunks.size());
    const auto chunk_count = static_cast<std::ptrdiff_t>(last_chunk - std::min(first_chunk, last_chunk));
    const auto k = center_positions_.rows();
    const double inv_sigma = 1.0 / sigma_;
    if (source == nullptr)
    {
        require_positions("this pass");
    }
#pragma omp parallel num_threads(threads_)
    {
        // Per thread: the B block, the positions of its rows (minus the origin) and a spare
        // block for the callbacks.
        std::vector<double> B(kBasisBlockRows * stride_);
        std::vector<double> P(kBasisBlockRows * 3);
        std::vector<double> spare(kBasisBlockRows * stride_);
#pragma omp for schedule(dynamic, 1)
        for (std::ptrdiff_t c = 0; c < chunk_count; ++c)
        {
            const std::size_t index = first_chunk + static_cast<std::size_t>(c);
            const auto& chunk = chunks[index];
            std::unique_ptr<RowPositionCursor> cursor;
            if (source != nullptr)
            {
                cursor = source->cursor(chunk.begin);
            }
            for (std::size_t begin = chunk.begin; begin < chunk.end; begin += kBasisBlockRows)
            {
                const std::size_t end = std::min(chunk.end, begin + kBasisBlockRows);
                const std::size_t rows = end - begin;
                if (cursor)
                {
                    cursor->read(rows, P.data());
                    for (std::size_t i = 0; i < rows; ++i)
                    {
                        for (Eigen::Index d = 0; d < 3; ++d)
                        {
                            P[3 * i + static_cast<std::size_t>(d)] -= origin_(d);
                        }
                    }
                }
                else
                {
                    for (std::size_t i = 0; i < rows; ++i)
                    {
                        const auto row = active_[sampled ? gram_row(begin + i) : begin + i];
                        for (Eigen::Index d = 0; d < 3; ++d)
                        {
                            P[3 * i + static_cast<std::size_t>(d)] = (*V_)(row, d) - origin_(d);
                        }
                    }
                }
                kernels_->evaluate(P.data(), rows, centers_soa_.data(), static_cast<std::size_t>(k),
                                   stride_, inv_sigma, B.data());
                fn(index, B.data(), P.data(), rows, begin, spare.data());
            }
        }
    }
}

void RbfBasis::require_positions(const char* what) const
{
    if (V_ == nullptr)
    {
        throw InvalidOption(std::string("RbfBasis: ") + what +
                            " needs the positions in memory, but this basis was built from a stream.");
    }
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
            throw NumericalError("the RBF Gram matrix is degenerate: mode " + std::to_string(j + 1) +
                                 " of the " + std::to_string(modes) +
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

Eigen::MatrixX3d RbfBasis::project(const Positions& X, int modes) const
{
    return project(std::vector<Positions>{X}, modes).front();
}

std::vector<Eigen::MatrixX3d> RbfBasis::project(const std::vector<Positions>& fields, int modes) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    const auto k = static_cast<Eigen::Index>(size());
    const std::size_t w = 3 * fields.size();
    const std::size_t ld = stride_;
    // (B^T [X_1 ... X_q])^T (3q x ld) per chunk, one evaluation of B for all fields.
    std::vector<std::vector<double>> parts(chunks_.size(), std::vector<double>(w * ld, 0.0));
    for_each_block([&](std::size_t chunk, double* B, const double* /*P*/, std::size_t rows,
                       std::size_t begin, double* spare) {
        // The spare block holds rows x 3q values when 3q <= ld, else a local buffer does.
        std::vector<double> local;
        double* x = spare;
        if (w > ld)
        {
            local.resize(rows * w);
            x = local.data();
        }
        for (std::size_t i = 0; i < rows; ++i)
        {
            const auto row = active_[begin + i];
            for (std::size_t f = 0; f < fields.size(); ++f)
            {
                for (Eigen::Index d = 0; d < 3; ++d)
                {
                    x[i * w + 3 * f + static_cast<std::size_t>(d)] = fields[f](row, d);
                }
            }
        }
        kernels_->accumulate(B, rows, ld, x, w, parts[chunk].data());
    });
    Eigen::MatrixXd bt_x = Eigen::MatrixXd::Zero(k, static_cast<Eigen::Index>(w));
    for (const auto& part : parts)
    {
        for (std::size_t col = 0; col < w; ++col)
        {
            for (Eigen::Index j = 0; j < k; ++j)
            {
                bt_x(j, static_cast<Eigen::Index>(col)) += part[col * ld + column_[static_cast<std::size_t>(j)]];
            }
        }
    }
    std::vector<Eigen::MatrixX3d> result;
    result.reserve(fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f)
    {
        result.emplace_back(T.transpose() * bt_x.middleCols(3 * static_cast<Eigen::Index>(f), 3));
    }
    return result;
}

Eigen::MatrixXd RbfBasis::project_design(int modes, int head, std::size_t width, const DesignFill& fill) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    if (head < 0 || head > modes)
    {
        throw InvalidOption("project_design: head = " + std::to_string(head) + " is outside 0.." +
                            std::to_string(modes) + ".");
    }
    const auto k = static_cast<Eigen::Index>(size());
    const auto h = static_cast<std::size_t>(head);
    const std::size_t ld = stride_;
    // The head modes exactly as modes_dense() computes them: the same multiply of B by the
    // same columns of T (each output column is its own fixed sequence of operations).
    const std::vector<double> t_head = h > 0 ? columns_transposed(T.leftCols(head)) : std::vector<double>();
    std::vector<std::vector<double>> parts(chunks_.size(), std::vector<double>(width * ld, 0.0));
    for_each_block([&](std::size_t chunk, double* B, const double* /*P*/, std::size_t rows,
                       std::size_t begin, double* /*spare*/) {
        // Per thread, reused from block to block.
        thread_local std::vector<double> u;
        thread_local std::vector<double> x;
        u.resize(rows * h);
        x.assign(rows * width, 0.0);
        if (h > 0)
        {
            kernels_->multiply(B, rows, ld, t_head.data(), h, u.data());
        }
        fill(std::span<const std::int32_t>(active_.data() + begin, rows), h > 0 ? u.data() : nullptr, x.data());
        kernels_->accumulate(B, rows, ld, x.data(), width, parts[chunk].data());
    });
    Eigen::MatrixXd bt_x = Eigen::MatrixXd::Zero(k, static_cast<Eigen::Index>(width));
    for (const auto& part : parts)
    {
        for (std::size_t col = 0; col < width; ++col)
        {
            for (Eigen::Index j = 0; j < k; ++j)
            {
                bt_x(j, static_cast<Eigen::Index>(col)) += part[col * ld + column_[static_cast<std::size_t>(j)]];
            }
        }
    }
    return T.transpose() * bt_x;
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

Eigen::MatrixX3d RbfBasis::project_least_squares(const Positions& X,
                                                 const std::vector<std::uint8_t>& is_kept,
                                                 int modes) const
{
    // Solve min |U_m,S c - X_S| over the leading modes only. Fitting all k modes looks more
    // complete but is ill-posed: combinations of modes that nearly vanish on the kept rows
    // (localized in the cropped part) make the normal matrix nearly singular, and any
    // regularization then biases the leading coefficients (measured: errors of 0.14 on a
    // half-cropped ellipsoid with 50 modes, 1e-12 with the leading 6). The leading modes are
    // global and smooth, so they stay well determined by what is left.
    const Eigen::MatrixXd T = mode_transform(modes);
    const auto k = static_cast<Eigen::Index>(size());
    const std::size_t ld = stride_;
    const std::size_t kp = padded_k_;
    // As in pass 1: the rank update of [B_S, X_S] gives B_S^T B_S and (B_S^T X_S)^T at once.
    std::vector<std::vector<double>> parts(chunks_.size(), std::vector<double>(ld * ld, 0.0));
    for_each_block([&](std::size_t chunk, double* B, const double* /*P*/, std::size_t rows,
                       std::size_t begin, double* kept) {
        std::size_t count = 0;
        for (std::size_t i = 0; i < rows; ++i)
        {
            const auto row = active_[begin + i];
            if (is_kept[static_cast<std::size_t>(row)] != 0)
            {
                double* out = kept + count * ld;
                std::copy(B + i * ld, B + i * ld + kp, out);
                out[kp] = X(row, 0);
                out[kp + 1] = X(row, 1);
                out[kp + 2] = X(row, 2);
                out[kp + 3] = 0.0;
                ++count;
            }
        }
        if (count > 0)
        {
            kernels_->gram(kept, count, ld, parts[chunk].data());
        }
    });
    std::vector<double> total(ld * ld, 0.0);
    for (const auto& part : parts)
    {
        for (std::size_t i = 0; i < total.size(); ++i)
        {
            total[i] += part[i];
        }
    }
    const Eigen::MatrixXd gram_kept = unpack_gram(total);
    Eigen::MatrixX3d rhs(k, 3);
    for (std::size_t i = 0; i < static_cast<std::size_t>(k); ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            rhs(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) = total[(kp + d) * ld + column_[i]];
        }
    }
    const Eigen::MatrixXd normal = T.transpose() * gram_kept * T;  // U_m,S^T U_m,S
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> check(normal);
    if (check.info() != Eigen::Success || !(check.eigenvalues()(0) > 1e-8))
    {
        throw NumericalError("too few vertices survive the cropping to determine the watermark's "
                             "coefficients (least-squares matrix is singular).");
    }
    return normal.ldlt().solve(T.transpose() * rhs);
}

Positions RbfBasis::synthesize(const Eigen::MatrixX3d& c, double* orthogonality_error) const
{
    require_positions("synthesize");
    const int modes = static_cast<int>(c.rows());
    const Eigen::MatrixXd T = mode_transform(modes);
    const Eigen::MatrixX3d Tc = T * c;
    const std::size_t ld = stride_;
    const std::vector<double> tc_t = columns_transposed(Tc);  // (T c)^T, zero on the padding
    Positions result = Positions::Zero(V_->rows(), 3);
    const bool check = orthogonality_error != nullptr;
    std::vector<std::vector<double>> parts(check ? chunks_.size() : 0, std::vector<double>(3 * ld, 0.0));
    for_each_block([&](std::size_t chunk, double* B, const double* /*P*/, std::size_t rows,
                       std::size_t begin, double* d) {
        kernels_->multiply(B, rows, ld, tc_t.data(), 3, d);
        for (std::size_t i = 0; i < rows; ++i)
        {
            const auto row = active_[begin + i];
            result(row, 0) = d[3 * i];
            result(row, 1) = d[3 * i + 1];
            result(row, 2) = d[3 * i + 2];
        }
        if (check)
        {
            kernels_->accumulate(B, rows, ld, d, 3, parts[chunk].data());
        }
    });
    if (check)
    {
        *orthogonality_error = orthogonality(T, c, parts);
    }
    return result;
}

void RbfBasis::synthesize_streamed(const Eigen::MatrixX3d& c, const RowPositionSource& source,
                                   std::size_t chunks_in_flight, const FieldSink& sink,
                                   double* orthogonality_error) const
{
    if (source.size() != row_count_)
    {
        throw InvalidOption("synthesize_streamed: the source has " + std::to_string(source.size()) +
                            " rows, the basis " + std::to_string(row_count_) + ".");
    }
    const int modes = static_cast<int>(c.rows());
    const Eigen::MatrixXd T = mode_transform(modes);
    const Eigen::MatrixX3d Tc = T * c;
    const std::size_t ld = stride_;
    const std::vector<double> tc_t = columns_transposed(Tc);
    const bool check = orthogonality_error != nullptr;
    std::vector<std::vector<double>> parts(check ? chunks_.size() : 0, std::vector<double>(3 * ld, 0.0));
    // Rounds of up to chunks_in_flight chunks, computed in parallel into one of two buffer sets
    // while the round before is handed to the sink, in order, on a thread of its own (the
    // sink writes a file: this keeps both cores busy). Each row's field is the same arithmetic
    // as in synthesize().
    const std::size_t in_flight = std::max<std::size_t>(1, chunks_in_flight);
    std::array<std::vector<std::vector<double>>, 2> fields;
    fields.fill(std::vector<std::vector<double>>(std::min(in_flight, chunks_.size())));
    std::future<void> delivering;
    // Waits for the round being delivered, also when the computation throws (the buffers and
    // the sink must outlive it).
    struct Wait
    {
        std::future<void>& job;
        ~Wait()
        {
            if (job.valid())
            {
                job.wait();
            }
        }
    } wait_on_exit{delivering};
    std::size_t round = 0;
    for (std::size_t first = 0; first < chunks_.size(); first += in_flight, ++round)
    {
        const std::size_t last = std::min(chunks_.size(), first + in_flight);
        auto& buffers = fields[round % 2];
        for (std::size_t i = first; i < last; ++i)
        {
            buffers[i - first].resize(3 * (chunks_[i].end - chunks_[i].begin));
        }
        for_each_block(
            [&](std::size_t chunk, double* B, const double* /*P*/, std::size_t rows, std::size_t begin,
                double* d) {
                kernels_->multiply(B, rows, ld, tc_t.data(), 3, d);
                std::copy(d, d + 3 * rows, buffers[chunk - first].data() + 3 * (begin - chunks_[chunk].begin));
                if (check)
                {
                    kernels_->accumulate(B, rows, ld, d, 3, parts[chunk].data());
                }
            },
            &source, first, last);
        if (delivering.valid())
        {
            delivering.get();  // the previous round is out (or its exception is thrown here)
        }
        delivering = std::async(std::launch::async, [this, &sink, &buffers, first, last]() {
            for (std::size_t i = first; i < last; ++i)
            {
                sink(chunks_[i].begin, chunks_[i].end - chunks_[i].begin, buffers[i - first].data());
            }
        });
    }
    if (delivering.valid())
    {
        delivering.get();
    }
    if (check)
    {
        *orthogonality_error = orthogonality(T, c, parts);
    }
}

double RbfBasis::orthogonality(const Eigen::MatrixXd& T, const Eigen::MatrixX3d& c,
                               const std::vector<std::vector<double>>& parts) const
{
    // Modes: U_m^T U_m = T^T G T. Field: U_m^T f = T^T (B^T f), against c.
    const auto k = static_cast<Eigen::Index>(size());
    const std::size_t ld = stride_;
    const auto modes = c.rows();
    const Eigen::MatrixXd utu = T.transpose() * gram_ * T;
    const double modes_error = (utu - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff();
    Eigen::MatrixX3d bt_f = Eigen::MatrixX3d::Zero(k, 3);
    for (const auto& part : parts)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            for (Eigen::Index j = 0; j < k; ++j)
            {
                bt_f(j, static_cast<Eigen::Index>(d)) += part[d * ld + column_[static_cast<std::size_t>(j)]];
            }
        }
    }
    const double scale = c.cwiseAbs().maxCoeff();
    const double field_error = scale > 0.0 ? (T.transpose() * bt_f - c).cwiseAbs().maxCoeff() / scale : 0.0;
    return std::max(modes_error, field_error);
}

Eigen::MatrixXd RbfBasis::modes_dense(int modes) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    const auto m = static_cast<std::size_t>(modes);
    const std::size_t ld = stride_;
    const std::vector<double> t_t = columns_transposed(T);
    Eigen::MatrixXd U(static_cast<Eigen::Index>(active_.size()), modes);
    for_each_block([&](std::size_t /*chunk*/, double* B, const double* /*P*/, std::size_t rows,
                       std::size_t begin, double* /*spare*/) {
        std::vector<double> out(rows * m);
        kernels_->multiply(B, rows, ld, t_t.data(), m, out.data());
        for (std::size_t i = 0; i < rows; ++i)
        {
            for (std::size_t c = 0; c < m; ++c)
            {
                U(static_cast<Eigen::Index>(begin + i), static_cast<Eigen::Index>(c)) = out[i * m + c];
            }
        }
    });
    return U;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/basis/rbf_basis.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string>

#include <Eigen/Eigenvalues>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"

namespace meshmark {
namespace {

using RowBlock = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>;

int resolve_threads(int threads) { return threads > 0 ? threads : omp_get_num_procs(); }

// At most this many chunks; each owns a k x k accumulator, so memory stays O(k^2).
constexpr std::size_t kMaxChunks = 64;
constexpr std::size_t kMinChunkBlocks = 16;

// Relative eigenvalue below which a mode of G is numerically absent (G is accumulated in
// double; condition numbers of 1e8-1e10 are normal for k = 100, see DESIGN.md).
constexpr double kGramRankTolerance = 1e-14;

}  // namespace

std::vector<std::int32_t> random_centers(const Positions& V, const std::vector<std::int32_t>& active,
                                         int k, std::uint64_t seed)
{
    if (k <= 0)
    {
        throw InvalidOption("basis size must be positive, got " + std::to_string(k) + ".");
    }
    std::vector<std::int32_t> pool = active;
    std::vector<std::int32_t> centers;
    centers.reserve(static_cast<std::size_t>(k));
    std::set<std::array<double, 3>> chosen;
    Rng rng(seed);
    // Partial Fisher-Yates: position i receives a uniform pick among the not yet drawn ones.
    for (std::size_t i = 0; i < pool.size() && centers.size() < static_cast<std::size_t>(k); ++i)
    {
        const auto j = i + static_cast<std::size_t>(rng.below(pool.size() - i));
        std::swap(pool[i], pool[j]);
        const auto row = pool[i];
        const std::array<double, 3> p = {V(row, 0), V(row, 1), V(row, 2)};
        if (chosen.insert(p).second)
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
                   int threads)
    : V_(&V), active_(std::move(active)), sigma_(sigma), origin_(origin), threads_(resolve_threads(threads))
{
    if (active_.empty() || centers.empty())
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
        center_positions_.row(j) = V.row(centers[static_cast<std::size_t>(j)]) - origin_.transpose();
    }

    // Fixed chunking: depends on the number of rows only, never on the thread count.
    const std::size_t n = active_.size();
    const std::size_t min_rows = kMinChunkBlocks * kBasisBlockRows;
    std::size_t chunk_rows = std::max(min_rows, (n + kMaxChunks - 1) / kMaxChunks);
    chunk_rows = (chunk_rows + kBasisBlockRows - 1) / kBasisBlockRows * kBasisBlockRows;
    for (std::size_t begin = 0; begin < n; begin += chunk_rows)
    {
        chunks_.push_back({begin, std::min(n, begin + chunk_rows)});
    }

    // Pass 1: G = B^T B (lower triangle), B^T 1 and B^T (P - o), per chunk, reduced in order.
    const auto chunk_count = chunks_.size();
    std::vector<Eigen::MatrixXd> gram_parts(chunk_count, Eigen::MatrixXd::Zero(k, k));
    std::vector<Eigen::MatrixX3d> position_parts(chunk_count, Eigen::MatrixX3d::Zero(k, 3));
    std::vector<Eigen::VectorXd> ones_parts(chunk_count, Eigen::VectorXd::Zero(k));
    for_each_block([&](std::size_t chunk, const Eigen::MatrixXd& B, const Positions& P, Eigen::Index rows,
                       std::size_t /*begin*/) {
        const auto block = B.topRows(rows);
        gram_parts[chunk].selfadjointView<Eigen::Lower>().rankUpdate(block.transpose());
        position_parts[chunk].noalias() += block.transpose() * P.topRows(rows);
        ones_parts[chunk].noalias() += block.colwise().sum().transpose();
    });
    gram_ = Eigen::MatrixXd::Zero(k, k);
    bt_positions_ = Eigen::MatrixX3d::Zero(k, 3);
    bt_ones_ = Eigen::VectorXd::Zero(k);
    for (std::size_t c = 0; c < chunk_count; ++c)
    {
        gram_ += gram_parts[c];
        bt_positions_ += position_parts[c];
        bt_ones_ += ones_parts[c];
    }
    gram_.triangularView<Eigen::StrictlyUpper>() = gram_.transpose();

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

template <class BlockFn>
void RbfBasis::for_each_block(const BlockFn& fn) const
{
    const auto chunk_count = static_cast<std::ptrdiff_t>(chunks_.size());
    const auto k = center_positions_.rows();
#pragma omp parallel num_threads(threads_)
    {
        Eigen::MatrixXd B(static_cast<Eigen::Index>(kBasisBlockRows), k);
        Positions P(static_cast<Eigen::Index>(kBasisBlockRows), 3);
#pragma omp for schedule(dynamic, 1)
        for (std::ptrdiff_t c = 0; c < chunk_count; ++c)
        {
            const auto& chunk = chunks_[static_cast<std::size_t>(c)];
            for (std::size_t begin = chunk.begin; begin < chunk.end; begin += kBasisBlockRows)
            {
                const std::size_t end = std::min(chunk.end, begin + kBasisBlockRows);
                evaluate_block(begin, end, B, P);
                fn(static_cast<std::size_t>(c), B, P, static_cast<Eigen::Index>(end - begin), begin);
            }
        }
    }
}

void RbfBasis::evaluate_block(std::size_t begin, std::size_t end, Eigen::MatrixXd& B, Positions& P) const
{
    const auto rows = static_cast<Eigen::Index>(end - begin);
    for (Eigen::Index i = 0; i < rows; ++i)
    {
        P.row(i) = V_->row(active_[begin + static_cast<std::size_t>(i)]) - origin_.transpose();
    }
    // Column by column so that the inner loop runs over contiguous rows and vectorizes.
    const double inv_sigma = 1.0 / sigma_;
    double px[kBasisBlockRows];
    double py[kBasisBlockRows];
    double pz[kBasisBlockRows];
    for (Eigen::Index i = 0; i < rows; ++i)
    {
        px[i] = P(i, 0);
        py[i] = P(i, 1);
        pz[i] = P(i, 2);
    }
    for (Eigen::Index j = 0; j < center_positions_.rows(); ++j)
    {
        const double qx = center_positions_(j, 0);
        const double qy = center_positions_(j, 1);
        const double qz = center_positions_(j, 2);
        double* column = B.col(j).data();
        for (Eigen::Index i = 0; i < rows; ++i)
        {
            const double dx = px[i] - qx;
            const double dy = py[i] - qy;
            const double dz = pz[i] - qz;
            const double r = std::sqrt(dx * dx + dy * dy + dz * dz) * inv_sigma;
            const double t = r < 1.0 ? 1.0 - r : 0.0;
            const double t2 = t * t;
            column[i] = t2 * t2 * (4.0 * r + 1.0);
        }
    }
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
    const auto q = static_cast<Eigen::Index>(fields.size());
    // B^T [X_1 ... X_q] (k x 3q) per chunk, one evaluation of B for all fields.
    std::vector<Eigen::MatrixXd> parts(chunks_.size(), Eigen::MatrixXd::Zero(k, 3 * q));
    for_each_block([&](std::size_t chunk, const Eigen::MatrixXd& B, const Positions& /*P*/,
                       Eigen::Index rows, std::size_t begin) {
        Eigen::MatrixXd x(rows, 3 * q);
        for (Eigen::Index i = 0; i < rows; ++i)
        {
            const auto row = active_[begin + static_cast<std::size_t>(i)];
            for (Eigen::Index f = 0; f < q; ++f)
            {
                x.block(i, 3 * f, 1, 3) = fields[static_cast<std::size_t>(f)].row(row);
            }
        }
        parts[chunk].noalias() += B.topRows(rows).transpose() * x;
    });
    Eigen::MatrixXd bt_x = Eigen::MatrixXd::Zero(k, 3 * q);
    for (const auto& part : parts)
    {
        bt_x += part;
    }
    std::vector<Eigen::MatrixX3d> result;
    result.reserve(fields.size());
    for (Eigen::Index f = 0; f < q; ++f)
    {
        result.emplace_back(T.transpose() * bt_x.middleCols(3 * f, 3));
    }
    return result;
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
    std::vector<Eigen::MatrixXd> gram_parts(chunks_.size(), Eigen::MatrixXd::Zero(k, k));
    std::vector<Eigen::MatrixX3d> rhs_parts(chunks_.size(), Eigen::MatrixX3d::Zero(k, 3));
    for_each_block([&](std::size_t chunk, const Eigen::MatrixXd& B, const Positions& /*P*/,
                       Eigen::Index rows, std::size_t begin) {
        Eigen::MatrixXd kept(rows, k);
        Eigen::Matrix<double, Eigen::Dynamic, 3> x(rows, 3);
        Eigen::Index count = 0;
        for (Eigen::Index i = 0; i < rows; ++i)
        {
            const auto row = active_[begin + static_cast<std::size_t>(i)];
            if (is_kept[static_cast<std::size_t>(row)] != 0)
            {
                kept.row(count) = B.row(i);
                x.row(count) = X.row(row);
                ++count;
            }
        }
        if (count > 0)
        {
            gram_parts[chunk].selfadjointView<Eigen::Lower>().rankUpdate(kept.topRows(count).transpose());
            rhs_parts[chunk].noalias() += kept.topRows(count).transpose() * x.topRows(count);
        }
    });
    Eigen::MatrixXd gram_kept = Eigen::MatrixXd::Zero(k, k);
    Eigen::MatrixX3d rhs = Eigen::MatrixX3d::Zero(k, 3);
    for (std::size_t c = 0; c < chunks_.size(); ++c)
    {
        gram_kept += gram_parts[c];
        rhs += rhs_parts[c];
    }
    gram_kept.triangularView<Eigen::StrictlyUpper>() = gram_kept.transpose();
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
    const int modes = static_cast<int>(c.rows());
    const Eigen::MatrixXd T = mode_transform(modes);
    const Eigen::MatrixX3d Tc = T * c;
    Positions result = Positions::Zero(V_->rows(), 3);
    std::vector<Eigen::MatrixXd> gram_parts;
    if (orthogonality_error != nullptr)
    {
        gram_parts.assign(chunks_.size(), Eigen::MatrixXd::Zero(modes, modes));
    }
    for_each_block([&](std::size_t chunk, const Eigen::MatrixXd& B, const Positions& /*P*/,
                       Eigen::Index rows, std::size_t begin) {
        const Eigen::Matrix<double, Eigen::Dynamic, 3> d = B.topRows(rows) * Tc;
        for (Eigen::Index i = 0; i < rows; ++i)
        {
            result.row(active_[begin + static_cast<std::size_t>(i)]) = d.row(i);
        }
        if (orthogonality_error != nullptr)
        {
            const Eigen::MatrixXd U = B.topRows(rows) * T;
            gram_parts[chunk].noalias() += U.transpose() * U;
        }
    });
    if (orthogonality_error != nullptr)
    {
        Eigen::MatrixXd utu = Eigen::MatrixXd::Zero(modes, modes);
        for (const auto& part : gram_parts)
        {
            utu += part;
        }
        *orthogonality_error =
            (utu - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff();
    }
    return result;
}

Eigen::MatrixXd RbfBasis::modes_dense(int modes) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    Eigen::MatrixXd U(static_cast<Eigen::Index>(active_.size()), modes);
    for_each_block([&](std::size_t /*chunk*/, const Eigen::MatrixXd& B, const Positions& /*P*/,
                       Eigen::Index rows, std::size_t begin) {
        U.middleRows(static_cast<Eigen::Index>(begin), rows) = B.topRows(rows) * T;
    });
    return U;
}

}  // namespace meshmark

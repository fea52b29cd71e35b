// SPDX-License-Identifier: MIT
// RbfBasis queries that evaluate B again, block by block: projections, least squares,
// syntheses (in memory and streamed) and the explicit modes.
#include <algorithm>
#include <array>
#include <future>
#include <string>

#include <Eigen/Eigenvalues>

#include "basis/rbf_kernels.h"
#include "basis/rbf_passes.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/error.h"

namespace meshmark
{

Eigen::MatrixX3d RbfBasis::project(const Positions& X, int modes) const
{
    return project(std::vector<Positions>{X}, modes).front();
}

std::vector<Eigen::MatrixX3d> RbfBasis::project(const std::vector<Positions>& fields,
                                                int modes) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    const std::size_t w = 3 * fields.size();
    const std::size_t ld = stride_;
    // (B^T [X_1 ... X_q])^T (3q x ld) per chunk, one evaluation of B for all fields.
    std::vector<std::vector<double>> parts(chunks_.size(), std::vector<double>(w * ld, 0.0));
    for_each_block(
        [&](std::size_t chunk, double* B, const double* /*P*/, const std::int32_t* vertices,
            std::size_t rows, std::size_t /*begin*/, double* spare)
        {
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
                const auto row = vertices[i];
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
    const Eigen::MatrixXd bt_x = reduce_columns(parts, w);
    std::vector<Eigen::MatrixX3d> result;
    result.reserve(fields.size());
    for (std::size_t f = 0; f < fields.size(); ++f)
    {
        result.emplace_back(T.transpose() * bt_x.middleCols(3 * static_cast<Eigen::Index>(f), 3));
    }
    return result;
}

Eigen::MatrixXd RbfBasis::project_design(int modes, int head, std::size_t width,
                                         const DesignFill& fill) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    if (head < 0 || head > modes)
    {
        throw InvalidOption("project_design: head = " + std::to_string(head) + " is outside 0.." +
                            std::to_string(modes) + ".");
    }
    const auto h = static_cast<std::size_t>(head);
    const std::size_t ld = stride_;
    // The head modes exactly as modes_dense() computes them: the same multiply of B by the
    // same columns of T (each output column is its own fixed sequence of operations).
    const std::vector<double> t_head =
        h > 0 ? columns_transposed(T.leftCols(head)) : std::vector<double>();
    std::vector<std::vector<double>> parts(chunks_.size(), std::vector<double>(width * ld, 0.0));
    for_each_block(
        [&](std::size_t chunk, double* B, const double* /*P*/, const std::int32_t* vertices,
            std::size_t rows, std::size_t /*begin*/, double* /*spare*/)
        {
            // Per thread, reused from block to block.
            thread_local std::vector<double> u;
            thread_local std::vector<double> x;
            u.resize(rows * h);
            x.assign(rows * width, 0.0);
            if (h > 0)
            {
                kernels_->multiply(B, rows, ld, t_head.data(), h, u.data());
            }
            fill(std::span<const std::int32_t>(vertices, rows), h > 0 ? u.data() : nullptr,
                 x.data());
            kernels_->accumulate(B, rows, ld, x.data(), width, parts[chunk].data());
        });
    return T.transpose() * reduce_columns(parts, width);
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
    for_each_block(
        [&](std::size_t chunk, double* B, const double* /*P*/, const std::int32_t* vertices,
            std::size_t rows, std::size_t /*begin*/, double* kept)
        {
            std::size_t count = 0;
            for (std::size_t i = 0; i < rows; ++i)
            {
                const auto row = vertices[i];
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
    const std::vector<double> total = detail::sum_parts(parts);
    const Eigen::MatrixXd gram_kept = unpack_gram(total);
    Eigen::MatrixX3d rhs(k, 3);
    for (std::size_t i = 0; i < static_cast<std::size_t>(k); ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            rhs(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)) =
                total[(kp + d) * ld + column_[i]];
        }
    }
    // U_m^T U_m is the identity on the whole mesh: a smallest eigenvalue at or below this over the
    // kept rows (a condition number of 1e8) leaves the coefficients undetermined. Chosen by
    // hand; no study on record.
    constexpr double kMinKeptEigenvalue = 1e-8;
    const Eigen::MatrixXd normal = T.transpose() * gram_kept * T;  // U_m,S^T U_m,S
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> check(normal);
    if (check.info() != Eigen::Success || !(check.eigenvalues()(0) > kMinKeptEigenvalue))
    {
        throw NumericalError(
            "too few vertices survive the cropping to determine the watermark's "
            "coefficients (least-squares matrix is singular).");
    }
    return normal.ldlt().solve(T.transpose() * rhs);
}

Positions RbfBasis::synthesize(const Eigen::MatrixX3d& c, double* orthogonality_error) const
{
    const int modes = static_cast<int>(c.rows());
    const Eigen::MatrixXd T = mode_transform(modes);
    const Eigen::MatrixX3d Tc = T * c;
    const std::size_t ld = stride_;
    const std::vector<double> tc_t = columns_transposed(Tc);  // (T c)^T, zero on the padding
    Positions result = Positions::Zero(static_cast<Eigen::Index>(rows_->vertex_count()), 3);
    const bool check = orthogonality_error != nullptr;
    std::vector<std::vector<double>> parts(check ? chunks_.size() : 0,
                                           std::vector<double>(3 * ld, 0.0));
    for_each_block(
        [&](std::size_t chunk, double* B, const double* /*P*/, const std::int32_t* vertices,
            std::size_t rows, std::size_t /*begin*/, double* d)
        {
            kernels_->multiply(B, rows, ld, tc_t.data(), 3, d);
            for (std::size_t i = 0; i < rows; ++i)
            {
                const auto row = vertices[i];
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

void RbfBasis::synthesize_streamed(const Eigen::MatrixX3d& c, std::size_t chunks_in_flight,
                                   const FieldSink& sink, double* orthogonality_error) const
{
    const int modes = static_cast<int>(c.rows());
    const Eigen::MatrixXd T = mode_transform(modes);
    const Eigen::MatrixX3d Tc = T * c;
    const std::size_t ld = stride_;
    const std::vector<double> tc_t = columns_transposed(Tc);
    const bool check = orthogonality_error != nullptr;
    std::vector<std::vector<double>> parts(check ? chunks_.size() : 0,
                                           std::vector<double>(3 * ld, 0.0));
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
            [&](std::size_t chunk, double* B, const double* /*P*/, const std::int32_t* /*vertices*/,
                std::size_t rows, std::size_t begin, double* d)
            {
                kernels_->multiply(B, rows, ld, tc_t.data(), 3, d);
                std::copy(d, d + 3 * rows,
                          buffers[chunk - first].data() + 3 * (begin - chunks_[chunk].begin));
                if (check)
                {
                    kernels_->accumulate(B, rows, ld, d, 3, parts[chunk].data());
                }
            },
            first, last);
        if (delivering.valid())
        {
            delivering.get();  // the previous round is out (or its exception is thrown here)
        }
        delivering = std::async(std::launch::async,
                                [this, &sink, &buffers, first, last]()
                                {
                                    for (std::size_t i = first; i < last; ++i)
                                    {
                                        sink(chunks_[i].begin, chunks_[i].end - chunks_[i].begin,
                                             buffers[i - first].data());
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
    const auto modes = c.rows();
    const Eigen::MatrixXd utu = T.transpose() * gram_ * T;
    const double modes_error =
        (utu - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff();
    const Eigen::MatrixX3d bt_f = reduce_columns(parts, 3);
    const double scale = c.cwiseAbs().maxCoeff();
    const double field_error =
        scale > 0.0 ? (T.transpose() * bt_f - c).cwiseAbs().maxCoeff() / scale : 0.0;
    return std::max(modes_error, field_error);
}

Eigen::MatrixXd RbfBasis::modes_dense(int modes) const
{
    const Eigen::MatrixXd T = mode_transform(modes);
    const auto m = static_cast<std::size_t>(modes);
    const std::size_t ld = stride_;
    const std::vector<double> t_t = columns_transposed(T);
    Eigen::MatrixXd U(static_cast<Eigen::Index>(row_count_), modes);
    for_each_block(
        [&](std::size_t /*chunk*/, double* B, const double* /*P*/, const std::int32_t* /*vertices*/,
            std::size_t rows, std::size_t begin, double* /*spare*/)
        {
            std::vector<double> out(rows * m);
            kernels_->multiply(B, rows, ld, t_t.data(), m, out.data());
            for (std::size_t i = 0; i < rows; ++i)
            {
                for (std::size_t c = 0; c < m; ++c)
                {
                    U(static_cast<Eigen::Index>(begin + i), static_cast<Eigen::Index>(c)) =
                        out[i * m + c];
                }
            }
        });
    return U;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/basis/rbf_basis.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <set>
#include <span>

#include <Eigen/SVD>
#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

std::vector<std::int32_t> all_rows(const TriangleMesh& mesh)
{
    return referenced_vertices(mesh);
}

// Dense reference: B evaluated directly, in the same centered frame.
Eigen::MatrixXd dense_B(const Positions& V, const std::vector<std::int32_t>& rows,
                        const std::vector<std::int32_t>& centers, double sigma)
{
    Eigen::MatrixXd B(static_cast<Eigen::Index>(rows.size()),
                      static_cast<Eigen::Index>(centers.size()));
    for (std::size_t i = 0; i < rows.size(); ++i)
    {
        for (std::size_t j = 0; j < centers.size(); ++j)
        {
            const double r = (V.row(rows[i]) - V.row(centers[j])).norm() / sigma;
            B(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = wendland(r);
        }
    }
    return B;
}

}  // namespace

TEST(WendlandTest, matches_closed_form_and_support)
{
    EXPECT_DOUBLE_EQ(wendland(0.0), 1.0);
    EXPECT_DOUBLE_EQ(wendland(0.5), std::pow(0.5, 4) * 3.0);
    EXPECT_DOUBLE_EQ(wendland(1.0), 0.0);
    EXPECT_DOUBLE_EQ(wendland(2.5), 0.0);
    // C2 at the support boundary: value and slope vanish.
    EXPECT_LT(wendland(1.0 - 1e-4), 1e-15);
}

TEST(RbfBasisTest, gram_matches_dense_computation)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);  // 642 vertices: several blocks
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 40, 11);
    const double sigma = 0.9;
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const RbfBasis basis(position_rows(mesh.V, rows), centers, sigma, origin, 2);
    const Eigen::MatrixXd B = dense_B(mesh.V, rows, centers, sigma);
    const Eigen::MatrixXd G = B.transpose() * B;
    EXPECT_LT((basis.gram() - G).cwiseAbs().maxCoeff(), 1e-10 * G.cwiseAbs().maxCoeff());
    // Singular values are those of B, descending.
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(B);
    for (int j = 0; j < 10; ++j)
    {
        EXPECT_NEAR(basis.singular_values()(j), svd.singularValues()(j),
                    1e-9 * svd.singularValues()(0));
    }
    for (int j = 1; j < basis.size(); ++j)
    {
        EXPECT_GE(basis.singular_values()(j - 1), basis.singular_values()(j));
    }
}

TEST(RbfBasisTest, leading_modes_are_orthonormal_and_span_B)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 60, 5);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const RbfBasis basis(position_rows(mesh.V, rows), centers, 1.0, origin, 1);
    const int m = 8;
    const Eigen::MatrixXd U = basis.modes_dense(m);
    EXPECT_LT((U.transpose() * U - Eigen::MatrixXd::Identity(m, m)).cwiseAbs().maxCoeff(), 1e-9);
    // U = B V W^-1 exactly as the dense formula says.
    const Eigen::MatrixXd B = dense_B(mesh.V, rows, centers, 1.0);
    const Eigen::MatrixXd U_ref = B * basis.eigenvectors().leftCols(m) *
                                  basis.singular_values().head(m).cwiseInverse().asDiagonal();
    EXPECT_LT((U - U_ref).cwiseAbs().maxCoeff(), 1e-9);
    // Sign convention: every mode has a positive sum.
    for (int j = 0; j < m; ++j)
    {
        EXPECT_GT(U.col(j).sum(), 0.0);
    }
    // The synthesis pass measures the same orthogonality.
    double error = 1.0;
    const Positions d = basis.synthesize(Eigen::MatrixX3d::Ones(m, 3), &error);
    EXPECT_LT(error, 1e-9);
    EXPECT_NEAR(d.col(0).squaredNorm(), static_cast<double>(m), 1e-8);
}

TEST(RbfBasisTest, project_design_equals_the_dense_product_for_any_thread_count)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);  // 2562 vertices: several chunks
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 50, 3);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const int modes = 20;
    const int head = 6;
    constexpr std::size_t kWidth = 7;
    // Design row i: products of the head modes with the positions, and a constant column.
    auto design_row = [&](std::int32_t i, const double* u, double* x)
    {
        for (std::size_t c = 0; c + 1 < kWidth; ++c)
        {
            x[c] =
                u[c % static_cast<std::size_t>(head)] * mesh.V(i, static_cast<Eigen::Index>(c % 3));
        }
        x[kWidth - 1] = 1.0;
    };
    std::vector<Eigen::MatrixXd> results;
    for (const int threads : {1, 2, 3})
    {
        const RbfBasis basis(position_rows(mesh.V, rows), centers, 1.1, origin, threads);
        results.push_back(basis.project_design(
            modes, head, kWidth,
            [&](std::span<const std::int32_t> block, const double* U, double* X)
            {
                for (std::size_t a = 0; a < block.size(); ++a)
                {
                    design_row(block[a], U + a * static_cast<std::size_t>(head), X + a * kWidth);
                }
            }));
        if (threads == 1)
        {
            // Against the dense modes: the same design, then U^T X.
            const Eigen::MatrixXd U = basis.modes_dense(modes);
            Eigen::MatrixXd X(U.rows(), static_cast<Eigen::Index>(kWidth));
            for (Eigen::Index a = 0; a < U.rows(); ++a)
            {
                const Eigen::RowVectorXd u = U.row(a).head(head);
                Eigen::RowVectorXd x(static_cast<Eigen::Index>(kWidth));
                design_row(rows[static_cast<std::size_t>(a)], u.data(), x.data());
                X.row(a) = x;
            }
            const Eigen::MatrixXd expected = U.transpose() * X;
            EXPECT_LT((results.back() - expected).cwiseAbs().maxCoeff(),
                      1e-9 * expected.cwiseAbs().maxCoeff());
        }
    }
    EXPECT_EQ(results[0], results[1]);
    EXPECT_EQ(results[0], results[2]);
}

TEST(RbfBasisTest, projection_inverts_synthesis_and_least_squares_handles_cropping)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);  // 2562 vertices
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 50, 9);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const RbfBasis basis(position_rows(mesh.V, rows), centers, 1.2, origin, 2);
    Eigen::MatrixX3d c(6, 3);
    Rng rng(1);
    for (Eigen::Index i = 0; i < c.size(); ++i)
    {
        c.data()[i] = rng.normal();
    }
    const Positions field = basis.synthesize(c);
    EXPECT_LT((basis.project(field, 6) - c).cwiseAbs().maxCoeff(), 1e-9);
    // Keep only the half with x > 0: least squares still recovers the coefficients of a field
    // that lies in the span of the basis.
    std::vector<std::uint8_t> kept(static_cast<std::size_t>(mesh.V.rows()));
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        kept[static_cast<std::size_t>(i)] = mesh.V(i, 0) > 0.0 ? 1 : 0;
    }
    EXPECT_LT((basis.project_least_squares(field, kept, 6) - c).cwiseAbs().maxCoeff(), 1e-5);
    // The plain projection of the cropped field is badly off, which is why least squares exists.
    Positions cropped = field;
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        if (kept[static_cast<std::size_t>(i)] == 0)
        {
            cropped.row(i).setZero();
        }
    }
    EXPECT_GT((basis.project(cropped, 6) - c).cwiseAbs().maxCoeff(), 0.1);
}

TEST(RbfBasisTest, results_are_bit_identical_for_any_thread_count)
{
    const TriangleMesh mesh = lumpy_ellipsoid(5);  // 10242 vertices: several chunks
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 100, 3);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const RbfBasis one(position_rows(mesh.V, rows), centers, 1.0, origin, 1);
    const RbfBasis two(position_rows(mesh.V, rows), centers, 1.0, origin, 2);
    const RbfBasis three(position_rows(mesh.V, rows), centers, 1.0, origin, 3);
    EXPECT_TRUE(one.gram() == two.gram());
    EXPECT_TRUE(one.gram() == three.gram());
    const Eigen::MatrixX3d c = Eigen::MatrixX3d::Ones(8, 3);
    EXPECT_TRUE(one.synthesize(c) == two.synthesize(c));
    EXPECT_TRUE(one.synthesize(c) == three.synthesize(c));
}

TEST(RbfBasisTest, sampled_gram_uses_evenly_spaced_rows_scaled_to_all_of_them)
{
    const TriangleMesh mesh = lumpy_ellipsoid(5);  // 10242 vertices
    const auto rows = all_rows(mesh);
    const auto n = static_cast<Eigen::Index>(rows.size());
    const auto centers = random_centers(mesh.V, rows, 50, 8);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    constexpr std::size_t m = 1500;
    const RbfBasis sampled(position_rows(mesh.V, rows), centers, 1.0, origin, 2, m);
    EXPECT_EQ(sampled.gram_sample_rows(), m);

    // Against the definition: rows floor((2i + 1) n / 2m) of dense B, times n / m.
    const Eigen::MatrixXd B = dense_B(mesh.V, rows, centers, 1.0);
    Eigen::MatrixXd G = Eigen::MatrixXd::Zero(B.cols(), B.cols());
    for (std::size_t i = 0; i < m; ++i)
    {
        const auto r = static_cast<Eigen::Index>((2 * i + 1) * rows.size() / (2 * m));
        G += B.row(r).transpose() * B.row(r);
    }
    G *= static_cast<double>(n) / static_cast<double>(m);
    EXPECT_LT((sampled.gram() - G).cwiseAbs().maxCoeff(), 1e-10 * G.cwiseAbs().maxCoeff());

    // An estimate: U over all rows is orthonormal up to the sampling error (3.5% here: a 15%
    // sample of a mesh whose rows come level by level of a subdivision; without the n / m
    // scale it would be 5.8, with the first m rows instead of spread ones far above 0.1), and
    // close to the exact basis.
    const RbfBasis exact(position_rows(mesh.V, rows), centers, 1.0, origin, 2);
    const Eigen::MatrixXd U = sampled.modes_dense(20);
    const double error =
        (U.transpose() * U - Eigen::MatrixXd::Identity(20, 20)).cwiseAbs().maxCoeff();
    EXPECT_GT(error, 1e-12);
    EXPECT_LT(error, 0.1);
    const Eigen::MatrixXd Ue = exact.modes_dense(20);
    for (const Eigen::Index j : {0, 5, 12, 19})
    {
        EXPECT_GT(std::abs(U.col(j).dot(Ue.col(j))), 0.95) << "mode " << j;
    }
    // The first m rows alone (a cap of the ellipsoid) would be a far worse estimate.
    std::vector<std::int32_t> first(rows.begin(), rows.begin() + static_cast<std::ptrdiff_t>(m));
    const RbfBasis cap(position_rows(mesh.V, first), centers, 1.0, origin, 2);
    const Eigen::MatrixXd scaled_cap =
        cap.gram() * (static_cast<double>(n) / static_cast<double>(m));
    EXPECT_GT((scaled_cap - exact.gram()).norm(), 3.0 * (sampled.gram() - exact.gram()).norm());

    // Sampled pass 1 is bit-identical for any thread count; gram_rows >= n means every row.
    const RbfBasis one_thread(position_rows(mesh.V, rows), centers, 1.0, origin, 1, m);
    EXPECT_TRUE(one_thread.gram() == sampled.gram());
    const RbfBasis all(position_rows(mesh.V, rows), centers, 1.0, origin, 2, rows.size());
    EXPECT_EQ(all.gram_sample_rows(), rows.size());
    EXPECT_TRUE(all.gram() == exact.gram());
}

namespace
{

// The active rows as a file-like stream: positions copied out in active-row order, read one
// record at a time like the out-of-core embedding's source.
class RecordRows final : public RowPositionSource
{
public:
    RecordRows(const Positions& V, const std::vector<std::int32_t>& rows)
        : rows_(rows), vertex_count_(V.rows())
    {
        for (const auto row : rows)
        {
            records_.push_back({V(row, 0), V(row, 1), V(row, 2)});
        }
    }
    [[nodiscard]] std::size_t size() const override { return rows_.size(); }
    [[nodiscard]] std::size_t vertex_count() const override
    {
        return static_cast<std::size_t>(vertex_count_);
    }
    [[nodiscard]] std::int32_t row(std::size_t i) const override { return rows_[i]; }
    [[nodiscard]] std::array<double, 3> position(std::int32_t row) const override
    {
        const auto at = std::lower_bound(rows_.begin(), rows_.end(), row);
        return records_[static_cast<std::size_t>(at - rows_.begin())];
    }
    [[nodiscard]] std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const override
    {
        return std::make_unique<Cursor>(*this, begin);
    }

private:
    struct Cursor final : RowPositionCursor
    {
        Cursor(const RecordRows& rows, std::size_t begin) : owner(rows), next(begin) {}
        void read(std::size_t count, double* xyz, std::int32_t* rows) override
        {
            for (std::size_t i = 0; i < count; ++i, ++next)
            {
                std::copy_n(owner.records_[next].data(), 3, xyz + 3 * i);
                rows[i] = owner.rows_[next];
            }
        }
        void read_at(std::span<const std::size_t> indices, double* xyz, std::int32_t* rows) override
        {
            for (std::size_t i = 0; i < indices.size(); ++i)
            {
                EXPECT_GE(indices[i], next);
                next = indices[i];
                read(1, xyz + 3 * i, rows + i);
            }
        }
        const RecordRows& owner;
        std::size_t next;
    };
    std::vector<std::int32_t> rows_;
    Eigen::Index vertex_count_;
    std::vector<std::array<double, 3>> records_;
};

}  // namespace

TEST(RbfBasisTest, streamed_synthesis_delivers_the_field_in_order_and_passes_sink_errors_on)
{
    const TriangleMesh mesh = lumpy_ellipsoid(6);  // 40962 vertices: 11 chunks, 6 rounds of 2
    const auto rows = all_rows(mesh);
    const auto centers = random_centers(mesh.V, rows, 40, 4);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    const RbfBasis memory(position_rows(mesh.V, rows), centers, 1.0, origin, 2, 5000);
    const RbfBasis streamed(std::make_shared<RecordRows>(mesh.V, rows), centers, 1.0, origin, 2,
                            5000);
    EXPECT_TRUE(memory.gram() == streamed.gram());  // the sampled rows read through the source

    Eigen::MatrixX3d c = Eigen::MatrixX3d::Zero(16, 3);
    c(12, 0) = 1.0;
    c(15, 2) = -0.5;
    double memory_error = 0.0;
    const Positions expected = memory.synthesize(c, &memory_error);
    Positions delivered = Positions::Constant(mesh.V.rows(), 3, -7.0);
    std::size_t next = 0;
    double streamed_error = 0.0;
    streamed.synthesize_streamed(
        c, 2,
        [&](std::size_t begin, std::size_t count, const double* field)
        {
            EXPECT_EQ(begin, next);
            for (std::size_t i = 0; i < count; ++i)
            {
                for (Eigen::Index d = 0; d < 3; ++d)
                {
                    delivered(rows[begin + i], d) = field[3 * i + static_cast<std::size_t>(d)];
                }
            }
            next = begin + count;
        },
        &streamed_error);
    EXPECT_EQ(next, rows.size());
    EXPECT_TRUE(delivered == expected);
    EXPECT_EQ(memory_error, streamed_error);
    EXPECT_TRUE(streamed.synthesize(c) == expected);  // every query works on any source
    EXPECT_TRUE(streamed.project(expected, 16) == memory.project(expected, 16));

    // A sink that fails on its fourth chunk: the error comes out, no chunk is delivered after it.
    int calls = 0;
    try
    {
        streamed.synthesize_streamed(c, 2,
                                     [&](std::size_t, std::size_t, const double*)
                                     {
                                         if (++calls == 4)
                                         {
                                             throw IoError("disk full");
                                         }
                                     });
        FAIL() << "the sink's error was lost";
    }
    catch (const IoError& e)
    {
        EXPECT_STREQ(e.what(), "disk full");
    }
    EXPECT_EQ(calls, 4);
}

TEST(RandomCentersTest, deterministic_distinct_and_refuses_too_few_positions)
{
    TriangleMesh mesh = icosphere(2);
    const auto rows = all_rows(mesh);
    const auto a = random_centers(mesh.V, rows, 30, 77);
    EXPECT_EQ(a, random_centers(mesh.V, rows, 30, 77));
    EXPECT_NE(a, random_centers(mesh.V, rows, 30, 78));
    std::vector<std::int32_t> sorted = a;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
    // Duplicate every position: centers never repeat a position.
    Positions doubled(2 * mesh.V.rows(), 3);
    doubled << mesh.V, mesh.V;
    std::vector<std::int32_t> doubled_rows(static_cast<std::size_t>(doubled.rows()));
    std::iota(doubled_rows.begin(), doubled_rows.end(), 0);
    const auto b = random_centers(doubled, doubled_rows, static_cast<int>(mesh.V.rows()), 1);
    std::set<std::array<double, 3>> positions;
    for (const auto i : b)
    {
        positions.insert({doubled(i, 0), doubled(i, 1), doubled(i, 2)});
    }
    EXPECT_EQ(positions.size(), b.size());
    EXPECT_THROW(
        (void)random_centers(doubled, doubled_rows, static_cast<int>(mesh.V.rows()) + 1, 1),
        InvalidMesh);
}

}  // namespace meshmark

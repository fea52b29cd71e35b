// SPDX-License-Identifier: MIT
// The implementations of the basis block kernels (portable, AVX2+FMA, AVX-512): each against
// naive loops, against each other through RbfBasis (AVX-512 bit for bit like AVX2), and
// bit-identical for any thread count.
#include "basis/rbf_kernels.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"

namespace meshmark
{
namespace
{

std::vector<const detail::BlockKernels*> available_kernels()
{
    std::vector<const detail::BlockKernels*> kernels{&detail::portable_kernels()};
    if (detail::avx2_kernels() != nullptr)
    {
        kernels.push_back(detail::avx2_kernels());
    }
    if (detail::avx512_kernels() != nullptr)
    {
        kernels.push_back(detail::avx512_kernels());
    }
    return kernels;
}

// Restores the process-wide choice when a test ends.
struct KernelChoice
{
    explicit KernelChoice(BasisKernel kernel) { set_basis_kernel(kernel); }
    ~KernelChoice() { set_basis_kernel(BasisKernel::Automatic); }
    KernelChoice(const KernelChoice&) = delete;
    KernelChoice& operator=(const KernelChoice&) = delete;
};

/// One basis problem (10242 vertices, 3 chunks, k = 100), built with a chosen kernel.
struct KernelComparison
{
    TriangleMesh mesh = lumpy_ellipsoid(5);
    std::vector<std::int32_t> rows = referenced_vertices(mesh);
    std::vector<std::int32_t> centers = random_centers(mesh.V, rows, 100, 8);
    Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();

    [[nodiscard]] RbfBasis build(BasisKernel kernel) const
    {
        const KernelChoice choice(kernel);
        return RbfBasis(position_rows(mesh.V, rows), centers, 1.0, origin, 2);
    }
};

double max_abs(const std::vector<double>& values)
{
    double largest = 0.0;
    for (const double v : values)
    {
        largest = std::max(largest, std::abs(v));
    }
    return largest;
}

struct Block
{
    std::size_t rows = 77;  // not a multiple of 4 nor of the Gram sub-block
    std::size_t k = 37;     // not a multiple of 4: padding columns
    std::size_t ld = 44;    // padded k (40) + 4
    double inv_sigma = 1.0 / 1.3;
    std::vector<double> P;
    std::vector<double> Q;
};

Block random_block()
{
    Block block;
    Rng rng(99);
    block.P.resize(block.rows * 3);
    for (auto& p : block.P)
    {
        p = rng.uniform(-1.0, 1.0);
    }
    block.Q.assign(3 * block.ld, 0.0);
    for (std::size_t d = 0; d < 3; ++d)
    {
        for (std::size_t j = 0; j < block.k; ++j)
        {
            block.Q[d * block.ld + j] = rng.uniform(-1.0, 1.0);
        }
    }
    return block;
}

}  // namespace

TEST(BlockKernelsTest, every_kernel_matches_naive_loops)
{
    const Block in = random_block();
    const std::size_t rows = in.rows;
    const std::size_t ld = in.ld;
    for (const auto* kernels : available_kernels())
    {
        SCOPED_TRACE(kernels->name);
        std::vector<double> B(rows * ld, -7.0);
        kernels->evaluate(in.P.data(), rows, in.Q.data(), in.k, ld, in.inv_sigma, B.data());
        for (std::size_t r = 0; r < rows; ++r)
        {
            for (std::size_t j = 0; j < ld; ++j)
            {
                double expected = 0.0;
                if (j < in.k)
                {
                    double sq = 0.0;
                    for (std::size_t d = 0; d < 3; ++d)
                    {
                        const double diff = in.P[3 * r + d] - in.Q[d * ld + j];
                        sq += diff * diff;
                    }
                    expected = wendland(std::sqrt(sq) * in.inv_sigma);
                }
                ASSERT_NEAR(B[r * ld + j], expected, 1e-15) << "row " << r << " column " << j;
            }
        }
        // Some entries inside the support, some outside.
        EXPECT_GT(max_abs(B), 0.1);

        // Gram: lower triangle of B^T B added to what G held.
        std::vector<double> G(ld * ld, 0.5);
        kernels->gram(B.data(), rows, ld, G.data());
        for (std::size_t i = 0; i < ld; ++i)
        {
            for (std::size_t j = 0; j <= i; ++j)
            {
                double expected = 0.5;
                for (std::size_t r = 0; r < rows; ++r)
                {
                    expected += B[r * ld + i] * B[r * ld + j];
                }
                ASSERT_NEAR(G[i * ld + j], expected, 1e-13 * (1.0 + std::abs(expected)))
                    << i << ", " << j;
            }
        }

        // multiply (w = 1..7, every column grouping) and accumulate.
        for (std::size_t w = 1; w <= 7; ++w)
        {
            std::vector<double> Mt(w * ld, 0.0);
            std::vector<double> X(rows * w);
            Rng rng(w);
            for (std::size_t c = 0; c < w; ++c)
            {
                for (std::size_t j = 0; j < in.k; ++j)
                {
                    Mt[c * ld + j] = rng.uniform(-1.0, 1.0);
                }
            }
            for (auto& x : X)
            {
                x = rng.uniform(-1.0, 1.0);
            }
            std::vector<double> out(rows * w, 0.0);
            kernels->multiply(B.data(), rows, ld, Mt.data(), w, out.data());
            std::vector<double> acc(w * ld, 0.25);
            kernels->accumulate(B.data(), rows, ld, X.data(), w, acc.data());
            for (std::size_t c = 0; c < w; ++c)
            {
                for (std::size_t r = 0; r < rows; ++r)
                {
                    double expected = 0.0;
                    for (std::size_t j = 0; j < ld; ++j)
                    {
                        expected += B[r * ld + j] * Mt[c * ld + j];
                    }
                    ASSERT_NEAR(out[r * w + c], expected, 1e-13) << "w " << w << " row " << r;
                }
                for (std::size_t j = 0; j < ld; ++j)
                {
                    double expected = 0.25;
                    for (std::size_t r = 0; r < rows; ++r)
                    {
                        expected += X[r * w + c] * B[r * ld + j];
                    }
                    ASSERT_NEAR(acc[c * ld + j], expected, 1e-12) << "w " << w << " column " << j;
                }
            }
        }
    }
}

TEST(BlockKernelsTest, evaluation_is_bit_identical_in_both_kernels)
{
    if (detail::avx2_kernels() == nullptr)
    {
        GTEST_SKIP() << "this CPU has no AVX2+FMA";
    }
    const Block in = random_block();
    std::vector<double> a(in.rows * in.ld);
    std::vector<double> b(in.rows * in.ld);
    detail::portable_kernels().evaluate(in.P.data(), in.rows, in.Q.data(), in.k, in.ld,
                                        in.inv_sigma, a.data());
    detail::avx2_kernels()->evaluate(in.P.data(), in.rows, in.Q.data(), in.k, in.ld, in.inv_sigma,
                                     b.data());
    EXPECT_TRUE(a == b);
}

// The AVX-512 Gram update and accumulation run every entry through the same FMA chain over the
// rows as the AVX2 ones, whatever the tiling: the same bits for every width, including widths
// that are multiples of 4 but not of 8 (the 4-wide remainder tiles) and all column counts.
TEST(BlockKernelsTest, avx512_products_are_bit_identical_to_avx2)
{
    if (detail::avx512_kernels() == nullptr)
    {
        GTEST_SKIP() << "this CPU has no AVX-512F";
    }
    const auto& wide = *detail::avx512_kernels();
    const auto& narrow = *detail::avx2_kernels();
    Rng rng(2024);
    for (const std::size_t ld : {4U, 8U, 12U, 20U, 28U, 44U, 104U})
    {
        for (const std::size_t rows : {1U, 33U, 77U})
        {
            SCOPED_TRACE("ld " + std::to_string(ld) + " rows " + std::to_string(rows));
            std::vector<double> B(rows * ld);
            for (auto& b : B)
            {
                b = rng.uniform(-1.0, 1.0);
            }
            std::vector<double> G_wide(ld * ld, 0.5);
            std::vector<double> G_narrow(ld * ld, 0.5);
            wide.gram(B.data(), rows, ld, G_wide.data());
            narrow.gram(B.data(), rows, ld, G_narrow.data());
            for (std::size_t i = 0; i < ld; ++i)
            {
                for (std::size_t j = 0; j <= i; ++j)
                {
                    ASSERT_EQ(G_wide[i * ld + j], G_narrow[i * ld + j]) << i << ", " << j;
                }
            }
            for (const std::size_t w : {1U, 2U, 3U, 4U, 5U, 7U, 8U, 129U})
            {
                std::vector<double> X(rows * w);
                for (auto& x : X)
                {
                    x = rng.uniform(-1.0, 1.0);
                }
                std::vector<double> acc_wide(w * ld, 0.25);
                std::vector<double> acc_narrow(w * ld, 0.25);
                wide.accumulate(B.data(), rows, ld, X.data(), w, acc_wide.data());
                narrow.accumulate(B.data(), rows, ld, X.data(), w, acc_narrow.data());
                ASSERT_TRUE(acc_wide == acc_narrow) << "w " << w;
            }
        }
    }
}

TEST(BasisKernelTest, choice_is_honoured)
{
    {
        const KernelChoice choice(BasisKernel::Portable);
        EXPECT_EQ(basis_kernel_name(), "portable");
        const TriangleMesh mesh = lumpy_ellipsoid(2);
        const auto rows = referenced_vertices(mesh);
        const RbfBasis basis(position_rows(mesh.V, rows), random_centers(mesh.V, rows, 10, 1), 1.0,
                             Eigen::Vector3d::Zero(), 1);
        EXPECT_EQ(basis.kernel_name(), "portable");
    }
    {
        const KernelChoice choice(BasisKernel::Avx2);
        EXPECT_EQ(basis_kernel_name(), detail::avx2_kernels() != nullptr ? "avx2-fma" : "portable");
    }
    const std::string fallback = detail::avx2_kernels() != nullptr ? "avx2-fma" : "portable";
    const std::string fastest = detail::avx512_kernels() != nullptr ? "avx512" : fallback;
    {
        const KernelChoice choice(BasisKernel::Avx512);
        EXPECT_EQ(basis_kernel_name(), fastest);
    }
    const KernelChoice choice(BasisKernel::Automatic);
    EXPECT_EQ(basis_kernel_name(), fastest);
}

// Whole passes through RbfBasis: AVX-512 gives AVX2's bits (Gram, modes, synthesis, projections).
TEST(BasisKernelTest, avx512_basis_is_bit_identical_to_avx2)
{
    if (detail::avx512_kernels() == nullptr)
    {
        GTEST_SKIP() << "this CPU has no AVX-512F";
    }
    const KernelComparison bases;
    const auto build = [&](BasisKernel kernel) { return bases.build(kernel); };
    const RbfBasis narrow = build(BasisKernel::Avx2);
    const RbfBasis wide = build(BasisKernel::Avx512);
    ASSERT_EQ(narrow.kernel_name(), "avx2-fma");
    ASSERT_EQ(wide.kernel_name(), "avx512");
    EXPECT_TRUE(narrow.gram() == wide.gram());
    EXPECT_TRUE(narrow.eigenvectors() == wide.eigenvectors());
    const Eigen::MatrixX3d c = Eigen::MatrixX3d::Constant(8, 3, -0.5);
    const Positions field = narrow.synthesize(c);
    EXPECT_TRUE(field == wide.synthesize(c));
    EXPECT_TRUE(narrow.project(std::vector<Positions>{field}, 8)[0] ==
                wide.project(std::vector<Positions>{field}, 8)[0]);
}

// The documented cross-CPU contract: AVX2 and portable results agree to rounding, and a field
// synthesized with one reads back through the other's projection.
TEST(BasisKernelTest, avx2_and_portable_agree_to_rounding)
{
    if (detail::avx2_kernels() == nullptr)
    {
        GTEST_SKIP() << "this CPU has no AVX2+FMA";
    }
    const KernelComparison bases;
    const auto build = [&](BasisKernel kernel) { return bases.build(kernel); };
    const RbfBasis portable = build(BasisKernel::Portable);
    const RbfBasis fast = build(BasisKernel::Avx2);
    ASSERT_EQ(portable.kernel_name(), "portable");
    ASSERT_EQ(fast.kernel_name(), "avx2-fma");

    const double gram_scale = portable.gram().cwiseAbs().maxCoeff();
    const double gram_diff = (portable.gram() - fast.gram()).cwiseAbs().maxCoeff() / gram_scale;
    EXPECT_GT(gram_diff, 0.0) << "FMA should change some last bits; is the AVX2 path used?";
    EXPECT_LT(gram_diff, 1e-13);
    for (Eigen::Index j = 0; j < 20; ++j)
    {
        EXPECT_NEAR(fast.singular_values()(j), portable.singular_values()(j),
                    1e-11 * portable.singular_values()(0));
    }
    const int m = 8;
    Eigen::MatrixX3d c(m, 3);
    Rng rng(5);
    for (Eigen::Index i = 0; i < c.size(); ++i)
    {
        c.data()[i] = rng.uniform(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
    }
    double error_portable = 1.0;
    double error_fast = 1.0;
    const Positions field_portable = portable.synthesize(c, &error_portable);
    const Positions field_fast = fast.synthesize(c, &error_fast);
    EXPECT_LT(error_portable, 1e-10);
    EXPECT_LT(error_fast, 1e-10);
    const double field_scale = field_portable.cwiseAbs().maxCoeff();
    EXPECT_LT((field_fast - field_portable).cwiseAbs().maxCoeff(), 1e-10 * field_scale);
    // Embedded on one CPU, read on the other: the coefficients come back to ~1e-10.
    EXPECT_LT((portable.project(field_fast, m) - c).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_LT((fast.project(field_portable, m) - c).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(BasisKernelTest, every_pass_is_bit_identical_for_1_2_3_threads_with_each_kernel)
{
    const TriangleMesh mesh = lumpy_ellipsoid(5);  // several chunks
    const auto rows = referenced_vertices(mesh);
    const auto centers = random_centers(mesh.V, rows, 37, 4);
    const Eigen::Vector3d origin = mesh.V.colwise().mean().transpose();
    std::vector<std::uint8_t> kept(static_cast<std::size_t>(mesh.V.rows()), 1);
    for (std::size_t i = 0; i < kept.size(); i += 3)
    {
        kept[i] = 0;
    }
    const Eigen::MatrixX3d c = Eigen::MatrixX3d::Constant(6, 3, 0.5);
    for (const BasisKernel kernel : {BasisKernel::Portable, BasisKernel::Avx2, BasisKernel::Avx512})
    {
        const KernelChoice choice(kernel);
        SCOPED_TRACE(std::string(basis_kernel_name()));
        const RbfBasis one(position_rows(mesh.V, rows), centers, 0.8, origin, 1);
        const Positions field = one.synthesize(c);
        const auto projected = one.project(std::vector<Positions>{field, mesh.V}, 6);
        const Eigen::MatrixX3d least_squares = one.project_least_squares(field, kept, 6);
        for (const int threads : {2, 3})
        {
            const RbfBasis other(position_rows(mesh.V, rows), centers, 0.8, origin, threads);
            EXPECT_TRUE(one.gram() == other.gram());
            EXPECT_TRUE(one.eigenvectors() == other.eigenvectors());
            EXPECT_TRUE(one.position_coefficients() == other.position_coefficients());
            EXPECT_TRUE(field == other.synthesize(c));
            const auto other_projected = other.project(std::vector<Positions>{field, mesh.V}, 6);
            EXPECT_TRUE(projected[0] == other_projected[0]);
            EXPECT_TRUE(projected[1] == other_projected[1]);
            EXPECT_TRUE(least_squares == other.project_least_squares(field, kept, 6));
        }
        // And the passes are right: the projection inverts the synthesis.
        EXPECT_LT((projected[0] - c).cwiseAbs().maxCoeff(), 1e-9);
        EXPECT_LT((least_squares - c).cwiseAbs().maxCoeff(), 1e-8);
    }
}

}  // namespace meshmark

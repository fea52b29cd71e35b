// SPDX-License-Identifier: MIT
// The Laplacian eigenbasis: the operator, the eigenpairs (orthonormal, L u = lambda u, ascending,
// known spectrum), the SpectralBasis queries, and the decimated RBF centers.
#include "meshmark/basis/laplacian_basis.h"

#include <array>
#include <cmath>
#include <set>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <gtest/gtest.h>

#include "meshmark/basis/decimated_centers.h"
#include "meshmark/core/error.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

Eigen::Vector3d centroid(const TriangleMesh& mesh)
{
    return mesh.V.colwise().mean().transpose();
}

// Checks L U = U diag(lambda), U^T U = I and ascending eigenvalues.
void expect_eigenpairs(const TriangleMesh& mesh, const LaplacianBasis& basis, double tolerance)
{
    const auto rows = referenced_vertices(mesh);
    const Eigen::SparseMatrix<double> L = combinatorial_laplacian(mesh, rows);
    const Eigen::MatrixXd& U = basis.eigenvectors();
    const Eigen::VectorXd& lambda = basis.eigenvalues();
    const Eigen::MatrixXd residual = L * U - U * lambda.asDiagonal();
    EXPECT_LT(residual.cwiseAbs().maxCoeff(), tolerance);
    const auto k = U.cols();
    EXPECT_LT((U.transpose() * U - Eigen::MatrixXd::Identity(k, k)).cwiseAbs().maxCoeff(), 1e-10);
    for (Eigen::Index j = 1; j < k; ++j)
    {
        EXPECT_LE(lambda(j - 1), lambda(j) + 1e-12) << j;
    }
}

}  // namespace

TEST(LaplacianBasisTest, combinatorial_laplacian_is_symmetric_with_zero_row_sums)
{
    const TriangleMesh mesh = icosphere(2);
    const Eigen::SparseMatrix<double> L = combinatorial_laplacian(mesh, referenced_vertices(mesh));
    const Eigen::MatrixXd dense = L;
    EXPECT_EQ((dense - dense.transpose()).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_LT(dense.rowwise().sum().cwiseAbs().maxCoeff(), 1e-15);
    // Icosphere: 12 vertices of degree 5, the others degree 6.
    EXPECT_EQ((dense.diagonal().array() == 5.0).count(), 12);
    EXPECT_EQ((dense.diagonal().array() == 6.0).count(), mesh.V.rows() - 12);
}

TEST(LaplacianBasisTest, closed_mesh_has_constant_first_mode_and_true_eigenvalues)
{
    // Icosphere (162 vertices), closed and connected: the first eigenvalue is 0 with the
    // constant vector, and every eigenvalue found is one of the dense Laplacian's. (Which ones:
    // its icosahedral symmetry repeats eigenvalues 3-5 times, and a single-vector Lanczos
    // iteration need not find every copy; see docs/algorithms/basis.md, "Symmetric meshes". The
    // count of the smallest ones is checked on a scanned mesh below.)
    const TriangleMesh mesh = icosphere(2);
    const auto rows = referenced_vertices(mesh);
    const Eigen::MatrixXd dense = combinatorial_laplacian(mesh, rows);
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> reference(dense, Eigen::EigenvaluesOnly);
    for (const auto factorization :
         {LaplacianFactorization::Cholmod, LaplacianFactorization::SimplicialLdlt})
    {
        const LaplacianBasis basis(mesh, rows, centroid(mesh),
                                   {.modes = 12, .factorization = factorization});
        ASSERT_EQ(basis.size(), 12);
        EXPECT_NEAR(basis.eigenvalues()(0), 0.0, 1e-10);
        const Eigen::VectorXd first = basis.eigenvectors().col(0);
        const double c = 1.0 / std::sqrt(static_cast<double>(rows.size()));
        EXPECT_LT((first.array() - c).abs().maxCoeff(), 1e-10)
            << "constant, positive by the sign rule";
        for (Eigen::Index j = 0; j < basis.size(); ++j)
        {
            EXPECT_LT((reference.eigenvalues().array() - basis.eigenvalues()(j)).abs().minCoeff(),
                      1e-9)
                << j;
        }
        expect_eigenpairs(mesh, basis, 1e-8);
    }
}

TEST(LaplacianBasisTest, shared_bunny_eigenvectors_are_orthonormal_eigenpairs)
{
    const auto path = test::mesh_dir() / "bunny.off";
    if (!std::filesystem::exists(path))
    {
        GTEST_SKIP() << path << " missing";
    }
    const TriangleMesh mesh = read_mesh(path);
    const LaplacianBasis basis(mesh, referenced_vertices(mesh), centroid(mesh), {.modes = 40});
    expect_eigenpairs(mesh, basis, 1e-7);
    // They are the 40 smallest: by Sylvester's law of inertia, the negative pivots of
    // LDL^T(L - s I), s between the 40th and the 41st eigenvalue, count the eigenvalues below s.
    const auto rows = referenced_vertices(mesh);
    const LaplacianBasis more(
        mesh, rows, centroid(mesh),
        {.modes = 41, .factorization = LaplacianFactorization::SimplicialLdlt});
    const double s = 0.5 * (more.eigenvalues()(39) + more.eigenvalues()(40));
    ASSERT_GT(more.eigenvalues()(40) - more.eigenvalues()(39), 1e-9);
    Eigen::SparseMatrix<double> shifted = combinatorial_laplacian(mesh, rows);
    for (Eigen::Index i = 0; i < shifted.rows(); ++i)
    {
        shifted.coeffRef(i, i) -= s;
    }
    const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(shifted);
    ASSERT_EQ(ldlt.info(), Eigen::Success);
    EXPECT_EQ((ldlt.vectorD().array() < 0.0).count(), 40);
    EXPECT_LT((more.eigenvalues().head(40) - basis.eigenvalues()).cwiseAbs().maxCoeff(), 1e-9);
    // Sign convention: sum of cubes positive for every mode.
    for (Eigen::Index j = 0; j < basis.size(); ++j)
    {
        EXPECT_GT(basis.eigenvectors().col(j).array().cube().sum(), 0.0) << j;
    }
}

TEST(LaplacianBasisTest, queries_agree_with_the_dense_modes_and_skip_inactive_rows)
{
    // An unreferenced vertex (appended) takes no part: zero in syntheses, ignored in projections.
    TriangleMesh mesh = lumpy_ellipsoid(2);
    const auto n = mesh.V.rows();
    mesh.V.conservativeResize(n + 1, 3);
    mesh.V.row(n) = Eigen::RowVector3d(5.0, 5.0, 5.0);
    const auto rows = referenced_vertices(mesh);
    ASSERT_EQ(static_cast<Eigen::Index>(rows.size()), n);
    const LaplacianBasis basis(mesh, rows, centroid(mesh), {.modes = 30});
    Eigen::MatrixX3d c = Eigen::MatrixX3d::Random(20, 3);
    double orthogonality = 1.0;
    const Positions field = basis.synthesize(c, &orthogonality);
    EXPECT_LT(orthogonality, 1e-10);
    EXPECT_EQ(field.row(n).norm(), 0.0);
    EXPECT_LT((basis.project(field, 20) - c).cwiseAbs().maxCoeff(), 1e-10);
    EXPECT_LT((basis.modes_dense(20) - basis.eigenvectors().leftCols(20)).norm(), 0.0 + 1e-300);
    // Least squares over the rows that survive a crop recovers the same coefficients.
    std::vector<std::uint8_t> kept(static_cast<std::size_t>(n + 1), 1);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        kept[static_cast<std::size_t>(i)] = mesh.V(i, 0) > -0.2 ? 1 : 0;
    }
    const Positions small = basis.synthesize(c.topRows(6));
    EXPECT_LT((basis.project_least_squares(small, kept, 6) - c.topRows(6)).cwiseAbs().maxCoeff(),
              1e-8);
    EXPECT_EQ(basis.well_conditioned_modes(1e-8), 30);
    EXPECT_THROW((void)basis.project(field, 31), InvalidOption);
}

TEST(LaplacianBasisTest, two_builds_are_bit_identical)
{
    // Embedding and detection rebuild the basis from the original: it must not vary.
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const auto rows = referenced_vertices(mesh);
    const LaplacianBasis a(mesh, rows, centroid(mesh), {.modes = 20});
    const LaplacianBasis b(mesh, rows, centroid(mesh), {.modes = 20});
    EXPECT_EQ(a.eigenvalues(), b.eigenvalues());
    EXPECT_EQ(a.eigenvectors(), b.eigenvectors());
}

TEST(LaplacianBasisTest, point_clouds_and_tiny_meshes_are_refused)
{
    TriangleMesh cloud = icosphere(1);
    cloud.F.resize(0, 3);
    EXPECT_THROW(LaplacianBasis(cloud, referenced_vertices(cloud), centroid(cloud), {.modes = 5}),
                 InvalidMesh);
    const TriangleMesh tiny = icosphere(0);  // 12 vertices
    EXPECT_THROW(LaplacianBasis(tiny, referenced_vertices(tiny), centroid(tiny), {.modes = 12}),
                 InvalidMesh);
    EXPECT_THROW(
        LaplacianBasis(tiny, referenced_vertices(tiny), centroid(tiny), {.modes = 4, .shift = 0.0}),
        InvalidOption);
}

TEST(DecimatedCentersTest, deterministic_distinct_and_exactly_k)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);  // 2562 vertices
    const auto rows = referenced_vertices(mesh);
    for (const int k : {7, 50, 100, 333})
    {
        const auto centers = decimated_centers(mesh, rows, k);
        ASSERT_EQ(static_cast<int>(centers.size()), k);
        EXPECT_EQ(centers, decimated_centers(mesh, rows, k)) << "deterministic";
        std::set<std::array<double, 3>> positions;
        for (std::size_t i = 0; i < centers.size(); ++i)
        {
            ASSERT_GE(centers[i], 0);
            ASSERT_LT(centers[i], mesh.V.rows());
            if (i > 0)
            {
                EXPECT_LT(centers[i - 1], centers[i]) << "increasing, hence distinct";
            }
            const auto v = mesh.V.row(centers[i]);
            positions.insert({v(0), v(1), v(2)});
        }
        EXPECT_EQ(static_cast<int>(positions.size()), k) << "distinct positions";
    }
}

TEST(DecimatedCentersTest, welds_seams_skips_unreferenced_rows_and_refuses_point_clouds)
{
    // Every vertex duplicated (a seam everywhere: faces use the copies of one half, the other
    // half unreferenced) plus triangles using both copies: centers sit at distinct positions.
    const TriangleMesh base = icosphere(3);
    const auto n = base.V.rows();
    TriangleMesh mesh;
    mesh.V.resize(2 * n, 3);
    mesh.V << base.V, base.V;
    mesh.F = base.F;
    for (Eigen::Index f = 0; f < mesh.F.rows(); f += 2)
    {
        mesh.F.row(f).array() += static_cast<std::int32_t>(n);
    }
    const auto rows = referenced_vertices(mesh);
    const auto centers = decimated_centers(mesh, rows, 60);
    ASSERT_EQ(centers.size(), 60U);
    std::set<std::array<double, 3>> positions;
    for (const auto c : centers)
    {
        positions.insert({mesh.V(c, 0), mesh.V(c, 1), mesh.V(c, 2)});
    }
    EXPECT_EQ(positions.size(), 60U);
    TriangleMesh cloud = base;
    cloud.F.resize(0, 3);
    EXPECT_THROW((void)decimated_centers(cloud, referenced_vertices(cloud), 10), InvalidMesh);
    EXPECT_THROW((void)decimated_centers(base, referenced_vertices(base), base.V.rows() + 1),
                 InvalidMesh);
}

}  // namespace meshmark

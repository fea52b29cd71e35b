// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Sparse factorization of L - sigma I used by the shift-invert eigensolver.
enum class LaplacianFactorization
{
    Cholmod,         ///< CHOLMOD supernodal Cholesky (SuiteSparse; the default, faster).
    SimplicialLdlt,  ///< Eigen's SimplicialLDLT (no external library).
};

/// Parameters of the Laplacian eigenbasis.
struct LaplacianBasisOptions
{
    int modes = 100;  ///< k, eigenvectors of the smallest eigenvalues (as the RBF basis's 100).
    LaplacianFactorization factorization = LaplacianFactorization::Cholmod;
    /// Shift sigma < 0 of the shift-invert iteration: L - sigma I is then positive definite
    /// (L is positive semi-definite with eigenvalue 0), and the k eigenvalues nearest sigma
    /// are the k smallest. Small against the gaps of the low spectrum (~1e-5 for 400K vertices).
    double shift = -1e-6;
    /// Spectra's relative convergence tolerance on the Ritz values; the Lanczos restarts allowed.
    /// Both chosen by hand (the Laplacian basis is a baseline); no study on record.
    double tolerance = 1e-10;
    int max_iterations = 1000;
    /// \throws InvalidOption naming the field, value and allowed range.
    void validate() const;
};

/// \brief The combinatorial (graph, "Tutte") Laplacian L = D - A over the active rows.
/// \details A_ij = 1 when some triangle has the edge (i, j), D = diag(degrees); symmetric,
/// positive semi-definite, L 1 = 0 [Karni & Gotsman 2000]. Row/column a is vertex active[a].
/// \param mesh    Triangle mesh with faces.
/// \param active  Rows taking part (sorted, unique); edges to other rows are ignored.
[[nodiscard]] Eigen::SparseMatrix<double> combinatorial_laplacian(
    const TriangleMesh& mesh, const std::vector<std::int32_t>& active);

/// \brief The Laplacian eigenbasis of a mesh [Karni & Gotsman 2000; Ohbuchi et al. 2002]: the
/// k eigenvectors of the smallest eigenvalues of the combinatorial Laplacian, the baseline the
/// RBF basis replaces [Wu & Kobbelt 2005].
/// \details Computed by shift-invert Lanczos (Spectra's SymEigsShiftSolver) on L - sigma I,
/// factorized once (CHOLMOD or Eigen's SimplicialLDLT). The eigenvectors are orthonormal in the
/// standard inner product (L is symmetric) and stored densely (#active x k doubles). Eigenvalues
/// ascend. Sign convention: every eigenvector has a positive sum of cubed components
/// (sum_i u_i^3 > 0; the plain sum vanishes for all but the constant mode), falling back to a
/// positive largest component. Within a repeated eigenvalue (symmetric shapes) the basis of the
/// eigenspace is whatever the iteration returns: reproducible for the same input and build,
/// not across machines.
class LaplacianBasis final : public SpectralBasis
{
public:
    /// \param mesh     The mesh (faces required); must outlive the basis.
    /// \param active   Rows taking part (sorted, unique): referenced vertices.
    /// \param origin   Frame origin (the centroid of the active rows).
    /// \throws InvalidMesh for a point cloud or fewer active rows than modes + 1;
    /// InvalidOption for bad options; NumericalError if the factorization or the eigensolver fails.
    LaplacianBasis(const TriangleMesh& mesh, std::vector<std::int32_t> active,
                   const Eigen::Vector3d& origin, const LaplacianBasisOptions& options);

    [[nodiscard]] int size() const noexcept override { return static_cast<int>(U_.cols()); }
    /// Rows taking part (sorted, unique).
    [[nodiscard]] const std::vector<std::int32_t>& active_rows() const noexcept { return active_; }
    /// Eigenvalues of L (k, ascending), matching the columns of eigenvectors().
    [[nodiscard]] const Eigen::VectorXd& eigenvalues() const noexcept { return eigenvalues_; }
    /// U (#active x k), orthonormal columns.
    [[nodiscard]] const Eigen::MatrixXd& eigenvectors() const noexcept { return U_; }
    /// Linear solves (operator applications) the eigensolver needed.
    [[nodiscard]] long long solver_operations() const noexcept { return operations_; }

    [[nodiscard]] Eigen::MatrixX3d position_coefficients() const override;
    [[nodiscard]] Eigen::MatrixX3d project(const Positions& X, int modes) const override;
    [[nodiscard]] std::vector<Eigen::MatrixX3d> project(const std::vector<Positions>& fields,
                                                        int modes) const override;
    /// All k modes: eigenvectors are orthonormal whatever the tolerance.
    [[nodiscard]] int well_conditioned_modes(double relative_tolerance) const override;
    [[nodiscard]] Eigen::MatrixX3d project_least_squares(const Positions& X,
                                                         const std::vector<std::uint8_t>& is_kept,
                                                         int modes) const override;
    /// \param orthogonality_error  max |U_m^T U_m - I| over the modes used, computed.
    [[nodiscard]] Positions synthesize(const Eigen::MatrixX3d& c,
                                       double* orthogonality_error = nullptr) const override;
    /// The field of synthesize() over the active rows, computed at once, delivered in chunks.
    void synthesize_streamed(const Eigen::MatrixX3d& c, std::size_t chunks_in_flight,
                             const FieldSink& sink,
                             double* orthogonality_error = nullptr) const override;
    [[nodiscard]] std::size_t max_chunk_rows() const noexcept override
    {
        return std::size_t{1} << 16U;
    }
    [[nodiscard]] Eigen::MatrixXd modes_dense(int modes) const override;
    /// The rows are visited in order, in blocks, on the calling thread (the eigenvectors are
    /// already materialized, so this is a plain sum U_m^T X).
    [[nodiscard]] Eigen::MatrixXd project_design(int modes, int head, std::size_t width,
                                                 const DesignFill& fill) const override;

private:
    void check_modes(int modes) const;
    // X over the active rows (#active x 3).
    [[nodiscard]] Eigen::MatrixX3d gather(const Positions& X) const;

    const Positions* V_;
    std::vector<std::int32_t> active_;
    Eigen::Vector3d origin_;
    Eigen::MatrixXd U_;
    Eigen::VectorXd eigenvalues_;
    long long operations_ = 0;
};

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief An orthonormal basis U (#active x k) of fields over the active vertices of a mesh,
/// modes ordered from the lowest frequency: what the watermark needs of a spectral domain.
/// \details Two implementations: RbfBasis (orthogonalized RBFs [Wu & Kobbelt 2005], never
/// materialized, streamed in row blocks) and LaplacianBasis (eigenvectors of the mesh Laplacian
/// [Karni & Gotsman 2000; Ohbuchi et al. 2002], materialized as #active x k doubles). The
/// watermark embeds and detects through this interface only, so both bases share the payload,
/// modulation, registration, extraction and verdict. Every query is const and thread-safe, and
/// gives bit-identical results for any thread count. Fields are #V x 3 over all vertices of the
/// file; inactive rows are ignored on input and zero on output. Coefficients are in the frame
/// centered at the basis's origin (the centroid of the active rows).
class SpectralBasis
{
public:
    virtual ~SpectralBasis() = default;

    /// k, the number of modes.
    [[nodiscard]] virtual int size() const noexcept = 0;
    /// Rows taking part (sorted, unique).
    [[nodiscard]] virtual const std::vector<std::int32_t>& active_rows() const noexcept = 0;

    /// \brief Spectral coefficients of the positions, alpha = U^T (P - o) (k x 3, file axes);
    /// modes that are numerically absent get zero.
    [[nodiscard]] virtual Eigen::MatrixX3d position_coefficients() const = 0;

    /// \brief Leading-mode projection U_m^T X over the active rows (m x 3).
    /// \throws InvalidOption unless 1 <= modes <= size(); NumericalError for a degenerate mode.
    [[nodiscard]] virtual Eigen::MatrixX3d project(const Positions& X, int modes) const = 0;

    /// \brief Leading-mode projections of several fields (each modes x 3).
    [[nodiscard]] virtual std::vector<Eigen::MatrixX3d> project(
        const std::vector<Positions>& fields, int modes) const = 0;

    /// \brief Number of leading modes whose projections are numerically trustworthy at
    /// \p relative_tolerance (for the RBF basis: eigenvalue W_j^2 of the Gram matrix above the
    /// tolerance times the largest; for the Laplacian basis: all of them).
    [[nodiscard]] virtual int well_conditioned_modes(double relative_tolerance) const = 0;

    /// \brief Least-squares coefficients of the leading modes over the rows with
    /// \p is_kept[i] != 0 (DESIGN.md step 8). With every row kept this equals project().
    /// \throws NumericalError if the kept rows cannot determine the coefficients.
    [[nodiscard]] virtual Eigen::MatrixX3d project_least_squares(
        const Positions& X, const std::vector<std::uint8_t>& is_kept, int modes) const = 0;

    /// \brief Synthesis U_m c (#V x 3, zero on inactive rows) of the first c.rows() modes.
    /// \param orthogonality_error  If not null, receives max |U_m^T U_m - I| over the modes
    ///        used, or a bound on it (see the implementations).
    [[nodiscard]] virtual Positions synthesize(const Eigen::MatrixX3d& c,
                                               double* orthogonality_error = nullptr) const = 0;

    /// \brief The first \p modes columns of U, explicitly (#active x modes).
    [[nodiscard]] virtual Eigen::MatrixXd modes_dense(int modes) const = 0;
};

}  // namespace meshmark

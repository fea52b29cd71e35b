// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
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
/// modulation, registration, extraction and verdict. Which rows are active is the caller's
/// (SpectralWatermark's) knowledge. Every query is const and thread-safe, and
/// gives bit-identical results for any thread count. Fields are #V x 3 over all vertices of the
/// file; inactive rows are ignored on input and zero on output. Coefficients are in the frame
/// centered at the basis's origin (the centroid of the active rows).
class SpectralBasis
{
public:
    virtual ~SpectralBasis() = default;

    /// Relative eigenvalue (W_j^2 over the largest, RBF basis) at or below which a mode is
    /// numerically absent: project() and synthesize() refuse it (NumericalError), and
    /// well_conditioned_modes(kDegenerateModeTolerance) counts the modes they accept.
    static constexpr double kDegenerateModeTolerance = 1e-14;

    /// k, the number of modes.
    [[nodiscard]] virtual int size() const noexcept = 0;

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
    /// \p is_kept[i] != 0 (cropped copies, docs/algorithms/basis.md). With every row kept this
    /// equals project(). \throws NumericalError if the kept rows cannot determine the coefficients.
    [[nodiscard]] virtual Eigen::MatrixX3d project_least_squares(
        const Positions& X, const std::vector<std::uint8_t>& is_kept, int modes) const = 0;

    /// \brief Synthesis U_m c (#V x 3, zero on inactive rows) of the first c.rows() modes.
    /// \param orthogonality_error  If not null, receives max |U_m^T U_m - I| over the modes
    ///        used, or a bound on it (see the implementations).
    [[nodiscard]] virtual Positions synthesize(const Eigen::MatrixX3d& c,
                                               double* orthogonality_error = nullptr) const = 0;

    /// Receives a synthesized field in active-row order: \p rows rows from active row
    /// \p begin, 3 doubles per row.
    using FieldSink = std::function<void(std::size_t begin, std::size_t rows, const double* field)>;

    /// \brief synthesize() delivered to \p sink chunk by chunk in active-row order instead of
    /// as a #V x 3 array: the same field, bit for bit. The sink is called from one thread at a
    /// time, in order; an exception it throws is passed on once the computation has stopped.
    /// \param chunks_in_flight  Chunks (of at most max_chunk_rows() rows) computed before they
    ///        are delivered, >= 1: the memory of the field is about 2 x chunks_in_flight chunks.
    virtual void synthesize_streamed(const Eigen::MatrixX3d& c, std::size_t chunks_in_flight,
                                     const FieldSink& sink,
                                     double* orthogonality_error = nullptr) const = 0;

    /// Largest number of rows synthesize_streamed() delivers in one chunk.
    [[nodiscard]] virtual std::size_t max_chunk_rows() const noexcept = 0;

    /// \brief Writes a block of design rows: for the active rows \p rows, given their values on
    /// the first `head` modes in \p U (rows.size() x head, row-major), fill \p X
    /// (rows.size() x width, row-major, zero on entry).
    using DesignFill =
        std::function<void(std::span<const std::int32_t> rows, const double* U, double* X)>;

    /// \brief U_m^T X (modes x width) for a design X that is never materialized.
    /// \details X is produced row block by row block by \p fill, which sees the leading \p head
    /// modes of the block's rows (bit-identical to the columns of modes_dense()). Memory is
    /// O(k width) per block instead of the #V x modes of modes_dense(); results are
    /// bit-identical for any thread count. \p fill may be called concurrently from several
    /// threads (each call on its own rows).
    /// \param head  0..modes; 0 passes no modes (U is null).
    [[nodiscard]] virtual Eigen::MatrixXd project_design(int modes, int head, std::size_t width,
                                                         const DesignFill& fill) const = 0;

    /// \brief The first \p modes columns of U, explicitly (#active x modes).
    [[nodiscard]] virtual Eigen::MatrixXd modes_dense(int modes) const = 0;
};

}  // namespace meshmark

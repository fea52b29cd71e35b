// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "meshmark/basis/row_source.h"
#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

namespace detail
{
struct BlockKernels;
}

/// \brief Which implementation of the block arithmetic the basis passes use.
/// \details Avx2 (AVX2 + FMA, about 3x faster; Avx512 gives the same bits) and Portable
/// (baseline x86-64, i.e. SSE2, or any other CPU) give results that are bit-identical for any
/// thread count, but differ from each other in the last bits of the Gram matrix and of the products
/// (FMA rounds once where mul + add rounds twice, and the summation order differs): relative
/// differences of ~1e-13 in the modes and ~1e-12 in a synthesized field (measured in
/// tests/unit/basis). A watermark embedded with one path is read back with the other exactly like
/// with the same path: detection reads coefficient changes in units of the modulation (a bit's
/// undecided band is 1e-1 of it), ten orders of magnitude above that. Choose Portable to make
/// marked files byte-identical across machines with and without AVX2.
enum class BasisKernel
{
    Automatic,  ///< The fastest this CPU has: Avx512, Avx2 or Portable (the default).
    Portable,   ///< Baseline instructions only.
    Avx2,       ///< AVX2 + FMA; falls back to Portable on a CPU without them.
    /// AVX-512F on 8 lanes for the Gram update and the accumulation (AVX2 for the rest): the same
    /// bits as Avx2, faster; falls back to Avx2, then Portable.
    Avx512,
};

/// \brief Choose the kernel of every RbfBasis built afterwards in this process (thread-safe).
/// \details The initial choice is Automatic, or what the environment variable
/// MESHMARK_BASIS_KERNEL says (portable, avx2, avx512 or auto).
void set_basis_kernel(BasisKernel kernel) noexcept;

/// The kernel a basis built now would use: "avx512", "avx2-fma" or "portable".
[[nodiscard]] std::string_view basis_kernel_name() noexcept;

/// \brief Wendland's compactly supported RBF, phi(r) = (1 - r)^4 (4 r + 1) for r < 1, else 0
/// [Wendland 1995; Wu & Kobbelt 2005, Sec. 3].
[[nodiscard]] inline double wendland(double r) noexcept
{
    if (r >= 1.0)
    {
        return 0.0;
    }
    const double t = 1.0 - r;
    const double t2 = t * t;
    return t2 * t2 * (4.0 * r + 1.0);
}

/// \brief Choose \p k centers among the active rows of \p rows, driven by \p seed.
/// \details Uniform sampling without replacement (a partial Fisher-Yates shuffle of the
/// active rows with Rng(seed), shuffled sparsely: O(k) memory, positions read one row at a
/// time); a candidate whose position equals an already chosen center is skipped, because two
/// equal centers make the Gram matrix singular (seams, STL corners).
/// \return k vertex indices, in draw order.
/// \throws InvalidOption if k <= 0; InvalidMesh if fewer than k distinct positions exist.
[[nodiscard]] std::vector<std::int32_t> random_centers(const RowPositionSource& rows, int k,
                                                       std::uint64_t seed);

/// random_centers() over the rows \p active of \p V.
[[nodiscard]] std::vector<std::int32_t> random_centers(const Positions& V,
                                                       const std::vector<std::int32_t>& active,
                                                       int k, std::uint64_t seed);

/// \brief The orthogonalized RBF basis of a mesh [Wu & Kobbelt 2005], never materialized.
/// \details With B_ij = phi(|p_i - q_j| / sigma) over the active rows (n x k), the Gram matrix
/// G = B^T B = V W^2 V^T is accumulated in row blocks (pass 1), and the orthonormal basis is
/// U = B V W^-1, singular values descending. U is never stored: projections and syntheses
/// evaluate B again block by block from the positions of a RowPositionSource (in memory or a
/// file read in chunks), so memory is O(k^2) beyond the source's own. Blocks are grouped into a
/// fixed number of chunks that depends only on n, chunks are reduced in order, so results are
/// bit-identical for any thread count and either kind of source. Eigenvector signs are fixed so
/// that every mode has a positive sum over the vertices (1^T U_j > 0), falling back to a
/// positive largest component. All arithmetic happens in the frame centered at \p origin (the
/// caller passes the centroid), which keeps it independent of where the model sits.
class RbfBasis final : public SpectralBasis
{
public:
    /// \brief Build the basis: pass 1 over the active rows (Gram matrix, B^T 1, B^T (P - o)),
    /// then the eigen-decomposition of the k x k Gram matrix.
    /// \param rows     Active rows and their positions (e.g. position_rows(V, active)); every
    ///        later pass reads them again, so the source is kept.
    /// \param centers  k vertex indices of the centers (positions read from \p rows).
    /// \param sigma    Support radius of phi, > 0.
    /// \param origin   Frame origin (the centroid of the active rows).
    /// \param threads  Worker threads, 0 = all cores.
    /// \param gram_rows  0, or at most this many rows for pass 1: with n active rows and
    ///        0 < gram_rows < n, pass 1 runs over the m = gram_rows rows
    ///        floor((2i + 1) n / 2m), i < m (evenly spaced in row order) and scales its sums
    ///        by n / m, so G, B^T 1 and B^T (P - o) are estimates and U is orthonormal up to
    ///        their sampling error (which synthesize()'s check reports). Otherwise every row.
    /// \throws InvalidOption on empty inputs or sigma <= 0.
    RbfBasis(std::shared_ptr<const RowPositionSource> rows,
             const std::vector<std::int32_t>& centers, double sigma, const Eigen::Vector3d& origin,
             int threads, std::size_t gram_rows = 0);

    /// \brief synthesize() delivered chunk by chunk: rounds of \p chunks_in_flight chunks
    /// (>= 1) are computed in parallel; the sink receives a round on a thread of its own while
    /// the next one is computed, so at most 2 x chunks_in_flight chunks are buffered at once.
    void synthesize_streamed(const Eigen::MatrixX3d& c, std::size_t chunks_in_flight,
                             const FieldSink& sink,
                             double* orthogonality_error = nullptr) const override;

    /// Largest number of rows in one chunk of the passes (the unit synthesize_streamed buffers).
    [[nodiscard]] std::size_t max_chunk_rows() const noexcept override;

    [[nodiscard]] int size() const noexcept override
    {
        return static_cast<int>(center_positions_.rows());
    }
    [[nodiscard]] double sigma() const noexcept { return sigma_; }
    /// The active rows and their positions.
    [[nodiscard]] const RowPositionSource& rows() const noexcept { return *rows_; }
    /// Rows pass 1 ran over: the number of active rows, or gram_rows when that was smaller.
    [[nodiscard]] std::size_t gram_sample_rows() const noexcept { return gram_sample_rows_; }
    /// Singular values of B (k, descending): W in G = V W^2 V^T.
    [[nodiscard]] const Eigen::VectorXd& singular_values() const noexcept
    {
        return singular_values_;
    }
    /// Eigenvectors V of G (k x k, columns match singular_values()).
    [[nodiscard]] const Eigen::MatrixXd& eigenvectors() const noexcept { return eigenvectors_; }
    /// The Gram matrix G = B^T B (k x k), as accumulated.
    [[nodiscard]] const Eigen::MatrixXd& gram() const noexcept { return gram_; }
    /// Implementation of the block arithmetic this basis uses ("avx512", "avx2-fma" or "portable").
    [[nodiscard]] std::string_view kernel_name() const noexcept;

    /// \brief Spectral coefficients of the positions, alpha = U^T (P - o) (k x 3), frame axes.
    [[nodiscard]] Eigen::MatrixX3d position_coefficients() const override;

    /// \brief Leading-mode projection U_m^T X over the active rows (m x 3).
    /// \param X  #V x 3 (inactive rows ignored), e.g. a displacement field.
    [[nodiscard]] Eigen::MatrixX3d project(const Positions& X, int modes) const override;

    /// \brief Leading-mode projections of several fields in one pass (each modes x 3).
    [[nodiscard]] std::vector<Eigen::MatrixX3d> project(const std::vector<Positions>& fields,
                                                        int modes) const override;

    [[nodiscard]] Eigen::MatrixXd project_design(int modes, int head, std::size_t width,
                                                 const DesignFill& fill) const override;

    /// \brief Number of leading modes whose eigenvalue W_j^2 exceeds \p relative_tolerance
    /// times the largest: the modes whose projections are numerically trustworthy.
    [[nodiscard]] int well_conditioned_modes(double relative_tolerance) const override;

    /// \brief Least-squares coefficients of the leading modes over a subset of rows.
    /// \details Minimizes |U_m,S c - X_S| over the rows S of the active set with
    /// \p is_kept[i] != 0 (cropped copies, docs/algorithms/basis.md: the cropped rows are left out
    /// of the basis functions). With every row kept this equals project(X, modes) up to rounding.
    /// \throws NumericalError if the kept rows cannot determine the coefficients.
    [[nodiscard]] Eigen::MatrixX3d project_least_squares(const Positions& X,
                                                         const std::vector<std::uint8_t>& is_kept,
                                                         int modes) const override;

    /// \brief Synthesis U_m c (#V x 3, zero on inactive rows) of the first c.rows() modes.
    /// \param orthogonality_error  If not null, receives a bound on the departure from
    ///        orthonormality of the modes used, the larger of two checks: max |U_m^T U_m - I|
    ///        with U_m^T U_m = T^T G T computed from the k x k Gram matrix G of pass 1
    ///        (T = V_m W_m^-1; exact algebra, since pass 2 evaluates the same B bit for bit),
    ///        and the round trip max |U_m^T f - c| / max |c| of the field f actually
    ///        synthesized, measured on the same pass (f^T B accumulated block by block, as
    ///        cheap as the synthesis itself). The round trip equals (U_m^T U_m - I) c, so it
    ///        catches any error of the pass that the k x k check cannot see.
    [[nodiscard]] Positions synthesize(const Eigen::MatrixX3d& c,
                                       double* orthogonality_error = nullptr) const override;

    /// \brief The first \p modes columns of U, explicitly (#active x modes). For tests and
    /// small meshes only: this is exactly what the streaming passes avoid.
    [[nodiscard]] Eigen::MatrixXd modes_dense(int modes) const override;

private:
    struct Chunk
    {
        std::size_t begin;
        std::size_t end;
    };
    // Pass 1 and the eigen-decomposition.
    void build(std::size_t gram_rows);
    // Active-row index of the i-th row of pass 1 (i itself unless sampled).
    [[nodiscard]] std::size_t gram_row(std::size_t i) const noexcept;
    // Runs fn(chunk, B, P, rows, count, begin, spare) on every block of the chunks
    // [first_chunk, last_chunk), in parallel over chunks: P holds the block's positions minus
    // the origin, rows their vertex indices, B their RBF values; begin is the active-row index
    // of the block's first row. Chunks: chunks_, or gram_chunks_ (rows at gram_row()) when sampled.
    template <class BlockFn>
    void for_each_block(const BlockFn& fn, std::size_t first_chunk = 0,
                        std::size_t last_chunk = SIZE_MAX, bool sampled = false) const;
    [[nodiscard]] double orthogonality(const Eigen::MatrixXd& T, const Eigen::MatrixX3d& c,
                                       const std::vector<std::vector<double>>& parts) const;
    [[nodiscard]] Eigen::MatrixXd mode_transform(int modes) const;  // V_m W_m^-1, k x m
    // k x k Gram matrix from the lower triangle of a stride_ x stride_ block-layout sum.
    [[nodiscard]] Eigen::MatrixXd unpack_gram(const std::vector<double>& total) const;
    // M^T (cols x stride_) in the block layout, zero on padding columns.
    [[nodiscard]] std::vector<double> columns_transposed(const Eigen::MatrixXd& M) const;
    // B^T X (k x width) from per-chunk accumulations (width x stride_ each), reduced in order.
    [[nodiscard]] Eigen::MatrixXd reduce_columns(const std::vector<std::vector<double>>& parts,
                                                 std::size_t width) const;

    std::shared_ptr<const RowPositionSource> rows_;
    std::size_t row_count_ = 0;                                                   // active rows
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> center_positions_;  // minus origin
    const detail::BlockKernels* kernels_;
    std::size_t padded_k_ = 0;         // k rounded up to a multiple of 4
    std::size_t stride_ = 0;           // row length of a B block: padded_k_ + 4 (pass 1: P and 1)
    std::vector<std::size_t> column_;  // column of center j in the blocks (spatial order)
    std::vector<double> centers_soa_;  // 3 x stride_: x, y, z of the centers, by column
    double sigma_;
    Eigen::Vector3d origin_;
    int threads_;
    std::vector<Chunk> chunks_;
    std::size_t gram_sample_rows_ = 0;  // rows of pass 1 (row_count_ unless sampled)
    std::vector<Chunk> gram_chunks_;    // chunks of pass 1 when sampled
    Eigen::MatrixXd gram_;
    Eigen::MatrixX3d bt_positions_;  // B^T (P - o)
    Eigen::VectorXd bt_ones_;        // B^T 1
    Eigen::VectorXd singular_values_;
    Eigen::MatrixXd eigenvectors_;
};

/// Rows per block of the streaming passes: a B block of 256 x 104 doubles stays in L2 cache.
inline constexpr std::size_t kBasisBlockRows = 256;

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <vector>

#include <Eigen/Core>

#include "meshmark/basis/rbf_basis.h"
#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/watermark/key.h"

namespace meshmark {

/// \brief The model's canonical frame: centroid and principal axes of the analysed vertices.
/// \details Embedding happens in this frame so that the watermark does not depend on where the
/// model sits, how it is oriented or how large it is (docs/algorithms/embedding.md, "Canonical frame").
/// Axes are the covariance eigenvectors, largest variance first; the first two point towards
/// the positive third moment (skewness) and the third is their cross product, so a rotated
/// model gets the rotated frame.
struct CanonicalFrame
{
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();      ///< Centroid of the analysed vertices.
    Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();    ///< Rows: principal axes (a rotation).
    double diagonal = 0.0;  ///< Diagonal of the bounding box in the principal axes ("D").
};

/// \brief Canonical frame of the listed rows.
/// \throws NumericalError if the vertices coincide or are collinear (no 2D extent).
[[nodiscard]] CanonicalFrame canonical_frame(const Positions& V, const std::vector<std::int32_t>& rows);

/// \brief canonical_frame() in three passes over the rows, for callers that stream positions
/// (out-of-core embedding). canonical_frame() runs on this builder, so the same positions fed
/// in the same order give the same frame, bit for bit.
/// \details Each pass feeds every row with add(), then next_pass(): centroid, covariance (axes),
/// then third moments (axis signs) together with the extent along the unsigned axes, which
/// the signs turn into the extent along the final axes exactly (negating an axis negates every
/// projection on it without rounding), for the diagonal D; then frame().
class CanonicalFrameBuilder
{
public:
    enum class Pass
    {
        Centroid,
        Covariance,
        Moments,  ///< third moments and extent
        Done,
    };
    [[nodiscard]] Pass pass() const noexcept { return pass_; }
    /// Feed one row's position to the current pass.
    void add(const Eigen::Vector3d& p);
    /// Feed the rows \p rows of \p V to the current pass: the same sums as add() on each row in
    /// order, with the pass chosen once instead of per row (3x faster on 1M rows).
    void add_rows(const Positions& V, std::span<const std::int32_t> rows);
    /// End the current pass. \throws NumericalError (no rows, collinear or coincident rows).
    void next_pass();
    /// The frame, once all three passes are done.
    [[nodiscard]] const CanonicalFrame& frame() const noexcept { return frame_; }

private:
    Pass pass_ = Pass::Centroid;
    std::size_t rows_ = 0;
    Eigen::Vector3d sum_ = Eigen::Vector3d::Zero();
    Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
    Eigen::Vector3d e1_ = Eigen::Vector3d::Zero();
    Eigen::Vector3d e2_ = Eigen::Vector3d::Zero();
    Eigen::Matrix3d unsigned_axes_ = Eigen::Matrix3d::Identity();  // rows e1, e2, e1 x e2 before the signs
    double moment1_ = 0.0;
    double moment2_ = 0.0;
    Eigen::Vector3d lo_ = Eigen::Vector3d::Zero();
    Eigen::Vector3d hi_ = Eigen::Vector3d::Zero();
    CanonicalFrame frame_;
};

/// What an extraction read from a suspect.
struct Extraction
{
    /// Signed coefficient change of each modulated coefficient divided by its modulation
    /// (3 m r values, coefficient c = 3 * mode + axis carries payload bit c mod 3m): +1 where
    /// the embedded sign b'_c was +1, -1 where it was -1, ~0 where nothing was embedded.
    std::vector<double> normalized_change;
    /// Weight of each coefficient in the correlation (3 m r values, >= 0): the inverse of its
    /// estimated noise variance where the extraction can estimate it, else 1. Never depends on
    /// the embedded signs, so the verdict's false-positive bound still holds.
    std::vector<double> weights;
    /// Per payload bit (3m values): the mean over its r coefficients of the change with the key
    /// mask undone, weighted by `weights`: +1 for an embedded 1 and -1 for a 0 (soft decision).
    std::vector<double> bit_values;
    std::vector<std::uint8_t> bits_found;  ///< Payload bits: 0, 1, or 2 for undecided.
};

/// How the verdict is reached (docs/statistics.md).
enum class VerdictRule
{
    /// Default: soft-decision correlation of all 3 m r coefficients with the embedded signs,
    /// z = sum_c b'_c x_c / |x|; ownership when the bound on P(an unmarked mesh scores z) is
    /// at most DetectOptions::max_false_positive.
    Correlation,
    /// [Wu & Kobbelt 2005]: R = fraction of payload bits read back, ownership when
    /// R >= DetectOptions::threshold; binomial false-positive probability.
    Bits,
};

/// Name used on the command line and in --json: "correlation" or "bits".
[[nodiscard]] const char* to_string(VerdictRule rule) noexcept;
/// \throws InvalidOption for any other name.
[[nodiscard]] VerdictRule parse_verdict_rule(const std::string& name);

/// Options of the decision (docs/algorithms/detection.md, docs/statistics.md).
struct DetectOptions
{
    VerdictRule verdict = VerdictRule::Correlation;
    /// Correlation rule: ownership is claimed when the false-positive bound is at most this.
    double max_false_positive = 1e-6;
    double threshold = 0.75;  ///< Bits rule: ownership is claimed when R >= threshold.
    double epsilon = 0.1;     ///< Undecided band of a payload bit, as a fraction of the modulation.
    /// Remove the attack's predictable part before deciding: the changes of a similarity
    /// motion and of Laplacian smoothing are fitted on the unmodulated modes (which carry no
    /// watermark) and subtracted from the modulated ones. See docs/algorithms/detection.md.
    bool remove_nuisance = true;
    /// \throws InvalidOption unless threshold is in (0, 1], epsilon in [0, 1) and
    /// max_false_positive in (0, 1].
    void validate() const;
};

/// The verdict on a suspect.
struct Decision
{
    bool is_present = false;
    VerdictRule verdict = VerdictRule::Correlation;
    double correlation = 0.0;  ///< R: fraction of payload bits read back correctly (N/A = wrong).
    int matches = 0;
    int bit_count = 0;
    /// z = sum_c a_c b'_c x_c / sqrt(sum_c a_c^2 x_c^2) over the 3 m r modulated coefficients,
    /// the largest over the weightings a = w^0, w^(1/2), w^1 (w: Extraction::weights): about
    /// sqrt(3 m r) for an intact mark; for an unmarked mesh, for each weighting, a sum of
    /// independent random signs (the key mask) with fixed weights, of mean 0 and variance 1.
    double score = 0.0;
    int coefficient_count = 0;  ///< 3 m r.
    /// Bound on P(an unmarked mesh scores at least z): 3 rademacher_tail_bound(z) (union bound
    /// over the three weightings), at most 1.
    double score_false_positive_probability = 1.0;
    /// P(X >= matches), X ~ Bin(3m, 1/2): each decided bit of an unrelated mesh matches the
    /// key-masked payload with probability 1/2 and an undecided one never does.
    double bits_false_positive_probability = 1.0;
    /// The false-positive probability of the rule in use (one of the two above).
    double false_positive_probability = 1.0;
    std::string bits_expected;  ///< '0'/'1'.
    std::string bits_found;     ///< '0'/'1'/'?'.
};

/// \brief Upper bound on P(sum_i s_i a_i >= z |a|) for independent uniform random signs s_i
/// and any real weights a_i: min(exp(-z^2/2), (2 e^3 / 9) (1 - Phi(z))) for z > 0, else 1
/// [Hoeffding 1963; Pinelis 1994, Ann. Statist. 22(1)]. Never optimistic whatever the a_i.
[[nodiscard]] double rademacher_tail_bound(double z);

/// \brief P(X >= k) for X ~ Binomial(n, 1/2), exact.
[[nodiscard]] double binomial_tail_half(int n, int k);

/// What an embedding did.
struct EmbedStats
{
    double max_displacement_rel = 0.0;  ///< Max vertex displacement / axis-aligned bbox diagonal.
    double rms_displacement_rel = 0.0;  ///< RMS over the analysed vertices, same unit.
    double orthogonality_error = 0.0;   ///< max |U_m^T U_m - I| over the modes used.
    double modulation_step = 0.0;       ///< Additive rule: s, in file units.
    int weak_bits = 0;  ///< Paper rule: bits on coefficients below 1/10 of the largest modulated one.
    int analysed_vertices = 0;
};

/// \brief Running maximum and sum of the squared row displacements (rows in order), as
/// SpectralWatermark::displacement() accumulates them for EmbedStats.
struct DisplacementSummary
{
    double max_squared = 0.0;
    double sum_squared = 0.0;
    std::size_t rows = 0;
    /// One row's displacement (x, y, z).
    void add(const double* d) noexcept;
};

/// \brief A watermark as defined by (original mesh, key): the basis and modulation, built
/// once and used for embedding, regeneration of the watermarked mesh, and extraction.
/// \details The key chooses the basis: RBF (centers drawn from the key's seed, or the survivors
/// of a decimation, among the referenced vertices; all vertices of a point cloud) or the
/// Laplacian eigenbasis (meshes with faces only). Either way unreferenced vertices take no part
/// and never move, and everything after the basis (modulation, extraction, verdict) is the same.
/// [Wu & Kobbelt 2005], with the corrections of docs/algorithms: canonical frame, additive rule by
/// default, key-masked payload, sign-correct decision.
class SpectralWatermark
{
public:
    /// \throws InvalidOption (bad key options), InvalidMesh (too few distinct vertices, or a
    /// point cloud with the Laplacian basis), NumericalError (degenerate geometry or Gram
    /// matrix, eigensolver failure).
    SpectralWatermark(const TriangleMesh& original, const Key& key, int threads = 0);

    /// \brief For embedding out of core: a watermark from its parts, computed by the caller
    /// exactly as the constructor above computes them (frame of the referenced rows, keyed
    /// centers, basis over \p analysed_rows rows). Only embedding queries are available:
    /// coefficient_change(), describe(), the accessors; displacement() and extraction throw.
    SpectralWatermark(const Key& key, CanonicalFrame frame, std::vector<std::int32_t> centers,
                      RbfBasis basis, std::size_t analysed_rows);

    /// Coefficient change beta - alpha in file axes (first_mode + m r rows, zero above): what
    /// displacement() synthesizes.
    [[nodiscard]] Eigen::MatrixX3d coefficient_change() const;

    /// \brief EmbedStats of a synthesized field from its summary, as displacement() fills them.
    /// \param aabb_diagonal  Axis-aligned bbox diagonal of the analysed rows.
    void describe(const DisplacementSummary& summary, double aabb_diagonal, double orthogonality_error,
                  EmbedStats* stats) const;

    [[nodiscard]] const Key& key() const noexcept { return key_; }
    [[nodiscard]] const CanonicalFrame& frame() const noexcept { return frame_; }
    [[nodiscard]] const SpectralBasis& basis() const noexcept { return *basis_; }
    /// RBF centers (k vertex indices); empty for the Laplacian basis.
    [[nodiscard]] const std::vector<std::int32_t>& centers() const noexcept { return centers_; }
    /// Signs b' in {-1, +1} actually embedded (m r x 3, canonical axes).
    [[nodiscard]] const Eigen::MatrixX3d& embedded_signs() const noexcept { return signs_; }
    /// Modulation of each coefficient (m r x 3, canonical axes): s, or alpha * rho (signed).
    [[nodiscard]] const Eigen::MatrixX3d& modulation() const noexcept { return modulation_; }

    /// \brief The watermark's displacement field in file coordinates (#V x 3; zero on
    /// unreferenced vertices). P_w = P + displacement. \param stats receives the distortion.
    [[nodiscard]] Positions displacement(EmbedStats* stats = nullptr) const;

    /// \brief Read the bits from \p suspect, given vertex for vertex in the original's frame.
    /// \param suspect  #V x 3, row i corresponds to vertex i of the original.
    /// \param is_kept  Optional: rows with 0 are cropped and left out (least squares over the
    ///                 others, docs/algorithms/basis.md).
    [[nodiscard]] Extraction extract(const Positions& suspect, const DetectOptions& options,
                                     const std::vector<std::uint8_t>* is_kept = nullptr) const;

    /// \brief Read the bits from a suspect resampled at the original's vertices.
    /// \details For a suspect registered and resampled (closest points of its surface to the
    /// original's vertices), only the normal component of the watermark survives, cropped rows
    /// carry nothing, and the similarity and smoothing nuisance is present. All of that is
    /// linear, so the expected response of every bit and every nuisance field is computed
    /// through the same operator (normal projection, crop mask) and the bits are decoded
    /// jointly by least squares on the leading modes. With no faces (a point cloud) no normal
    /// projection is applied.
    /// \param resampled #V x 3 closest points, original frame. \param is_kept optional crop mask.
    [[nodiscard]] Extraction extract_resampled(const Positions& resampled, const DetectOptions& options,
                                               const std::vector<std::uint8_t>* is_kept = nullptr) const;

    /// \brief Correlation, verdict and false-positive probability of an extraction.
    [[nodiscard]] Decision decide(const Extraction& extraction, const DetectOptions& options) const;

private:
    struct NuisanceModel
    {
        int modes = 0;                           ///< r: modulated + unmodulated modes used.
        std::vector<Eigen::MatrixX3d> responses;  ///< U_r^T N_q per nuisance field (r x 3).
    };
    [[nodiscard]] const NuisanceModel& nuisance_model() const;
    void init_modulation(double analysed);
    void require_original(const char* what) const;
    // The key's basis over the active rows (sets centers_ for the RBF basis).
    [[nodiscard]] std::unique_ptr<const SpectralBasis> make_basis(const TriangleMesh& original,
                                                                  std::vector<std::int32_t> active);
    [[nodiscard]] Extraction extraction_from(const Eigen::VectorXd& normalized, const Eigen::VectorXd& variances,
                                             const DetectOptions& options) const;

    const TriangleMesh* original_;
    Key key_;
    CanonicalFrame frame_;
    std::vector<std::int32_t> centers_;
    std::unique_ptr<const SpectralBasis> basis_;
    Eigen::MatrixX3d signs_;
    Eigen::MatrixX3d modulation_;
    std::vector<std::uint8_t> mask_;
    int weak_bits_ = 0;
    int threads_ = 0;
    mutable std::optional<NuisanceModel> nuisance_;  // built on first extraction
};

}  // namespace meshmark

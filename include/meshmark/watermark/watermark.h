// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "meshmark/basis/row_source.h"
#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/watermark/decision.h"
#include "meshmark/watermark/frame.h"
#include "meshmark/watermark/key.h"

namespace meshmark
{

/// What an embedding did.
struct EmbedStats
{
    double max_displacement_rel = 0.0;  ///< Max vertex displacement / axis-aligned bbox diagonal.
    double rms_displacement_rel = 0.0;  ///< RMS over the analysed vertices, same unit.
    /// First-order RMS distance of the marked surface from the original (surface_rms_displacement),
    /// same unit; 0 where it is not measured (the out-of-core embed, which has no faces in memory).
    double surface_rms_rel = 0.0;
    double orthogonality_error = 0.0;  ///< max |U_m^T U_m - I| over the modes used.
    double modulation_step = 0.0;      ///< Additive rule: s, in file units.
    int weak_bits =
        0;  ///< Paper rule: bits on coefficients below 1/10 of the largest modulated one.
    int analysed_vertices = 0;
    /// Modes the basis spans numerically (SpectralBasis::kDegenerateModeTolerance): k, unless
    /// the vertices lie on a few curves or in a small patch.
    int basis_span = 0;
    /// The automatic repetitions were lowered to fit the mark into basis_span modes.
    bool shortened_to_span = false;
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

/// \brief Refuse a key whose basis has more functions than the original has analysed rows.
/// \throws InvalidMesh naming both counts (and \p source, the file, when given).
void check_analysed_rows(const EmbedOptions& options, std::size_t analysed_rows,
                         const std::string& source = {});

/// \brief The repetitions r a key with EmbedOptions::kAutoRepetitions gets on an original with
/// \p analysed_rows analysed vertices (docs/statistics.md, "How long a mark"): 5 (120
/// coefficients, an intact score of 10.95) from 5,000 analysed vertices on if the mark fits the
/// basis, otherwise 4 (96 coefficients, 9.8), or the largest r the basis fits. The watermark
/// lowers it further when the original's vertices span fewer modes than the mark needs
/// (EmbedStats::shortened_to_span).
[[nodiscard]] int automatic_repetitions(const EmbedOptions& options, std::size_t analysed_rows);

/// \brief A watermark as defined by (original mesh, key): the frame, basis and modulation,
/// built once and used to embed (the displacement field) and to decide. Reading a suspect
/// needs the original mesh as well: see Detector (detector.h).
/// \details The key chooses the basis: RBF (centers drawn from the key's seed, or the survivors
/// of a decimation, among the referenced vertices; all vertices of a point cloud) or the
/// Laplacian eigenbasis (meshes with faces only). Either way unreferenced vertices take no part
/// and never move, and everything after the basis (modulation, extraction, verdict) is the same.
/// Both constructors run the same steps (key checks, keyed centers, basis over the analysed
/// rows, modulation) on positions read through a RowPositionSource; the first one derives the
/// rows and their frame from a mesh in memory, the second one is given them (out-of-core
/// embedding streams a file). Every query works whichever constructor built the object; all
/// are const and safe to call from several threads at once.
/// [Wu & Kobbelt 2005], with the corrections of docs/algorithms: canonical frame, additive rule by
/// default, key-masked payload, sign-correct decision.
class SpectralWatermark
{
public:
    /// \brief The watermark of \p key on the referenced vertices of \p original (which must
    /// outlive the watermark), in their canonical frame.
    /// \throws InvalidOption (bad key options), InvalidMesh (too few distinct vertices, or a
    /// point cloud with the Laplacian basis), NumericalError (degenerate geometry or Gram
    /// matrix, a mark longer than the modes the vertices span, eigensolver failure).
    SpectralWatermark(const TriangleMesh& original, const Key& key, int threads = 0);

    /// \brief The watermark of \p key on the analysed rows \p rows, whose canonical frame is
    /// \p frame (canonical_frame() of the same rows, or a CanonicalFrameBuilder fed them in
    /// order): bit for bit the watermark the constructor above builds from the mesh. Without the
    /// mesh only the RBF basis with random centers can be built.
    /// \throws as above; InvalidOption for the Laplacian basis or decimated centers.
    SpectralWatermark(const Key& key, std::shared_ptr<const RowPositionSource> rows,
                      const CanonicalFrame& frame, int threads = 0);

    /// Coefficient change beta - alpha in file axes (first_mode + m r rows, zero above): what
    /// displacement() synthesizes. For a family key this is the owner's mark, shared by every copy.
    [[nodiscard]] Eigen::MatrixX3d coefficient_change() const;

    /// M, the modes of the recipient code after the owner's m r (0 unless a family key).
    [[nodiscard]] int recipient_modes() const noexcept;
    /// Signs (-1/+1, M x 3, canonical axes) of recipient \p index's code (recipient_code).
    [[nodiscard]] Eigen::MatrixX3d recipient_signs(std::uint32_t index) const;
    /// \brief Coefficient change of recipient \p index's code in file axes (M x 3): rows
    /// first_mode + m r .. of the basis; a copy is displaced by the owner's field plus this one's.
    /// \throws InvalidOption unless the key is a family key.
    [[nodiscard]] Eigen::MatrixX3d recipient_change(std::uint32_t index) const;

    /// \brief EmbedStats of a synthesized field from its summary, as displacement() fills them.
    /// \param aabb_diagonal  Axis-aligned bbox diagonal of the analysed rows.
    void describe(const DisplacementSummary& summary, double aabb_diagonal,
                  double orthogonality_error, EmbedStats* stats) const;

    [[nodiscard]] const Key& key() const noexcept { return key_; }
    [[nodiscard]] const CanonicalFrame& frame() const noexcept { return frame_; }
    [[nodiscard]] const SpectralBasis& basis() const noexcept { return *basis_; }
    /// The analysed rows and their positions.
    [[nodiscard]] const RowPositionSource& rows() const noexcept { return *rows_; }
    /// The same rows when the watermark was built from a mesh in memory (its positions and
    /// referenced vertices); null when it was built from streamed rows.
    [[nodiscard]] const PositionRows* mesh_rows() const noexcept { return mesh_rows_.get(); }
    /// RBF centers (k vertex indices); empty for the Laplacian basis.
    [[nodiscard]] const std::vector<std::int32_t>& centers() const noexcept { return centers_; }
    /// Signs b' in {-1, +1} actually embedded (m r x 3, canonical axes).
    [[nodiscard]] const Eigen::MatrixX3d& embedded_signs() const noexcept { return signs_; }
    /// Modulation of each coefficient (m r + M rows x 3, canonical axes): s, or alpha * rho
    /// (signed); the last M rows (family keys) are the recipient code's step.
    [[nodiscard]] const Eigen::MatrixX3d& modulation() const noexcept { return modulation_; }
    /// Key mask of each modulated coefficient (3 m r values, coefficient c = 3 * mode + axis).
    [[nodiscard]] const std::vector<std::uint8_t>& mask() const noexcept { return mask_; }

    /// \brief The watermark's displacement field in file coordinates (#V x 3; zero on
    /// unreferenced vertices). P_w = P + displacement. \param stats receives the distortion.
    [[nodiscard]] Positions displacement(EmbedStats* stats = nullptr) const;

    /// \brief The surface measure's calibration (EmbedOptions::needs_calibration): scales
    /// \p field, which displacement() just synthesized with the key's nominal modulation, so that
    /// its first-order RMS surface distance (surface_rms_displacement) is the strength times the
    /// bbox diagonal of the analysed rows, and scales the modulation (the owner's and a family's
    /// codes alike) and records the vertex strength that gives it in key() (vertex_strength),
    /// from which detection and later copies rebuild it (docs/algorithms/embedding.md,
    /// "Strength"). A family key's owner mark carries its share of the energy only.
    /// \param original  The mesh this watermark was built from (its faces are read here).
    /// \param stats     If not null, scaled with the field; surface_rms_rel is filled in either
    /// way. \return The factor: 1 when the key needs no calibration (it then only measures).
    /// \throws InvalidOption when the watermark was built from streamed rows, or when the
    /// calibrated vertex strength would exceed 0.5 of the diagonal.
    double calibrate_strength(const TriangleMesh& original, Positions& field,
                              EmbedStats* stats = nullptr);

    /// \brief Lower (or raise) the mark's strength by \p factor after the embedding chose it: the
    /// key's strength (and calibrated vertex strength) and the modulation (the owner's and a
    /// family's codes alike) are multiplied by it, so the displacement, which is linear in the
    /// modulation, is the one displacement() synthesized times \p factor, and detection rebuilds
    /// it from key(). How embed caps the largest displacement (EmbedMeshOptions::max_displacement).
    /// \throws InvalidOption unless \p factor is finite and positive.
    void scale_strength(double factor);

    /// \brief Correlation, verdict and false-positive probability of an extraction
    /// (docs/statistics.md). For a family key: of the owner's mark.
    [[nodiscard]] Decision decide(const Extraction& extraction, const DetectOptions& options) const;

    /// \brief Every recipient of a family key scored on the extraction's recipient
    /// coefficients, in the key's order (docs/fingerprinting.md); empty for other keys.
    [[nodiscard]] std::vector<RecipientScore> trace(const Extraction& extraction,
                                                    const DetectOptions& options) const;

private:
    // Checks the key; a family key's automatic repetitions become kFamilyRepetitions here.
    void check_key();
    // The steps common to both constructors, after the frame: centers, basis, modulation.
    // \p mesh and its referenced rows \p active are null when built from streamed rows.
    void build(const TriangleMesh* mesh, const std::vector<std::int32_t>* active);
    // The repetitions resolved against the modes the basis spans: an automatic choice that
    // does not fit is lowered (with a margin), and a mark that cannot fit is refused.
    void fit_to_span();
    void init_modulation(double analysed);

    Key key_;
    CanonicalFrame frame_;
    std::shared_ptr<const RowPositionSource> rows_;
    std::shared_ptr<const PositionRows> mesh_rows_;  // rows_ when built from a mesh, else null
    std::vector<std::int32_t> centers_;
    std::unique_ptr<const SpectralBasis> basis_;
    Eigen::MatrixX3d signs_;
    Eigen::MatrixX3d modulation_;
    std::vector<std::uint8_t> mask_;
    int basis_span_ = 0;
    bool shortened_to_span_ = false;
    int weak_bits_ = 0;
    int threads_ = 0;
};

}  // namespace meshmark

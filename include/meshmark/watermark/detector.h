// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/watermark/decision.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// Weight of a resampled row at distance \p distance from the original's vertex, for a weight
/// scale \p scale > 0 (Detector::extract_resampled): 1 / (1 + (distance / scale)^2).
[[nodiscard]] inline double row_weight(double distance, double scale) noexcept
{
    const double x = distance / scale;
    return 1.0 / (1.0 + x * x);
}

/// \brief Reads a watermark back from suspects: the watermark and the ORIGINAL mesh it was
/// embedded in (not the watermarked one). Everything geometric of an extraction (the change
/// from the original, its normals, the nuisance fields, the rows a crop keeps) is taken from
/// the original, never from anything the key's signs shaped, so the verdict's false-positive
/// bound holds (docs/statistics.md).
/// \details Construction only checks that the original fits the watermark. Each extraction is
/// a pure function of its arguments (the nuisance model is built by the call that needs it and
/// is not cached), so one Detector may be used from several threads at once.
class Detector
{
public:
    /// \param mark      The watermark (built from \p original and the key); must outlive this.
    /// \param original  The original mesh; must outlive this.
    /// \throws InvalidOption unless \p original has the vertex count and analysed rows of the
    /// mesh the watermark was built on.
    Detector(const SpectralWatermark& mark, const TriangleMesh& original);

    /// \brief Read the bits from \p suspect, given vertex for vertex in the original's frame.
    /// \param suspect  #V x 3, row i corresponds to vertex i of the original.
    /// \param is_kept  Optional: rows with 0 are cropped and left out (least squares over the
    ///                 others, docs/algorithms/basis.md).
    /// \details With every row kept and DetectOptions::remove_nuisance, the similarity and
    /// smoothing nuisance is fitted jointly with the coefficients on the leading modes
    /// (docs/algorithms/detection.md), when the basis has enough unmodulated modes for it.
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
    /// \param weight_scale  0, or s > 0 to weight the rows by their distance: row i, at
    ///        d_i = |resampled_i - original_i|, gets w_i = row_weight(d_i, s) = 1 / (1 + (d_i /
    ///        s)^2), and its design and observation are scaled by w_i before the projection on
    ///        the modes, so rows an attack moved far from the mark count less. The weights
    ///        depend on the suspect and the original only, never on a key's signs, so the bound
    ///        holds.
    /// \throws InvalidOption if \p weight_scale is negative or not finite.
    [[nodiscard]] Extraction extract_resampled(const Positions& resampled,
                                               const DetectOptions& options,
                                               const std::vector<std::uint8_t>* is_kept = nullptr,
                                               double weight_scale = 0.0) const;

    /// \brief Read a suspect that keeps the original's vertices in order, except for rows
    /// \p is_kept leaves out (a tool threw them far away: MeshLab's Taubin smoothing moves a
    /// few vertices of some meshes by 10% of the diagonal).
    /// \details The whole change of every kept row is read (no normal projection), jointly with
    /// the nuisance (similarity, smoothing) and with a family key's code, by the least squares
    /// of extract_resampled(); the rows left out carry nothing.
    [[nodiscard]] Extraction extract_kept(const Positions& suspect, const DetectOptions& options,
                                          const std::vector<std::uint8_t>& is_kept) const;

    /// \brief extract_resampled() reading a family key's code modes jointly with the owner's
    /// even on a cropped suspect (where extract_resampled reads the owner's alone): the code's
    /// coefficients of a slightly cropped suspect (remeshing, simplification) for tracing.
    [[nodiscard]] Extraction extract_resampled_with_code(const Positions& resampled,
                                                         const DetectOptions& options,
                                                         const std::vector<std::uint8_t>* is_kept,
                                                         double weight_scale = 0.0) const;

    /// Number of regions region_changes() reads: first every row (kept by the crop mask), then
    /// the halves, thirds and quarters of the original along each of its three principal axes.
    static constexpr int kRegionCount = 28;

    /// \brief For a family key: the recipient code's coefficients of the suspect's change,
    /// confined region by region (kRegionCount regions of the original), for suspects spliced
    /// from several copies (docs/fingerprinting.md).
    /// \details The change (minus the owner's field; for a resampled suspect its normal
    /// components) is zeroed outside the region and projected on the code's modes; each region's
    /// 3M values are divided by the code's modulation. Everything here comes from the original
    /// and the suspect, nothing from a recipient's signs, so each region's correlation with an
    /// innocent recipient's code is bounded as the whole one's. One pass over the rows.
    /// \param suspect  #V x 3 in the original's frame: vertex for vertex, or resampled.
    /// \param is_resampled  The suspect was resampled (only normal components are compared).
    /// \param is_kept  Optional crop mask: rows with 0 are left out.
    /// \param weight_scale  0, or the scale of the rows' weights as for extract_resampled().
    /// \param code_sampling  Empty, or the Extraction::code_sampling of a reading of the same
    ///        resampled suspect with the same rows and weights: each region's projection y is
    ///        then replaced by (K + lambda I)^-1 y, lambda = 0.3 trace(K) / 3M, which undoes
    ///        part of what reading the normal components alone does to the code. K is the
    ///        whole model's, not the region's, so on a slab it is an approximation; it depends
    ///        on no recipient's signs, so the bound holds.
    /// \throws InvalidOption unless the watermark has a recipient code, or if \p code_sampling
    ///        is neither empty nor 3M x 3M.
    [[nodiscard]] std::vector<std::vector<double>> region_changes(
        const Positions& suspect, bool is_resampled,
        const std::vector<std::uint8_t>* is_kept = nullptr, double weight_scale = 0.0,
        const std::vector<double>& code_sampling = {}) const;

    /// The watermark's decision on an extraction (SpectralWatermark::decide).
    [[nodiscard]] Decision decide(const Extraction& extraction, const DetectOptions& options) const
    {
        return mark_->decide(extraction, options);
    }

    /// \brief A further nuisance field (#V x 3, original frame) that the resampled readings
    /// (extract_resampled and the like) fit beside the similarity and smoothing ones: what an
    /// attack is predicted to do to the original without any mark (a voxel remesh of it), so that
    /// only what differs from that is read. Null: none. It must come from the original and the
    /// suspect only, never from a key, for the bound to hold; it must outlive the extractions,
    /// and is set between them, not during them.
    void set_predicted_change(const Positions* field) noexcept { predicted_ = field; }

    [[nodiscard]] const SpectralWatermark& watermark() const noexcept { return *mark_; }
    [[nodiscard]] const TriangleMesh& original() const noexcept { return *original_; }

private:
    // Modes read by an extraction: every modulated one, or a family key's owner modes alone on
    // a cropped suspect (\p is_kept not null).
    [[nodiscard]] int read_modes(const std::vector<std::uint8_t>* is_kept) const noexcept;
    [[nodiscard]] Extraction read_resampled(const Positions& resampled,
                                            const DetectOptions& options,
                                            const std::vector<std::uint8_t>* is_kept,
                                            double weight_scale, int modes,
                                            bool is_whole_change = false) const;
    // Extraction of coefficients normalized by their modulation, with their variances and
    // (where the joint least squares computes them) their damped readings.
    [[nodiscard]] Extraction extraction_from(const Eigen::VectorXd& normalized,
                                             const Eigen::VectorXd& variances,
                                             const DetectOptions& options,
                                             const std::vector<Eigen::VectorXd>& damped = {}) const;

    const SpectralWatermark* mark_;
    const TriangleMesh* original_;
    // The original's referenced vertices (the watermark's rows): the watermark's own list when
    // it was built from this very mesh (borrowed_), else a scan of our own (own_active_).
    [[nodiscard]] const std::vector<std::int32_t>& active() const noexcept
    {
        return borrowed_active_ != nullptr ? *borrowed_active_ : own_active_;
    }
    const std::vector<std::int32_t>* borrowed_active_ = nullptr;
    std::vector<std::int32_t> own_active_;
    const Positions* predicted_ = nullptr;
};

}  // namespace meshmark

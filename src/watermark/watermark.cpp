// SPDX-License-Identifier: MIT
// SpectralWatermark: the steps from the analysed rows to the modulated coefficients (keyed
// centers, basis, key-masked signs, modulation), and the displacement field they give.
#include "meshmark/watermark/watermark.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "meshmark/basis/decimated_centers.h"
#include "meshmark/basis/laplacian_basis.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/metrics/distortion.h"

namespace meshmark
{
namespace
{

// A modulated coefficient below this fraction of the largest one carries a weak bit under the
// paper's multiplicative rule (docs/algorithms/embedding.md, "Modulation": those fail first under
// noise).
constexpr double kWeakCoefficientFraction = 0.1;

// Rows read per block when a pass over the analysed rows runs here (the bounding box): 4096 x 3
// doubles (96 KB) per read; chosen by hand; no study on record.
constexpr std::size_t kReadBlockRows = 4096;

// The automatic repetitions (docs/statistics.md, "How long a mark"): the longer mark from this
// many analysed vertices on. Below it the longer mark's top modes (44-51) are what a coarse
// resampling takes first: on the shared meshes of 1.1K-4.5K vertices it lost remeshed and
// simplified copies (6 lost, 2 gained of 480). From 5.2K vertices on every attack of the
// suite scores as high or higher with it, and it claims the same copies but two of 200
// simplified to 2% (bench/results/2026-11-26-120-coefficients-from-5k.md). From 30K until
// 2026-11-26.
constexpr std::size_t kLongMarkMinRows = 5000;
constexpr int kLongMarkRepetitions = 5;
constexpr int kDefaultRepetitions = 4;

// An automatic mark shortened to the modes the basis spans keeps its last mode at a relative
// eigenvalue 4 times above the degenerate one (SpectralBasis::kDegenerateModeTolerance), so
// that the basis detection rebuilds on another machine (other SIMD kernels, other rounding of
// the Gram matrix: about 1e-16 of the largest eigenvalue, 1% of a mode at 1e-14) still
// accepts every mode of it.
constexpr double kShortenedMarkTolerance = 4.0 * SpectralBasis::kDegenerateModeTolerance;
// ... and keeps at least this many repetitions: a mark of one (24 coefficients, an intact score
// of 4.90) is claimed only by its bit count read in one pose (2^-24 times the combined verdict's
// 16: 9.5e-7), so only on copies that keep the vertex order; a copy read in more poses (a
// reordered printer bed: 24 of 24 bits at 3.05e-6) is not.
constexpr int kMinShortenedRepetitions = 2;

}  // namespace

int automatic_repetitions(const EmbedOptions& options, std::size_t analysed_rows)
{
    auto fits = [&](int r)
    {
        return static_cast<long long>(options.first_mode) +
                   static_cast<long long>(r) * options.coefficients <=
               options.basis_size;
    };
    if (analysed_rows >= kLongMarkMinRows && fits(kLongMarkRepetitions))
    {
        return kLongMarkRepetitions;
    }
    for (int r = kDefaultRepetitions; r > 1; --r)
    {
        if (fits(r))
        {
            return r;
        }
    }
    return 1;
}

void DisplacementSummary::add(const double* d) noexcept
{
    const double sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    max_squared = std::max(max_squared, sq);
    sum_squared += sq;
    ++rows;
}

void check_analysed_rows(const EmbedOptions& options, std::size_t analysed_rows,
                         const std::string& source)
{
    if (analysed_rows < static_cast<std::size_t>(std::max(0, options.basis_size)))
    {
        const std::string prefix = source.empty() ? std::string("the mesh") : source + ": the mesh";
        if (analysed_rows == 0)
        {
            throw InvalidMesh(prefix + " has nothing to watermark: no triangles and no points.");
        }
        throw InvalidMesh(
            prefix + " has " + std::to_string(analysed_rows) +
            (analysed_rows == 1 ? " usable vertex" : " usable vertices") + ", fewer than the " +
            std::to_string(options.basis_size) +
            " basis functions a mark needs (a smaller --basis-size, with --first-mode and "
            "--coefficients to match, marks it weakly).");
    }
}

SpectralWatermark::SpectralWatermark(const TriangleMesh& original, const Key& key, int threads)
    : key_(key), threads_(threads)
{
    check_key();
    std::vector<std::int32_t> active = referenced_vertices(original);
    check_analysed_rows(key_.options, active.size());
    frame_ = canonical_frame(original.V, active);
    mesh_rows_ = position_rows(original.V, std::move(active));
    rows_ = mesh_rows_;
    build(&original, &mesh_rows_->active());
}

SpectralWatermark::SpectralWatermark(const Key& key, std::shared_ptr<const RowPositionSource> rows,
                                     const CanonicalFrame& frame, int threads)
    : key_(key), frame_(frame), rows_(std::move(rows)), threads_(threads)
{
    check_key();
    check_analysed_rows(key_.options, rows_->size());
    build(nullptr, nullptr);
}

void SpectralWatermark::check_key()
{
    if (key_.recipients && key_.options.repetitions == EmbedOptions::kAutoRepetitions)
    {
        key_.options.repetitions = kFamilyRepetitions;  // the code's modes follow the owner's
    }
    key_.options.validate();
    const int bit_count = payload_bit_count(key_.options);
    if (static_cast<int>(key_.payload.size()) != bit_count)
    {
        throw InvalidOption("the payload has " + std::to_string(key_.payload.size()) +
                            " bits, but the key's parameters need " + std::to_string(bit_count) +
                            ".");
    }
    if (key_.recipients)
    {
        key_.recipients->validate(key_.options);
        if (key_.options.rule != EmbeddingRule::Additive)
        {
            throw InvalidOption("a family key (recipients) needs the additive embedding rule.");
        }
    }
}

void SpectralWatermark::build(const TriangleMesh* mesh, const std::vector<std::int32_t>* active)
{
    const bool needs_mesh = key_.options.basis == BasisType::Laplacian ||
                            key_.options.centers == CenterSelection::Decimate;
    if (needs_mesh && mesh == nullptr)
    {
        throw InvalidOption(
            "the Laplacian basis and decimated centers need the mesh in memory; a watermark "
            "built from streamed rows supports the RBF basis with random centers only.");
    }
    // Keyed centers -> basis over the analysed rows.
    if (key_.options.basis == BasisType::Laplacian)
    {
        LaplacianBasisOptions options;
        options.modes = key_.options.basis_size;
        basis_ = std::make_unique<LaplacianBasis>(*mesh, *active, frame_.origin, options);
    }
    else
    {
        centers_ = key_.options.centers == CenterSelection::Decimate
                       ? decimated_centers(*mesh, *active, key_.options.basis_size)
                       : random_centers(*rows_, key_.options.basis_size,
                                        derive_seed(key_.seed, "centers"));
        const double sigma = key_.options.sigma_factor * frame_.diagonal / 2.0;
        basis_ = std::make_unique<RbfBasis>(rows_, centers_, sigma, frame_.origin, threads_,
                                            static_cast<std::size_t>(key_.options.gram_rows));
    }
    fit_to_span();
    init_modulation(static_cast<double>(rows_->size()));
}

void SpectralWatermark::fit_to_span()
{
    EmbedOptions& options = key_.options;
    // A new family key on an original whose vertices span fewer modes than the owner's mark and
    // the code need: a shorter code, if kMinRecipientModes fit (the owner's mark keeps its r).
    if (key_.recipients && key_.recipients->shorten_to_span)
    {
        key_.recipients->shorten_to_span = false;
        const int repetitions = options.repetitions == EmbedOptions::kAutoRepetitions
                                    ? automatic_repetitions(options, rows_->size())
                                    : options.repetitions;
        const int room = basis_->well_conditioned_modes(kShortenedMarkTolerance) -
                         options.first_mode - options.coefficients * repetitions;
        if (room < key_.recipients->modes && room >= kMinRecipientModes)
        {
            key_.recipients->modes = room;
            shortened_to_span_ = true;
        }
    }
    const int recipient_modes = key_.recipients ? key_.recipients->modes : 0;
    const auto needed = [&](int r)
    { return options.first_mode + options.coefficients * r + recipient_modes; };
    basis_span_ = basis_->well_conditioned_modes(SpectralBasis::kDegenerateModeTolerance);
    // The most repetitions whose last mode stands clear of the degenerate ones (the margin).
    const int fits = (basis_->well_conditioned_modes(kShortenedMarkTolerance) - options.first_mode -
                      recipient_modes) /
                     options.coefficients;
    const bool automatic = options.repetitions == EmbedOptions::kAutoRepetitions;
    if (automatic)
    {
        options.repetitions = automatic_repetitions(options, rows_->size());
        // Vertices on a few curves (a flat part whose faces have no inner vertices) span fewer
        // modes than k: a shorter mark, if one fits.
        if (needed(options.repetitions) > basis_span_ && fits >= kMinShortenedRepetitions)
        {
            options.repetitions = std::min(fits, options.repetitions);
            shortened_to_span_ = true;
        }
    }
    const int modes = needed(options.repetitions);
    if (modes > basis_span_)
    {
        std::string advice;
        if (fits < 1)
        {
            advice = "not even one repetition of the payload fits";
        }
        else if (fits == 1)
        {
            advice = "--repetitions 1 fits, but a mark of " +
                     std::to_string(3 * options.coefficients) +
                     " coefficients is claimed only on copies that keep the vertex order";
        }
        else
        {
            advice = "--repetitions " + std::to_string(fits) + " fits";
        }
        throw NumericalError("the mesh's vertices span only " + std::to_string(basis_span_) +
                             " independent modes of the RBF basis, and the mark needs " +
                             std::to_string(modes) + " (modulated modes " +
                             std::to_string(options.first_mode) + "-" + std::to_string(modes - 1) +
                             "): they lie on a few curves or in a small patch "
                             "(a flat part whose faces have no inner vertices, say), and " +
                             advice + ".");
    }
}

void SpectralWatermark::init_modulation(double analysed)
{
    const int bit_count = payload_bit_count(key_.options);
    // Payload -> key-masked signs b': coefficient c = 3 * mode + axis carries payload bit
    // c mod 3m, with its own mask bit, so the r copies of a bit get independent signs.
    const int modes = modulated_modes(key_.options);
    const int coefficient_count = 3 * modes;
    // A family key: the recipient code's M modes follow the owner's, and the two share the
    // energy (docs/fingerprinting.md). Otherwise the owner has all of it.
    const int recipient_modes = key_.recipients ? key_.recipients->modes : 0;
    const double owner_share = key_.recipients ? 1.0 - key_.recipients->energy_share : 1.0;
    mask_ = payload_mask(key_.seed, coefficient_count);
    signs_.resize(modes, 3);
    for (int c = 0; c < coefficient_count; ++c)
    {
        const unsigned embedded =
            static_cast<unsigned>(key_.payload[static_cast<std::size_t>(c % bit_count)]) ^
            static_cast<unsigned>(mask_[static_cast<std::size_t>(c)]);
        signs_(c / 3, c % 3) = embedded != 0 ? 1.0 : -1.0;
    }

    // Modulation per coefficient, in the canonical frame.
    const double strength = key_.options.modulation_strength();
    if (key_.options.rule == EmbeddingRule::Additive)
    {
        // |U b' s|_F^2 = 3 m r s^2 for orthonormal modes, so this s gives an RMS displacement of
        // strength * D over the analysed vertices.
        const double step = strength * std::sqrt(owner_share) * frame_.diagonal *
                            std::sqrt(analysed / static_cast<double>(coefficient_count));
        modulation_.resize(modes + recipient_modes, 3);
        modulation_.topRows(modes).setConstant(step);
        if (recipient_modes > 0)
        {
            // The code's 3M coefficients carry the rest of the energy: an RMS displacement of
            // strength * sqrt(share) * D.
            modulation_.bottomRows(recipient_modes)
                .setConstant(strength * std::sqrt(key_.recipients->energy_share) * frame_.diagonal *
                             std::sqrt(analysed / (3.0 * recipient_modes)));
        }
    }
    else
    {
        const Eigen::MatrixX3d alpha_file =
            basis_->position_coefficients().middleRows(key_.options.first_mode, modes);
        const Eigen::MatrixX3d alpha = alpha_file * frame_.axes.transpose();
        modulation_ = alpha * strength;
        const double largest = alpha.cwiseAbs().maxCoeff();
        weak_bits_ =
            static_cast<int>((alpha.array().abs() < kWeakCoefficientFraction * largest).count());
    }
}

Eigen::MatrixX3d SpectralWatermark::coefficient_change() const
{
    // Coefficient change (canonical frame) -> file axes.
    const int first = key_.options.first_mode;
    Eigen::MatrixX3d change = Eigen::MatrixX3d::Zero(first + signs_.rows(), 3);
    change.bottomRows(signs_.rows()) =
        signs_.cwiseProduct(modulation_.topRows(signs_.rows())) * frame_.axes;
    return change;
}

int SpectralWatermark::recipient_modes() const noexcept
{
    return static_cast<int>(modulation_.rows() - signs_.rows());
}

Eigen::MatrixX3d SpectralWatermark::recipient_signs(std::uint32_t index) const
{
    const int modes = recipient_modes();
    const std::vector<std::uint8_t> code = recipient_code(key_.seed, index, 3 * modes);
    Eigen::MatrixX3d signs(modes, 3);
    for (int c = 0; c < 3 * modes; ++c)
    {
        signs(c / 3, c % 3) = code[static_cast<std::size_t>(c)] != 0 ? 1.0 : -1.0;
    }
    return signs;
}

Eigen::MatrixX3d SpectralWatermark::recipient_change(std::uint32_t index) const
{
    const int modes = recipient_modes();
    if (modes == 0)
    {
        throw InvalidOption("the key has no recipients: it is not a family key.");
    }
    return recipient_signs(index).cwiseProduct(modulation_.bottomRows(modes)) * frame_.axes;
}

void SpectralWatermark::describe(const DisplacementSummary& summary, double aabb_diagonal,
                                 double orthogonality_error, EmbedStats* stats) const
{
    stats->max_displacement_rel = std::sqrt(summary.max_squared) / aabb_diagonal;
    stats->rms_displacement_rel =
        std::sqrt(summary.sum_squared / static_cast<double>(summary.rows)) / aabb_diagonal;
    stats->orthogonality_error = orthogonality_error;
    stats->modulation_step = key_.options.rule == EmbeddingRule::Additive ? modulation_(0, 0) : 0.0;
    stats->weak_bits = weak_bits_;
    stats->analysed_vertices = static_cast<int>(summary.rows);
    stats->basis_span = basis_span_;
    stats->shortened_to_span = shortened_to_span_;
}

Positions SpectralWatermark::displacement(EmbedStats* stats) const
{
    // Synthesis U_m (beta - alpha) of the coefficient change.
    double orthogonality = 0.0;
    Positions field = basis_->synthesize(coefficient_change(), &orthogonality);
    if (stats != nullptr)
    {
        // One pass over the analysed rows in order: their bounding box and the field's summary.
        Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
        Eigen::Vector3d hi = -lo;
        DisplacementSummary summary;
        const std::unique_ptr<RowPositionCursor> cursor = rows_->cursor(0);
        std::vector<double> xyz(3 * kReadBlockRows);
        std::vector<std::int32_t> vertices(kReadBlockRows);
        for (std::size_t begin = 0; begin < rows_->size(); begin += kReadBlockRows)
        {
            const std::size_t count = std::min(kReadBlockRows, rows_->size() - begin);
            cursor->read(count, xyz.data(), vertices.data());
            for (std::size_t i = 0; i < count; ++i)
            {
                const Eigen::Vector3d p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
                lo = lo.cwiseMin(p);
                hi = hi.cwiseMax(p);
                summary.add(field.data() + 3 * static_cast<std::size_t>(vertices[i]));
            }
        }
        describe(summary, (hi - lo).norm(), orthogonality, stats);
    }
    return field;
}

double SpectralWatermark::calibrate_strength(const TriangleMesh& original, Positions& field,
                                             EmbedStats* stats)
{
    if (mesh_rows_ == nullptr)
    {
        throw InvalidOption("the surface strength measure needs the mesh in memory (its faces).");
    }
    const double diagonal = bounding_box(original.V, mesh_rows_->active()).diagonal();
    double surface = surface_rms_displacement(original, field, threads_);
    double factor = 1.0;
    if (key_.options.needs_calibration())
    {
        // The field is linear in the modulation: one synthesis and one scaling suffice. A field
        // with no normal part at all (no area) keeps the nominal modulation.
        const double share = key_.recipients ? 1.0 - key_.recipients->energy_share : 1.0;
        const double target = key_.options.resolved_strength() * std::sqrt(share) * diagonal;
        factor = surface > 0.0 ? target / surface : 1.0;
        const double vertex_strength = key_.options.modulation_strength() * factor;
        if (!(vertex_strength <= 0.5))
        {
            throw InvalidOption(
                "the surface strength " + std::to_string(key_.options.resolved_strength()) +
                " would need an RMS vertex displacement of " + std::to_string(vertex_strength) +
                " of the diagonal on this mesh; use --strength-measure vertex.");
        }
        key_.options.vertex_strength = vertex_strength;
        // Rebuilt from the recorded strength, exactly as a watermark built from the key is.
        init_modulation(static_cast<double>(rows_->size()));
        field *= factor;
        surface *= factor;
        if (stats != nullptr)
        {
            stats->rms_displacement_rel *= factor;
            stats->max_displacement_rel *= factor;
            stats->modulation_step *= factor;
        }
    }
    if (stats != nullptr)
    {
        stats->surface_rms_rel = diagonal > 0.0 ? surface / diagonal : 0.0;
    }
    return factor;
}

void SpectralWatermark::scale_strength(double factor)
{
    if (!(std::isfinite(factor) && factor > 0.0))
    {
        throw InvalidOption("the strength can only be scaled by a positive factor, got " +
                            std::to_string(factor) + ".");
    }
    // The additive step and the paper's rho are both proportional to the strength the
    // modulation is built from (modulation_strength): scaling what the key records scales it.
    key_.options.strength = key_.options.resolved_strength() * factor;
    if (key_.options.vertex_strength >= 0.0)
    {
        key_.options.vertex_strength *= factor;
    }
    init_modulation(static_cast<double>(rows_->size()));
}

}  // namespace meshmark

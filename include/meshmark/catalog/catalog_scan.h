// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "meshmark/catalog/catalog.h"
#include "meshmark/pipeline/detect_file.h"

namespace meshmark
{

/// \brief The \p count assets of \p index nearest to a suspect's \p features, nearest first, each
/// with its distance to the nearest of its views and its place in \p index.
/// \details Two rankings taken in turn, without repeats: by every feature of a view, and by the
/// features of positions alone (kShapePositionFeatures). The normals' features rank crops far
/// better and noised, smoothed or remeshed copies somewhat worse, so the turns keep the best
/// of each (bench/results/2026-11-30-scan-speed.md). An asset of an older catalogue, whose
/// views hold the positions' features alone, is in the second ranking only. Exact search over
/// every view (10,000 assets in about 40 ms).
[[nodiscard]] std::vector<std::pair<float, std::size_t>> shape_candidates(
    const std::vector<Catalog::IndexEntry>& index, const ShapeFeatures& features,
    std::size_t count);

/// \brief The first \p count assets of \p by_shape (shape_candidates' ranking) not \p taken, and
/// the variants of the best fitted among them, ranked by the fit of \p suspect's points onto
/// theirs (shape_fit), best first, each with its fit; on \p threads threads. \p features: the
/// suspect's (shape_features). Assets without points are left out. \details The index's features
/// tell near-duplicates apart no better than an attack moves a copy, and rank a crop's asset low;
/// the fit of the points ranks them far better (bench/results/2026-11-30-shape-fit.md). Each asset
/// is fitted from its whole and its 3 crop views nearest the suspect's features. The assets of the
/// vertex and face counts of any of the 8 best fitted (variants of one mesh: stretched, bent,
/// rescanned on the same triangles), up to 64, are fitted as well, wherever the index ranked them;
/// then the \p refits best (`catalog scan`: 32) are fitted again from 16 crop views each, the
/// better fit kept (bench/results/2026-11-30-variants-fitted.md).
[[nodiscard]] std::vector<std::pair<double, std::size_t>> shape_fit_ranking(
    const std::vector<Catalog::IndexEntry>& index,
    const std::vector<std::pair<float, std::size_t>>& by_shape, const std::vector<bool>& taken,
    const TriangleMesh& suspect, const ShapeFeatures& features, std::size_t count,
    std::size_t refits, int threads);

/// \brief Asset \p best and the other assets of its vertex and face counts in \p index (variants
/// of one mesh: stretched, bent, rescanned on the same triangles), closest to \p suspect first,
/// each with its score (surface_fits from shape_fit's pose of the suspect on \p best: an ICP
/// onto each one's original); at most \p count of them read (\p best, then the others in
/// \p index's order), on \p threads threads. Empty when \p best has no variant or the suspect
/// cannot be placed on it; an asset whose original cannot be read is left out.
/// \details shape_fit_ranking cannot tell a copy of one variant from another; their own
/// surfaces can (bench/results/2026-12-01-variants-by-their-surfaces.md).
[[nodiscard]] std::vector<std::pair<double, std::size_t>> variant_ranking(
    const Catalog& catalog, const std::vector<Catalog::IndexEntry>& index, std::size_t best,
    const TriangleMesh& suspect, const ShapeFeatures& features, std::size_t count, int threads);

/// Options of catalog_scan.
struct CatalogScanOptions
{
    /// The detection's options; decision.max_false_positive is the bound for a whole suspect
    /// against the whole catalogue (each asset's key is tested at it over the catalogue's size).
    DetectFileOptions detect;
    /// Assets tried per suspect: those in the suspect's numbering, then the nearest in shape
    /// (shape_candidates). 8: chosen by hand, measured at it and at 16
    /// (bench/results/2026-11-30-scan-speed.md); more trade time for crops and attacked
    /// look-alikes the index ranks low.
    int candidates = 8;
    /// A suspect none of the candidates claims: the shape index's next wider_shortlist assets
    /// are fitted too, and this many of the best fits not yet tried are tried, each replaced by
    /// the closest untried variant of its mesh (variant_ranking; 0: none); when two of the
    /// candidates were variants of the best fit's mesh (same vertex and face counts), up to 16
    /// of its other variants after them, closest first.
    int more_candidates = 4;
    /// The shape index's first assets fitted for the candidates (shape_fit_ranking; 128 found on
    /// scans what 64 missed, 256 little more: bench/results/2026-11-30-shape-fit.md), and the
    /// next ones fitted for the more candidates (real crops and smoothed copies among look-alike
    /// furniture ranked 143rd and 174th: bench/results/2026-11-30-wider-fit.md).
    std::size_t fit_shortlist = 128;
    std::size_t wider_shortlist = 256;
    /// Stop at the first asset that matches (the others would have to carry marks of their own
    /// in the same suspect); false: try every candidate.
    bool stop_at_match = true;
    ProgressCallback progress;  ///< ("N/M suspects", fraction done).
};

/// One asset whose mark was found in a suspect.
struct CatalogMatch
{
    std::string asset;
    std::filesystem::path original;
    /// The owner's claim's bound for the whole scan: the detection's times the number of assets
    /// (the union bound over every key the scan could have tried; docs/statistics.md).
    double false_positive_probability = 1.0;
    double score = 0.0;  ///< The owner's score (Decision::score).
    /// The accused recipients, each bound likewise; the published copy's is kPublishedRecipient.
    std::vector<RecipientScore> recipients;
    double shape_distance = 0.0;  ///< Its distance in the shape index.
    int rank = 0;                 ///< Its place among the candidates as tried (0 = first).
    DetectReport report;          ///< The detection against it.
};

/// An asset tried and not matched (for --json's "tried").
struct CatalogTry
{
    std::string asset;
    double shape_distance = 0.0;
    double false_positive_probability = 1.0;  ///< Scaled as CatalogMatch's.
    std::string error;  ///< The detection could not run (original missing...).
};

/// What catalog_scan found in one suspect.
struct SuspectScan
{
    std::filesystem::path path;
    bool detected = false;
    std::vector<CatalogMatch> matches;  ///< Strongest first.
    std::vector<CatalogTry> tried;      ///< The candidates that did not match, in the order tried.
    std::string error;                  ///< The suspect could not be read: why.
    double index_seconds = 0.0;
    double seconds = 0.0;
};

/// What catalog_scan found.
struct CatalogScanReport
{
    std::size_t assets = 0;  ///< Assets in the catalogue (interrupted adds too): the bound's count.
    double max_false_positive = 0.0;  ///< The per-suspect bound the claims were held to.
    std::vector<SuspectScan> suspects;
};

/// \brief Which catalogue assets each suspect was made from (docs/catalog.md): the assets in the
/// suspect's numbering (same counts, in-order fit), then the shape index's nearest, are tried
/// by the detection (with tracing), options.candidates of them in order.
/// \details A suspect is claimed for an asset when the detection's bound, times the number of
/// assets, is at most options.detect.decision.max_false_positive: the chance that an unmarked
/// suspect is claimed for any asset of the catalogue is then at most that, whichever assets the
/// index chose to try. A suspect that cannot be read is reported with its error; the scan goes on.
/// \throws InvalidOption for bad options; IoError when the catalogue cannot be read.
[[nodiscard]] CatalogScanReport catalog_scan(const Catalog& catalog,
                                             const std::vector<std::filesystem::path>& suspects,
                                             const CatalogScanOptions& options);

/// Options of catalog_issue.
struct CatalogIssueOptions
{
    std::vector<std::string> recipients;
    std::chrono::milliseconds lock_timeout = kDefaultLockTimeout;
    int threads = 0;
    ProgressCallback progress;
};

/// \brief Per-recipient copies of catalogue asset \p asset (embed_recipients, with the asset's
/// family key kept in the catalogue): each name's code is recorded, durably, before any copy is
/// written; a name recorded before gets the same copy again.
/// \throws InvalidOption (no such asset, an incomplete one, bad names or pattern), IoError (the
/// original missing or changed), InvalidMesh, NumericalError.
[[nodiscard]] EmbedRecipientsReport catalog_issue(Catalog& catalog, const std::string& asset,
                                                  const std::string& output_pattern,
                                                  const CatalogIssueOptions& options);

}  // namespace meshmark

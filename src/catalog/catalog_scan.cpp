// SPDX-License-Identifier: MIT
// `catalog scan`: the shape index ranks the assets, the detection decides; and `catalog issue`.
#include "meshmark/catalog/catalog_scan.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <optional>
#include <thread>

#include "catalog/catalog_add_impl.h"
#include "catalog/scan_candidates.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/shape_signature.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/verdict.h"

namespace meshmark
{
namespace
{

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start)
{
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// What trying one candidate gave: a match, a try that did not match (or failed), or nothing
// (the asset was removed since the index was read).
struct CandidateOutcome
{
    std::optional<CatalogMatch> match;
    std::optional<CatalogTry> tried;
    std::exception_ptr failure;  ///< anything but a detection's own Error, rethrown in rank order
};

// The detection of \p suspect against the catalogue's asset \p id, at the scan's level: its
// bounds times the number of \p assets.
CandidateOutcome try_candidate(const Catalog& catalog, const std::string& id, float distance,
                               int rank, const TriangleMesh& suspect,
                               const DetectFileOptions& detect, double assets)
{
    const auto scaled = [assets](double p) { return std::min(1.0, p * assets); };
    CandidateOutcome outcome;
    CatalogTry tried{id, distance, 1.0, {}};
    try
    {
        const std::optional<CatalogAsset> asset = catalog.asset(id);
        if (!asset)
        {
            return outcome;  // removed since the index was read
        }
        DetectReport found = detect_against_original(suspect, asset->original, asset->key, detect);
        // The verdict's probability (verdict.h): the strongest accusation's, else the ownership's.
        const double verdict_fpp =
            verdict_of(found, detect.decision.max_false_positive).false_positive_probability;
        tried.false_positive_probability = scaled(verdict_fpp);
        if (found.detected())
        {
            CatalogMatch match;
            match.asset = id;
            match.original = asset->original;
            match.false_positive_probability = scaled(verdict_fpp);
            match.score = found.decision.score;
            match.recipients = found.accused;
            for (RecipientScore& recipient : match.recipients)
            {
                recipient.false_positive_probability = scaled(recipient.false_positive_probability);
            }
            match.shape_distance = distance;
            match.rank = rank;
            match.report = std::move(found);
            outcome.match = std::move(match);
            return outcome;
        }
    }
    catch (const Error& e)
    {
        tried.error = e.what();
    }
    outcome.tried = std::move(tried);
    return outcome;
}

// The shape index's features rank near-duplicates (variants of one object) about as far apart
// as an attack moves a copy, and a crop's asset often low; a fit of the suspect's points onto
// each of the first options.fit_shortlist assets' points (shape_fit_ranking) ranks them far
// better. Candidates taken from the fit's ranking for each one from the index's: the index's
// own first assets stay among the candidates (where the fit's start poses miss, it does not).
constexpr std::size_t kFitTurns = 3;
// The first kRefits of the fit's ranking are fitted again from more crop views (a crop's start
// poses: bench/results/2026-11-30-variants-fitted.md).
constexpr std::size_t kRefits = 32;

// Variants of the best fit's mesh tried at most in the second round, beside the best fits.
constexpr std::size_t kVariantTries = 16;
// Variants of the best fit's mesh read and scored at most (variant_ranking): a catalogue of
// 100,000 near-duplicates holds about 150 of each mesh.
constexpr std::size_t kVariantReads = 256;

// The detection of one suspect against a list of candidates.
struct Candidates
{
    const Catalog& catalog;
    const std::vector<Catalog::IndexEntry>& index;
    const TriangleMesh& suspect;
    const DetectFileOptions& detect;
    double assets = 1.0;  ///< the bound's count
    int threads = 1;
    bool stop_at_match = true;

    /// Tries \p ranked (shape distance, asset) in order, ranks numbered from \p first_rank,
    /// into \p scan's matches and tries; \return whether any matched. The first alone on every
    /// thread (a suspect the index ranks right costs one detection, at full speed); the others
    /// several at once, one thread each (a small model's detection gains little from a second
    /// thread, two detections at once twice: bench/results/2026-11-30-scan-speed.md).
    bool try_all(const std::vector<std::pair<float, std::size_t>>& ranked, int first_rank,
                 SuspectScan& scan) const
    {
        if (ranked.empty())
        {
            return false;
        }
        std::vector<CandidateOutcome> outcomes(ranked.size());
        const auto try_rank = [&](std::size_t r, int detect_threads)
        {
            DetectFileOptions one = detect;
            one.threads = detect_threads;
            try
            {
                outcomes[r] = try_candidate(catalog, index[ranked[r].second].id, ranked[r].first,
                                            first_rank + static_cast<int>(r), suspect, one, assets);
            }
            catch (...)
            {
                outcomes[r].failure = std::current_exception();
            }
        };
        try_rank(0, threads);
        if (!(stop_at_match && outcomes[0].match))
        {
            // Ranks handed out in order; none past a match is started once the match is known.
            std::atomic<std::size_t> next{1};
            std::atomic<std::size_t> first_match{ranked.size()};
            const auto work = [&]
            {
                for (std::size_t r = next++; r < ranked.size(); r = next++)
                {
                    if (stop_at_match && r > first_match.load())
                    {
                        return;
                    }
                    try_rank(r, 1);
                    if (outcomes[r].match)
                    {
                        std::size_t known = first_match.load();
                        while (r < known && !first_match.compare_exchange_weak(known, r))
                        {
                        }
                    }
                }
            };
            const int jobs = std::min<int>(threads, static_cast<int>(ranked.size()) - 1);
            std::vector<std::jthread> workers;
            for (int j = 1; j < jobs; ++j)
            {
                workers.emplace_back(work);
            }
            work();
            workers.clear();  // joins
        }
        // In rank order, as one thread trying them in turn would report them: past the first
        // match (when stopping there) nothing counts, even what a worker had already tried.
        bool matched = false;
        for (CandidateOutcome& outcome : outcomes)
        {
            if (outcome.failure)
            {
                std::rethrow_exception(outcome.failure);
            }
            if (outcome.match)
            {
                scan.matches.push_back(std::move(*outcome.match));
                matched = true;
                if (stop_at_match)
                {
                    break;
                }
            }
            else if (outcome.tried)
            {
                scan.tried.push_back(std::move(*outcome.tried));
            }
        }
        return matched;
    }
};

}  // namespace

CatalogScanReport catalog_scan(const Catalog& catalog,
                               const std::vector<std::filesystem::path>& suspects,
                               const CatalogScanOptions& options)
{
    options.detect.decision.validate();
    if (options.candidates < 1)
    {
        throw InvalidOption("--candidates must be at least 1.");
    }
    if (options.more_candidates < 0)
    {
        throw InvalidOption("--more-candidates must be at least 0.");
    }
    CatalogScanReport report;
    const std::vector<Catalog::IndexEntry> index = catalog.shape_index();
    report.assets = index.size();
    report.max_false_positive = options.detect.decision.max_false_positive;
    // Each key is tested at the whole scan's level over the number of keys: a union bound over
    // every asset, whether or not the index proposes it.
    const double assets = static_cast<double>(std::max<std::size_t>(report.assets, 1));
    DetectFileOptions detect = options.detect;
    detect.decision.max_false_positive = options.detect.decision.max_false_positive / assets;
    detect.progress = nullptr;

    const int threads = resolve_threads(options.detect.threads);
    for (std::size_t s = 0; s < suspects.size(); ++s)
    {
        const auto start = Clock::now();
        SuspectScan scan;
        scan.path = suspects[s];
        TriangleMesh suspect;
        try
        {
            suspect = read_mesh(suspects[s]);
        }
        catch (const Error& e)
        {
            scan.error = e.what();
        }
        if (scan.error.empty() && !index.empty())
        {
            const auto index_start = Clock::now();
            // Assets in the suspect's numbering first, then the shape index's, up to the
            // candidates asked; each with its shape distance.
            const ShapeFeatures features = shape_features(suspect);
            const auto by_shape = shape_candidates(index, features, index.size());
            std::vector<float> distance(index.size(), std::numeric_limits<float>::infinity());
            for (const auto& [d, a] : by_shape)
            {
                distance[a] = d;
            }
            std::vector<std::pair<float, std::size_t>> ranked;
            std::vector<bool> taken(index.size(), false);
            const auto take = [&](std::size_t a)
            {
                if (!taken[a] && ranked.size() < static_cast<std::size_t>(options.candidates))
                {
                    taken[a] = true;
                    ranked.emplace_back(distance[a], a);
                }
            };
            for (const std::size_t a :
                 catalog_detail::in_order_fits(catalog, index, suspect, threads))
            {
                take(a);
            }
            const std::size_t in_order = ranked.size();
            // Then kFitTurns of the fit's ranking for each of the index's, in turn.
            const std::vector<std::pair<double, std::size_t>> by_fit = shape_fit_ranking(
                index, by_shape, taken, suspect, features, options.fit_shortlist, kRefits, threads);
            std::size_t at_fit = 0;
            std::size_t at_shape = 0;
            while (ranked.size() < static_cast<std::size_t>(options.candidates) &&
                   (at_fit < by_fit.size() || at_shape < by_shape.size()))
            {
                for (std::size_t turn = 0; turn < kFitTurns && at_fit < by_fit.size(); ++turn)
                {
                    take(by_fit[at_fit++].second);
                }
                while (at_shape < by_shape.size() && taken[by_shape[at_shape].second])
                {
                    ++at_shape;
                }
                if (at_shape < by_shape.size())
                {
                    take(by_shape[at_shape++].second);
                }
            }
            // The variants of the best fit's mesh (shape_fit cannot choose among them), closest
            // first by a fit onto each one's own surface: the candidates' places that hold
            // variants go to the closest of them.
            // (Ranked once, when places are left after the assets in the suspect's numbering or
            // for the second round.)
            std::optional<std::vector<std::pair<double, std::size_t>>> ranked_variants;
            const auto variants = [&]() -> const std::vector<std::pair<double, std::size_t>>&
            {
                if (!ranked_variants)
                {
                    ranked_variants =
                        by_fit.empty() ? std::vector<std::pair<double, std::size_t>>{}
                                       : variant_ranking(catalog, index, by_fit.front().second,
                                                         suspect, features, kVariantReads, threads);
                }
                return *ranked_variants;
            };
            if (in_order < ranked.size())
            {
                catalog_detail::closest_variants_first(ranked, in_order, taken, variants(),
                                                       distance);
            }
            scan.index_seconds = seconds_since(index_start);
            const Candidates candidates{
                catalog, index, suspect, detect, assets, threads, options.stop_at_match};
            if (!candidates.try_all(ranked, 0, scan) && options.more_candidates > 0)
            {
                // None claimed it: the index's next options.wider_shortlist fitted too (from 3
                // crop views each, not again from more), and the best fits of both not yet tried.
                const auto wider_start = Clock::now();
                std::vector<bool> fitted = taken;
                for (const auto& [fit, a] : by_fit)
                {
                    fitted[a] = true;
                }
                std::vector<std::pair<double, std::size_t>> fits =
                    shape_fit_ranking(index, by_shape, fitted, suspect, features,
                                      options.wider_shortlist, 0, threads);
                for (const auto& [fit, a] : by_fit)
                {
                    if (!taken[a])
                    {
                        fits.emplace_back(fit, a);
                    }
                }
                std::stable_sort(fits.begin(), fits.end(),
                                 [](const auto& x, const auto& y) { return x.first < y.first; });
                // The fit cannot tell a crop of one variant of a mesh from another (the same
                // vertex and face counts: stretched, bent, rescanned on the same triangles):
                // when the first round was crowded with them, the best fit's others not yet
                // tried are tried too, up to kVariantTries.
                std::vector<std::pair<float, std::size_t>> more;
                const std::size_t best_fit = by_fit.empty()
                                                 ? (fits.empty() ? 0 : fits.front().second)
                                                 : by_fit.front().second;
                const Catalog::IndexEntry& best = index[best_fit];
                const auto variant_of_best = [&](std::size_t a) {
                    return index[a].vertex_count == best.vertex_count &&
                           index[a].face_count == best.face_count;
                };
                // Only when the first round's candidates held two of its variants (itself
                // included: the fit could not choose among them); otherwise the best fits alone.
                const bool crowded =
                    std::count_if(ranked.begin(), ranked.end(),
                                  [&](const auto& r) { return variant_of_best(r.second); }) >= 2;
                // The best fits, then the best fit's other variants, closest by their own
                // surfaces (by the points' fit where none could be read).
                std::vector<bool> chosen = taken;
                const auto choose = [&](std::size_t a)
                {
                    chosen[a] = true;
                    more.emplace_back(distance[a], a);
                };
                // The best fits' places, each given to the closest untried variant of its mesh
                // (the fit cannot choose among them; their surfaces can).
                std::vector<std::size_t> best_fits;
                for (const auto& [fit, a] : fits)
                {
                    if (!chosen[a] &&
                        best_fits.size() < static_cast<std::size_t>(options.more_candidates))
                    {
                        best_fits.push_back(a);
                    }
                }
                std::map<std::pair<std::int64_t, std::int64_t>,
                         std::vector<std::pair<double, std::size_t>>>
                    closest;
                for (const std::size_t a : best_fits)
                {
                    const std::pair counts{index[a].vertex_count, index[a].face_count};
                    if (!closest.contains(counts))
                    {
                        closest[counts] = variant_of_best(a)
                                              ? variants()
                                              : variant_ranking(catalog, index, a, suspect,
                                                                features, kVariantReads, threads);
                    }
                    std::size_t pick = a;
                    for (const auto& [score, b] : closest[counts])
                    {
                        if (!chosen[b])
                        {
                            pick = b;
                            break;
                        }
                    }
                    if (!chosen[pick])
                    {
                        choose(pick);
                    }
                }
                if (crowded)
                {
                    std::size_t variant_tries = 0;
                    for (const auto& [score, a] : variants().empty() ? fits : variants())
                    {
                        if (!chosen[a] && variant_of_best(a) && variant_tries < kVariantTries)
                        {
                            ++variant_tries;
                            choose(a);
                        }
                    }
                }
                scan.index_seconds += seconds_since(wider_start);
                candidates.try_all(more, static_cast<int>(ranked.size()), scan);
            }
        }
        std::stable_sort(scan.matches.begin(), scan.matches.end(),
                         [](const CatalogMatch& a, const CatalogMatch& b)
                         { return a.false_positive_probability < b.false_positive_probability; });
        scan.detected = !scan.matches.empty();
        scan.seconds = seconds_since(start);
        report.suspects.push_back(std::move(scan));
        if (options.progress)
        {
            options.progress("suspects",
                             static_cast<double>(s + 1) / static_cast<double>(suspects.size()));
        }
    }
    return report;
}

CatalogAsset catalog_detail::issuable_asset(const Catalog& catalog, const std::string& asset_id)
{
    std::optional<CatalogAsset> asset = catalog.asset(asset_id);
    if (!asset)
    {
        throw InvalidOption(catalog.path().string() + ": no asset '" + asset_id +
                            "' in the catalogue (`meshmark catalog list` shows them).");
    }
    if (!asset->is_complete)
    {
        throw InvalidOption(
            catalog.path().string() + ": asset '" + asset_id +
            "' was not finished being added; run the same `catalog add` again first.");
    }
    std::error_code error;
    if (!std::filesystem::is_regular_file(asset->original, error))
    {
        throw IoError(asset->original.string() + ": the original of asset '" + asset_id +
                      "' is no longer there; copies are made from the original.");
    }
    return std::move(*asset);
}

EmbedRecipientsReport catalog_issue(Catalog& catalog, const std::string& asset_id,
                                    const std::string& output_pattern,
                                    const CatalogIssueOptions& options)
{
    const CatalogAsset asset = catalog_detail::issuable_asset(catalog, asset_id);
    EmbedRecipientsOptions embed;
    embed.recipients = options.recipients;
    embed.lock_timeout = options.lock_timeout;
    embed.threads = options.threads;
    embed.progress = options.progress;
    const std::unique_ptr<FamilyKeyStore> store = catalog.family_store(asset_id);
    return embed_recipients(
        asset.original, nullptr,
        [&](const std::string& name) { return recipient_output(output_pattern, name); }, *store,
        embed);
}

}  // namespace meshmark

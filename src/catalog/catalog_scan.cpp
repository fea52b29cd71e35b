// SPDX-License-Identifier: MIT
// `catalog scan`: the shape index ranks the assets, the detection decides; and `catalog issue`.
#include "meshmark/catalog/catalog_scan.h"

#include <algorithm>
#include <array>
#include <limits>
#include <chrono>
#include <cmath>

#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/verdict.h"

namespace meshmark {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start)
{
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// The assets nearest to \p features, by the distance to the nearest of their views: exact
// search over the stored bytes (at 10,000 assets about 20 ms, a small part of one detection;
// bench/results/2026-11-29-catalogue.md). Each view's features are bytes of 255ths, so the
// suspect's are scaled alike and the squared differences summed in that unit.
std::vector<std::pair<float, std::size_t>> nearest(const std::vector<Catalog::IndexEntry>& index,
                                                   const ShapeFeatures& features, std::size_t count)
{
    std::array<float, kShapeFeatures> scaled{};
    for (std::size_t i = 0; i < scaled.size(); ++i)
    {
        scaled[i] = 255.0F * features[i];
    }
    std::vector<std::pair<float, std::size_t>> ranked;
    ranked.reserve(index.size());
    for (std::size_t a = 0; a < index.size(); ++a)
    {
        const std::vector<std::uint8_t>& views = index[a].views;
        float best = std::numeric_limits<float>::infinity();
        for (std::size_t at = 0; at + kShapeFeatures <= views.size(); at += kShapeFeatures)
        {
            float sum = 0.0F;
            for (std::size_t i = 0; i < kShapeFeatures; ++i)
            {
                const float d = scaled[i] - static_cast<float>(views[at + i]);
                sum += d * d;
            }
            best = std::min(best, sum);
        }
        ranked.emplace_back(std::sqrt(best) / 255.0F, a);
    }
    count = std::min(count, ranked.size());
    std::partial_sort(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(count), ranked.end());
    ranked.resize(count);
    return ranked;
}

}  // namespace

CatalogScanReport catalog_scan(const Catalog& catalog, const std::vector<std::filesystem::path>& suspects,
                               const CatalogScanOptions& options)
{
    options.detect.decision.validate();
    if (options.candidates < 1)
    {
        throw InvalidOption("--candidates must be at least 1.");
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
    const auto scaled = [&](double p) { return std::min(1.0, p * assets); };

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
            const auto ranked = nearest(index, shape_features(suspect), static_cast<std::size_t>(options.candidates));
            scan.index_seconds = seconds_since(index_start);
            for (std::size_t r = 0; r < ranked.size(); ++r)
            {
                const auto& [distance, a] = ranked[r];
                const std::string& id = index[a].id;
                CatalogTry tried{id, distance, 1.0, {}};
                try
                {
                    const std::optional<CatalogAsset> asset = catalog.asset(id);
                    if (!asset)
                    {
                        continue;  // removed since the index was read
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
                        match.rank = static_cast<int>(r);
                        match.report = std::move(found);
                        scan.matches.push_back(std::move(match));
                        if (options.stop_at_match)
                        {
                            break;
                        }
                        continue;
                    }
                }
                catch (const Error& e)
                {
                    tried.error = e.what();
                }
                scan.tried.push_back(std::move(tried));
            }
        }
        std::stable_sort(scan.matches.begin(), scan.matches.end(), [](const CatalogMatch& a, const CatalogMatch& b)
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

EmbedRecipientsReport catalog_issue(Catalog& catalog, const std::string& asset_id, const std::string& output_pattern,
                                    const CatalogIssueOptions& options)
{
    const std::optional<CatalogAsset> asset = catalog.asset(asset_id);
    if (!asset)
    {
        throw InvalidOption(catalog.path().string() + ": no asset '" + asset_id +
                            "' in the catalogue (`meshmark catalog list` shows them).");
    }
    if (!asset->is_complete)
    {
        throw InvalidOption(catalog.path().string() + ": asset '" + asset_id +
                            "' was not finished being added; run the same `catalog add` again first.");
    }
    std::error_code error;
    if (!std::filesystem::is_regular_file(asset->original, error))
    {
        throw IoError(asset->original.string() + ": the original of asset '" + asset_id +
                      "' is no longer there; copies are made from the original.");
    }
    EmbedRecipientsOptions embed;
    embed.recipients = options.recipients;
    embed.lock_timeout = options.lock_timeout;
    embed.threads = options.threads;
    embed.progress = options.progress;
    const std::unique_ptr<FamilyKeyStore> store = catalog.family_store(asset_id);
    return embed_recipients(
        asset->original, nullptr, [&](const std::string& name) { return recipient_output(output_pattern, name); },
        *store, embed);
}

}  // namespace meshmark

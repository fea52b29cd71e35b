// SPDX-License-Identifier: MIT
// Tracing a family key's recipients: SpectralWatermark::trace (docs/fingerprinting.md).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/watermark/decision.h"
#include "meshmark/watermark/watermark.h"
#include "watermark/unit_vectors.h"

namespace meshmark
{

std::vector<RecipientScore> SpectralWatermark::trace(const Extraction& extraction,
                                                     const DetectOptions& options) const
{
    options.validate();
    std::vector<RecipientScore> scores;
    if (!key_.recipients ||
        (extraction.recipient_change.empty() && extraction.region_changes.empty()))
    {
        return scores;
    }
    // Each innocent recipient's code is independent of the suspect (made from the owner's mark
    // and other recipients' codes), so its score is bounded as the owner's soft score is; the
    // union over the key's recipients bounds the chance that any innocent is accused.
    const int threads = resolve_threads(threads_);
    const SoftCorrelation soft(extraction.recipient_change, extraction.recipient_weights,
                               extraction.further_recipient_changes, true, threads);
    // Regions (spliced suspects): one uniform-weight correlation each; the global test and the
    // regions share the level half and half (a weighted union bound, docs/fingerprinting.md).
    std::vector<std::vector<double>> regions;  // each region's values scaled to unit norm
    regions.reserve(extraction.region_changes.size());
    for (const std::vector<double>& change : extraction.region_changes)
    {
        regions.push_back(detail::scaled_to_unit(change));
    }
    const double region_count = static_cast<double>(regions.size());
    const std::vector<Recipient>& recipients = key_.recipients->recipients;
    const double recipient_count = static_cast<double>(recipients.size());
    const auto n = static_cast<std::size_t>(3 * recipient_modes());
    const bool has_whole = soft.size() > 0;
    // The owner's coefficients followed by the code's, for the joint (ownership) score.
    std::vector<double> joint_x = extraction.normalized_change;
    std::vector<double> joint_w = extraction.weights;
    joint_x.insert(joint_x.end(), extraction.recipient_change.begin(),
                   extraction.recipient_change.end());
    joint_w.insert(joint_w.end(), extraction.recipient_weights.begin(),
                   extraction.recipient_weights.end());
    const std::size_t owner_count = extraction.normalized_change.size();
    const bool has_joint = has_whole && owner_count == static_cast<std::size_t>(signs_.size());
    // The damped readings of both parts, joined the same way.
    std::vector<std::vector<double>> joint_damped;
    if (has_joint &&
        extraction.further_changes.size() == extraction.further_recipient_changes.size())
    {
        for (std::size_t l = 0; l < extraction.further_changes.size(); ++l)
        {
            std::vector<double> both = extraction.further_changes[l];
            both.insert(both.end(), extraction.further_recipient_changes[l].begin(),
                        extraction.further_recipient_changes[l].end());
            joint_damped.push_back(std::move(both));
        }
    }
    const SoftCorrelation joint(has_joint ? joint_x : std::vector<double>(),
                                has_joint ? joint_w : std::vector<double>(), joint_damped, true,
                                threads);
    const bool is_sized = (!has_whole || soft.size() == n) &&
                          std::all_of(regions.begin(), regions.end(),
                                      [n](const auto& unit) { return unit.size() == n; });
    if (!is_sized)
    {
        throw InvalidOption("trace: the extraction's recipient code readings must have " +
                            std::to_string(n) + " values (3 per code mode).");
    }
    // Recipients are scored kLanes at a time: their signs interleaved (code c of lane j at
    // c * kLanes + j), so each region's dot products run as kLanes independent sums that the
    // compiler vectorizes; each sum still adds its terms in coefficient order, so every score
    // is the one a recipient-by-recipient loop gives. (One recipient at a time, the regions'
    // 28 serial sums were 0.1 s of a trace of 10,000.)
    // Groups of recipients are independent: they are spread over the watermark's threads, each
    // writing its own entries (the same result for any thread count).
    // 8 lanes (8 doubles, one AVX-512 register): chosen by hand; no study on record.
    constexpr std::size_t kLanes = 8;
    // From this many recipients on the groups go to threads (10,000: 45 -> 24 ms on 2 threads,
    // commit 694ea24); the 512 itself was chosen by hand; no study on record.
    constexpr int kParallelRecipients = 512;
    scores.resize(recipients.size());
    const auto groups = static_cast<std::int64_t>((recipients.size() + kLanes - 1) / kLanes);
    const int score_threads = recipients.size() >= kParallelRecipients ? threads : 1;
#pragma omp parallel for num_threads(score_threads) schedule(dynamic, 8)
    for (std::int64_t group = 0; group < groups; ++group)
    {
        const std::size_t first = static_cast<std::size_t>(group) * kLanes;
        const std::size_t lanes = std::min(kLanes, recipients.size() - first);
        std::vector<double> signs(n * kLanes, 0.0);
        for (std::size_t j = 0; j < lanes; ++j)
        {
            const std::vector<std::uint8_t> code =
                recipient_code(key_.seed, recipients[first + j].index, static_cast<int>(n));
            for (std::size_t c = 0; c < n; ++c)
            {
                signs[c * kLanes + j] = code[c] != 0 ? 1.0 : -1.0;
            }
        }
        std::array<double, kLanes> best_region{};
        std::array<double, kLanes> whole_region{};  // region 0: every (kept) row
        for (std::size_t region = 0; region < regions.size(); ++region)
        {
            const std::vector<double>& unit = regions[region];
            std::array<double, kLanes> z{};
            for (std::size_t c = 0; c < n; ++c)
            {
                const double u = unit[c];
                const double* s_c = signs.data() + c * kLanes;
                for (std::size_t j = 0; j < kLanes; ++j)
                {
                    z[j] += s_c[j] * u;
                }
            }
            if (region == 0)
            {
                whole_region = z;
            }
            for (std::size_t j = 0; j < kLanes; ++j)
            {
                best_region[j] = region == 0 ? z[j] : std::max(best_region[j], z[j]);
            }
        }
        for (std::size_t j = 0; j < lanes; ++j)
        {
            const Recipient& recipient = recipients[first + j];
            RecipientScore entry{recipient.name, recipient.index};
            double bound = 1.0;
            if (has_whole)
            {
                const SoftScore whole =
                    soft.score([&](std::size_t c) { return signs[c * kLanes + j]; });
                entry.score = whole.z;
                bound = whole.probability;
            }
            if (has_joint)
            {
                // Under the null (a suspect without the mark) every sign, the owner's and the
                // code's, is independent of the readings: one Rademacher sum, bounded as any.
                const SoftScore both = joint.score(
                    [&](std::size_t c)
                    {
                        return c < owner_count ? signs_(static_cast<Eigen::Index>(c / 3),
                                                        static_cast<Eigen::Index>(c % 3))
                                               : signs[(c - owner_count) * kLanes + j];
                    });
                entry.joint_score = both.z;
                entry.joint_false_positive_probability =
                    std::min(1.0, recipient_count * both.probability);
            }
            if (!regions.empty())
            {
                entry.region_score = std::max(0.0, best_region[j]);
                if (!has_whole)
                {
                    entry.score =
                        whole_region[j];  // a cropped suspect: the whole (kept) model's region
                }
                const double regions_bound =
                    region_count * rademacher_tail_bound(entry.region_score);
                // With the joint reading of the whole model, it and the regions share the level
                // half and half; without it (cropped suspects) the regions have all of it.
                bound = has_whole ? std::min(2.0 * bound, 2.0 * regions_bound) : regions_bound;
            }
            entry.false_positive_probability = std::min(1.0, recipient_count * bound);
            entry.is_accused = entry.false_positive_probability <= options.max_false_positive;
            scores[first + j] = std::move(entry);
        }
    }
    return scores;
}

}  // namespace meshmark

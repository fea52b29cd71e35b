// SPDX-License-Identifier: MIT
// The verdict: options, further readings joined, the soft correlation and SpectralWatermark::decide
// (tracing recipients: tracing.cpp; the tail bounds: tail_bounds.cpp).
#include "meshmark/watermark/decision.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <tuple>

#include "meshmark/core/error.h"
#include "meshmark/core/named_choice.h"
#include "meshmark/core/threads.h"
#include "meshmark/watermark/watermark.h"
#include "watermark/unit_vectors.h"

namespace meshmark
{
namespace
{

// Normalized coefficient changes below this are rounding, not signal or attack.
constexpr double kNegligibleChange = 1e-6;
// Combined verdict: the share of the false-positive level given to the bit count. 1/16 is the
// smallest share at which a perfect read of the default 24 bits (2^-24) is claimed at 1e-6;
// the soft score keeps 15/16 of the level (its threshold moves from z 5.35 to 5.36 with its 5
// statistics; docs/statistics.md).
constexpr double kBitCountShare = 1.0 / 16.0;

}  // namespace

void DetectOptions::validate() const
{
    if (!(threshold > 0.0 && threshold <= 1.0))
    {
        throw InvalidOption("detection threshold must be in (0, 1], got " +
                            std::to_string(threshold) + ".");
    }
    if (!(epsilon >= 0.0 && epsilon < 1.0))
    {
        throw InvalidOption("epsilon must be in [0, 1), got " + std::to_string(epsilon) + ".");
    }
    if (!(max_false_positive > 0.0 && max_false_positive <= 1.0))
    {
        throw InvalidOption(
            "the largest false-positive probability (--max-fpp) must be in (0, 1], got " +
            std::to_string(max_false_positive) + ".");
    }
}

const char* to_string(VerdictRule rule) noexcept
{
    switch (rule)
    {
        case VerdictRule::Combined:
            return "combined";
        case VerdictRule::Correlation:
            return "correlation";
        case VerdictRule::Bits:
            return "bits";
    }
    return "combined";
}

VerdictRule parse_verdict_rule(const std::string& name)
{
    return parse_named_choice<VerdictRule>(name, "verdict rule",
                                           {{"combined", VerdictRule::Combined},
                                            {"correlation", VerdictRule::Correlation},
                                            {"bits", VerdictRule::Bits}});
}

namespace
{

/// \p x times \p w to the power \p power (0, 1/2 or 1: the verdict's three weightings).
std::vector<double> weighted_by(const std::vector<double>& x, const std::vector<double>& w,
                                double power)
{
    std::vector<double> weighted(x.size());
    for (std::size_t c = 0; c < x.size(); ++c)
    {
        const double a = power == 0.0 ? 1.0 : std::pow(std::max(w[c], 0.0), power);
        weighted[c] = a * x[c];
    }
    return weighted;
}

/// The sum of \p readings[i] for i in \p group, each scaled to unit norm.
std::vector<double> sum_of_units(const std::vector<std::vector<double>>& readings,
                                 const std::vector<std::size_t>& group)
{
    std::vector<double> sum(readings[group.front()].size(), 0.0);
    for (const std::size_t i : group)
    {
        const std::vector<double> unit = detail::scaled_to_unit(readings[i]);
        std::transform(sum.begin(), sum.end(), unit.begin(), sum.begin(), std::plus<>());
    }
    return sum;
}

}  // namespace

double score_level_factor(VerdictRule rule) noexcept
{
    switch (rule)
    {
        case VerdictRule::Combined:
            return 1.0 / (1.0 - kBitCountShare);
        case VerdictRule::Correlation:
            return 1.0;
        case VerdictRule::Bits:
            break;
    }
    return 0.0;
}

void add_further_reading(Extraction& primary, const Extraction& other)
{
    if (other.normalized_change.size() != primary.normalized_change.size() ||
        other.weights.size() != other.normalized_change.size())
    {
        throw InvalidOption(
            "add_further_reading: the two readings do not have the same coefficients.");
    }
    const bool is_paired =
        !primary.recipient_change.empty() &&
        primary.further_recipient_changes.size() == primary.further_changes.size();
    const bool has_code = other.recipient_change.size() == primary.recipient_change.size() &&
                          other.recipient_weights.size() == other.recipient_change.size() &&
                          other.further_recipient_changes.size() == other.further_changes.size();
    const std::vector<double> no_code(primary.recipient_change.size(), 0.0);
    // Both readings' own damped readings, before anything is added, for the joined statistics.
    const std::size_t own = primary.further_changes.size();
    const bool is_joined = own > 0 && own == other.further_changes.size() &&
                           primary.further_weightings.empty() && other.further_weightings.empty();
    for (const double power : {0.0, 0.5, 1.0})
    {
        primary.further_weightings.push_back(primary.further_changes.size());
        primary.further_changes.push_back(
            weighted_by(other.normalized_change, other.weights, power));
        if (is_paired)
        {
            primary.further_recipient_changes.push_back(
                has_code ? weighted_by(other.recipient_change, other.recipient_weights, power)
                         : no_code);
        }
    }
    for (std::size_t l = 0; l < other.further_changes.size(); ++l)
    {
        if (other.further_changes[l].size() != primary.normalized_change.size())
        {
            throw InvalidOption(
                "add_further_reading: the two readings do not have the same coefficients.");
        }
        primary.further_changes.push_back(other.further_changes[l]);
        if (is_paired)
        {
            primary.further_recipient_changes.push_back(
                has_code ? other.further_recipient_changes[l] : no_code);
        }
    }
    if (!is_joined)
    {
        return;
    }
    // The joined readings: at each damping level l the primary's (l) and the other's (the
    // last `own` further changes), then all of them; the code's parts joined alike.
    const std::size_t others = primary.further_changes.size() - own;
    std::vector<std::vector<std::size_t>> groups;
    for (std::size_t l = 0; l < own; ++l)
    {
        groups.push_back({l, others + l});
    }
    if (own >= 2)
    {
        groups.emplace_back();
        for (std::size_t l = 0; l < own; ++l)
        {
            groups.back().push_back(l);
            groups.back().push_back(others + l);
        }
    }
    for (const std::vector<std::size_t>& group : groups)
    {
        primary.further_changes.push_back(sum_of_units(primary.further_changes, group));
        if (is_paired)
        {
            primary.further_recipient_changes.push_back(
                sum_of_units(primary.further_recipient_changes, group));
        }
    }
}

int joined_reading_count(int damped) noexcept
{
    return damped < 1 ? 0 : damped + (damped >= 2 ? 1 : 0);
}

SoftCorrelation::SoftCorrelation(const std::vector<double>& x, const std::vector<double>& w,
                                 const std::vector<std::vector<double>>& extra,
                                 bool with_weightings, int threads)
    : size_(x.size())
{
    // A change below a millionth of the modulation is rounding (an unmarked original compared
    // with itself); dropping it keeps such a score at 0 and depends on no sign.
    auto add = [&](const std::vector<double>& values, auto weight_of)
    {
        std::vector<double> weighted(size_);
        double norm = 0.0;
        for (std::size_t c = 0; c < size_; ++c)
        {
            const double value = std::abs(values[c]) < kNegligibleChange ? 0.0 : values[c];
            weighted[c] = weight_of(c) * value;
            norm += weighted[c] * weighted[c];
        }
        weighted_.push_back(std::move(weighted));
        norm_.push_back(norm);
    };
    if (with_weightings)
    {
        add(x, [](std::size_t) { return 1.0; });
        add(x, [&](std::size_t c) { return std::sqrt(w[c]); });
        add(x, [&](std::size_t c) { return w[c]; });
    }
    for (const std::vector<double>& reading : extra)
    {
        if (reading.size() != size_)
        {
            throw InvalidOption("a damped reading has " + std::to_string(reading.size()) +
                                " values, expected " + std::to_string(size_) + ".");
        }
        add(reading, [](std::size_t) { return 1.0; });
    }
    // The tails are independent of one another and each costs up to a few milliseconds (a
    // family key's trace of a resampled suspect counts 26): one statistic per thread at a time.
    tails_.resize(weighted_.size());
    const auto count = static_cast<std::int64_t>(weighted_.size());
    const int workers = count > 1 ? std::min(resolve_threads(threads), static_cast<int>(count)) : 1;
#pragma omp parallel for num_threads(workers) schedule(dynamic, 1) if (workers > 1)
    for (std::int64_t s = 0; s < count; ++s)
    {
        tails_[static_cast<std::size_t>(s)] =
            RademacherTail(weighted_[static_cast<std::size_t>(s)]);
    }
}

Decision SpectralWatermark::decide(const Extraction& extraction, const DetectOptions& options) const
{
    options.validate();
    Decision decision;
    decision.verdict = options.verdict;
    decision.bit_count = static_cast<int>(key_.payload.size());
    for (std::size_t t = 0; t < key_.payload.size(); ++t)
    {
        const auto found = extraction.bits_found[t];
        decision.bits_expected.push_back(key_.payload[t] != 0 ? '1' : '0');
        decision.bits_found.push_back(found == 2 ? '?' : (found != 0 ? '1' : '0'));
        if (found == key_.payload[t])
        {
            ++decision.matches;
        }
    }
    decision.correlation = static_cast<double>(decision.matches) / decision.bit_count;
    decision.bits_false_positive_probability =
        binomial_tail_half(decision.bit_count, decision.matches);

    // Soft-decision correlation with the embedded signs. For a mesh that does not carry this
    // key's mark, x does not depend on the key mask, so sum_c b'_c a_c x_c is a sum of
    // independent random signs with fixed weights (docs/statistics.md). Three weightings a:
    // uniform (best when every coefficient is read equally well), inverse variance (best when
    // the nuisance fit or a crop makes some coefficients far noisier than others) and their
    // geometric mean; the verdict takes the best and pays for the choice with a union bound.
    // The damped readings (a crop or a coarse resampling leaves the modulated modes nearly
    // dependent) are further statistics with uniform weights, each paid for in the union bound.
    // A resampled suspect (Extraction::damped_only) scores its damped readings alone.
    std::vector<std::vector<double>> damped;
    if (extraction.damped_only)
    {
        for (std::size_t l = 0; l < extraction.further_changes.size(); ++l)
        {
            if (std::find(extraction.further_weightings.begin(),
                          extraction.further_weightings.end(),
                          l) == extraction.further_weightings.end())
            {
                damped.push_back(extraction.further_changes[l]);
            }
        }
    }
    const bool damped_only = !damped.empty();  // else (no damped reading) every statistic
    const SoftCorrelation soft(extraction.normalized_change, extraction.weights,
                               damped_only ? damped : extraction.further_changes, !damped_only,
                               threads_);
    decision.coefficient_count = static_cast<int>(soft.size());
    decision.statistic_count = soft.statistic_count();
    const SoftScore scored = soft.score(
        [&](std::size_t c)
        { return signs_(static_cast<Eigen::Index>(c / 3), static_cast<Eigen::Index>(c % 3)); });
    decision.score = scored.z;
    decision.score_tail = scored.tail;
    decision.score_false_positive_probability = scored.probability;
    if (extraction.unread_statistics > 0)
    {
        // Paid for as if computed: the score is the best of a subset of them.
        decision.statistic_count += extraction.unread_statistics;
        decision.score_false_positive_probability =
            std::min(1.0, decision.statistic_count * scored.tail);
    }

    switch (options.verdict)
    {
        case VerdictRule::Bits:
            decision.false_positive_probability = decision.bits_false_positive_probability;
            decision.is_present = decision.correlation >= options.threshold;
            break;
        case VerdictRule::Correlation:
            decision.false_positive_probability = decision.score_false_positive_probability;
            decision.is_present = decision.false_positive_probability <= options.max_false_positive;
            break;
        case VerdictRule::Combined:
            // Two tests of one null hypothesis, the soft score (already paid for its three
            // weightings) and the bit count (exact for an unmarked mesh), with a weighted union
            // bound: a share kBitCountShare of the level to the bit count (docs/statistics.md).
            decision.false_positive_probability = std::min(
                {1.0,
                 decision.score_false_positive_probability * score_level_factor(options.verdict),
                 decision.bits_false_positive_probability / kBitCountShare});
            decision.is_present = decision.false_positive_probability <= options.max_false_positive;
            break;
    }
    return decision;
}

}  // namespace meshmark

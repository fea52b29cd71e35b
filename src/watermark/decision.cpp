// SPDX-License-Identifier: MIT
// The verdict: options, tail bounds of the two rules, and SpectralWatermark::decide.
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

namespace meshmark {
namespace {

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
        throw InvalidOption("detection threshold must be in (0, 1], got " + std::to_string(threshold) + ".");
    }
    if (!(epsilon >= 0.0 && epsilon < 1.0))
    {
        throw InvalidOption("epsilon must be in [0, 1), got " + std::to_string(epsilon) + ".");
    }
    if (!(max_false_positive > 0.0 && max_false_positive <= 1.0))
    {
        throw InvalidOption("the largest false-positive probability (--max-fpp) must be in (0, 1], got " +
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

namespace {

/// \p x times \p w to the power \p power (0, 1/2 or 1: the verdict's three weightings).
std::vector<double> weighted_by(const std::vector<double>& x, const std::vector<double>& w, double power)
{
    std::vector<double> weighted(x.size());
    for (std::size_t c = 0; c < x.size(); ++c)
    {
        const double a = power == 0.0 ? 1.0 : std::pow(std::max(w[c], 0.0), power);
        weighted[c] = a * x[c];
    }
    return weighted;
}

/// \p values scaled to unit norm (all zeros where their norm is 0).
std::vector<double> scaled_to_unit(const std::vector<double>& values)
{
    double norm_sq = 0.0;
    for (const double v : values)
    {
        norm_sq += v * v;
    }
    std::vector<double> unit(values.size(), 0.0);
    if (norm_sq > 0.0)
    {
        const double scale = 1.0 / std::sqrt(norm_sq);
        std::transform(values.begin(), values.end(), unit.begin(), [scale](double v) { return v * scale; });
    }
    return unit;
}

/// The sum of \p readings[i] for i in \p group, each scaled to unit norm.
std::vector<double> sum_of_units(const std::vector<std::vector<double>>& readings, const std::vector<std::size_t>& group)
{
    std::vector<double> sum(readings[group.front()].size(), 0.0);
    for (const std::size_t i : group)
    {
        const std::vector<double> unit = scaled_to_unit(readings[i]);
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
        throw InvalidOption("add_further_reading: the two readings do not have the same coefficients.");
    }
    const bool is_paired = !primary.recipient_change.empty() &&
                           primary.further_recipient_changes.size() == primary.further_changes.size();
    const bool has_code = other.recipient_change.size() == primary.recipient_change.size() &&
                          other.recipient_weights.size() == other.recipient_change.size() &&
                          other.further_recipient_changes.size() == other.further_changes.size();
    const std::vector<double> no_code(primary.recipient_change.size(), 0.0);
    // Both readings' own damped readings, before anything is added, for the joined statistics.
    const std::size_t own = primary.further_changes.size();
    const bool is_joined = own > 0 && own == other.further_changes.size() && primary.further_weightings.empty() &&
                           other.further_weightings.empty();
    for (const double power : {0.0, 0.5, 1.0})
    {
        primary.further_weightings.push_back(primary.further_changes.size());
        primary.further_changes.push_back(weighted_by(other.normalized_change, other.weights, power));
        if (is_paired)
        {
            primary.further_recipient_changes.push_back(
                has_code ? weighted_by(other.recipient_change, other.recipient_weights, power) : no_code);
        }
    }
    for (std::size_t l = 0; l < other.further_changes.size(); ++l)
    {
        if (other.further_changes[l].size() != primary.normalized_change.size())
        {
            throw InvalidOption("add_further_reading: the two readings do not have the same coefficients.");
        }
        primary.further_changes.push_back(other.further_changes[l]);
        if (is_paired)
        {
            primary.further_recipient_changes.push_back(has_code ? other.further_recipient_changes[l] : no_code);
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
            primary.further_recipient_changes.push_back(sum_of_units(primary.further_recipient_changes, group));
        }
    }
}

int joined_reading_count(int damped) noexcept
{
    return damped < 1 ? 0 : damped + (damped >= 2 ? 1 : 0);
}

SoftCorrelation::SoftCorrelation(const std::vector<double>& x, const std::vector<double>& w,
                                 const std::vector<std::vector<double>>& extra, bool with_weightings, int threads)
    : size_(x.size())
{
    // A change below a millionth of the modulation is rounding (an unmarked original compared
    // with itself); dropping it keeps such a score at 0 and depends on no sign.
    auto add = [&](const std::vector<double>& values, auto weight_of) {
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
            throw InvalidOption("a damped reading has " + std::to_string(reading.size()) + " values, expected " +
                                std::to_string(size_) + ".");
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
        tails_[static_cast<std::size_t>(s)] = RademacherTail(weighted_[static_cast<std::size_t>(s)]);
    }
}

std::vector<RecipientScore> SpectralWatermark::trace(const Extraction& extraction, const DetectOptions& options) const
{
    options.validate();
    std::vector<RecipientScore> scores;
    if (!key_.recipients || (extraction.recipient_change.empty() && extraction.region_changes.empty()))
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
        regions.push_back(scaled_to_unit(change));
    }
    const double region_count = static_cast<double>(regions.size());
    const std::vector<Recipient>& recipients = key_.recipients->recipients;
    const double recipient_count = static_cast<double>(recipients.size());
    const auto n = static_cast<std::size_t>(3 * recipient_modes());
    const bool has_whole = soft.size() > 0;
    // The owner's coefficients followed by the code's, for the joint (ownership) score.
    std::vector<double> joint_x = extraction.normalized_change;
    std::vector<double> joint_w = extraction.weights;
    joint_x.insert(joint_x.end(), extraction.recipient_change.begin(), extraction.recipient_change.end());
    joint_w.insert(joint_w.end(), extraction.recipient_weights.begin(), extraction.recipient_weights.end());
    const std::size_t owner_count = extraction.normalized_change.size();
    const bool has_joint = has_whole && owner_count == static_cast<std::size_t>(signs_.size());
    // The damped readings of both parts, joined the same way.
    std::vector<std::vector<double>> joint_damped;
    if (has_joint && extraction.further_changes.size() == extraction.further_recipient_changes.size())
    {
        for (std::size_t l = 0; l < extraction.further_changes.size(); ++l)
        {
            std::vector<double> both = extraction.further_changes[l];
            both.insert(both.end(), extraction.further_recipient_changes[l].begin(),
                        extraction.further_recipient_changes[l].end());
            joint_damped.push_back(std::move(both));
        }
    }
    const SoftCorrelation joint(has_joint ? joint_x : std::vector<double>(), has_joint ? joint_w : std::vector<double>(),
                                joint_damped, true, threads);
    const bool is_sized = (!has_whole || soft.size() == n) &&
                          std::all_of(regions.begin(), regions.end(), [n](const auto& unit) { return unit.size() == n; });
    if (!is_sized)
    {
        throw InvalidOption("trace: the extraction's recipient code readings must have " + std::to_string(n) +
                            " values (3 per code mode).");
    }
    // Recipients are scored kLanes at a time: their signs interleaved (code c of lane j at
    // c * kLanes + j), so each region's dot products run as kLanes independent sums that the
    // compiler vectorizes; each sum still adds its terms in coefficient order, so every score
    // is the one a recipient-by-recipient loop gives. (One recipient at a time, the regions'
    // 28 serial sums were 0.1 s of a trace of 10,000.)
    // Groups of recipients are independent: they are spread over the watermark's threads, each
    // writing its own entries (the same result for any thread count).
    constexpr std::size_t kLanes = 8;
    scores.resize(recipients.size());
    const auto groups = static_cast<std::int64_t>((recipients.size() + kLanes - 1) / kLanes);
    const int score_threads = recipients.size() >= 512 ? threads : 1;
#pragma omp parallel for num_threads(score_threads) schedule(dynamic, 8)
    for (std::int64_t group = 0; group < groups; ++group)
    {
        const std::size_t first = static_cast<std::size_t>(group) * kLanes;
        const std::size_t lanes = std::min(kLanes, recipients.size() - first);
        std::vector<double> signs(n * kLanes, 0.0);
        for (std::size_t j = 0; j < lanes; ++j)
        {
            const std::vector<std::uint8_t> code = recipient_code(key_.seed, recipients[first + j].index, static_cast<int>(n));
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
                const SoftScore whole = soft.score([&](std::size_t c) { return signs[c * kLanes + j]; });
                entry.score = whole.z;
                bound = whole.probability;
            }
            if (has_joint)
            {
                // Under the null (a suspect without the mark) every sign, the owner's and the
                // code's, is independent of the readings: one Rademacher sum, bounded as any.
                const SoftScore both = joint.score([&](std::size_t c) {
                    return c < owner_count ? signs_(static_cast<Eigen::Index>(c / 3), static_cast<Eigen::Index>(c % 3))
                                           : signs[(c - owner_count) * kLanes + j];
                });
                entry.joint_score = both.z;
                entry.joint_false_positive_probability = std::min(1.0, recipient_count * both.probability);
            }
            if (!regions.empty())
            {
                entry.region_score = std::max(0.0, best_region[j]);
                if (!has_whole)
                {
                    entry.score = whole_region[j];  // a cropped suspect: the whole (kept) model's region
                }
                const double regions_bound = region_count * rademacher_tail_bound(entry.region_score);
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

RademacherTail::RademacherTail(const std::vector<double>& weights, double resolution)
{
    if (!(resolution > 0.0))
    {
        throw InvalidOption("RademacherTail: the resolution must be positive.");
    }
    double norm_sq = 0.0;
    std::size_t nonzero = 0;
    for (const double a : weights)
    {
        norm_sq += a * a;
        nonzero += a != 0.0 ? 1 : 0;
    }
    if (!(norm_sq > 0.0) || !std::isfinite(norm_sq))
    {
        return;  // no weight: the sum is 0, every tail above 0 is 0 and reported as 1
    }
    const double norm = std::sqrt(norm_sq);
    double sum = 0.0;  // sum_i |a_i| / |a|, at most sqrt(n)
    for (const double a : weights)
    {
        sum += std::abs(a) / norm;
    }
    // Rounding to the nearest multiple of h errs by at most h / 2 per weight: h = 2 resolution / n
    // keeps the shift e within the resolution. The table has Q ~ sum / h entries and the
    // counting costs about n Q / 2: beyond kMaxWork (some 470 equal weights at the default
    // resolution) nothing is counted and the formula bound stands alone.
    const auto n = static_cast<double>(nonzero);
    const double step = 2.0 * resolution / n;
    if (n * sum / step / 2.0 > kMaxWork)
    {
        return;
    }
    inverse_step_ = 1.0 / step;
    std::vector<std::int64_t> units;
    units.reserve(nonzero);
    std::int64_t total = 0;
    for (const double a : weights)
    {
        const double u = std::abs(a) / norm;
        const auto q = static_cast<std::int64_t>(std::llround(u * inverse_step_));
        slack_ += std::abs(u - static_cast<double>(q) * step);
        if (q > 0)
        {
            units.push_back(q);
            total += q;
        }
    }
    // Smallest first: each step spans the sums reachable so far, and small steps first keep
    // those spans short (about a third less work than in coefficient order for normal weights).
    std::sort(units.begin(), units.end());
    // The distribution of the sum of q_i over the positive signs, one weight at a time:
    // P_next(s) = (P(s) + P(s - q)) / 2 over the sums reachable so far (0 .. top + q). Both
    // buffers start at 0 and each step writes 0 .. its new top, so past the current top the
    // source still holds zeros. (Counting in place from the top down, in one buffer, was twice
    // as fast alone but made whole detections 25% slower, measured and not understood: kept
    // out.)
    std::vector<double> mass(static_cast<std::size_t>(total) + 1, 0.0);
    std::vector<double> next(mass.size(), 0.0);
    mass[0] = 1.0;
    std::size_t top = 0;
    for (const std::int64_t q64 : units)
    {
        const auto q = static_cast<std::size_t>(q64);
        for (std::size_t s = 0; s < q; ++s)
        {
            next[s] = 0.5 * mass[s];
        }
        for (std::size_t s = q; s <= top + q; ++s)
        {
            next[s] = 0.5 * (mass[s] + mass[s - q]);
        }
        top += q;
        mass.swap(next);
    }
    // Tails summed from the largest sum down, the small terms first. Only the upper half is
    // kept (a score z > 0 asks for k > Q / 2 but for the rounding's slack, which below half
    // reads as 1): a family key's trace of a resampled suspect keeps 26 such tables.
    total_ = static_cast<std::size_t>(total);
    first_ = total_ / 2;
    at_least_.assign(total_ - first_ + 2, 0.0);
    for (std::size_t k = total_ + 1; k-- > first_;)
    {
        at_least_[k - first_] = at_least_[k - first_ + 1] + mass[k];
    }
}

double RademacherTail::operator()(double z) const
{
    if (!(z > 0.0) || at_least_.empty())
    {
        return 1.0;
    }
    // sum_i s_i a_i / |a| >= z implies h sum_i s_i q_i >= z - e, i.e. (with Q = sum_i q_i and
    // S the sum of q_i over the positive signs, sum_i s_i q_i = 2 S - Q) S >= ((z - e) / h + Q) / 2.
    const auto total = static_cast<double>(total_);
    const double at = 0.5 * ((z - slack_) * inverse_step_ + total);
    // A hair lower: a threshold that lands on an integer by rounding must not skip it.
    const double k = std::ceil(at - 1e-9 * std::max(1.0, std::abs(at)));
    if (k <= static_cast<double>(first_))
    {
        return 1.0;
    }
    if (k > total)
    {
        return 0.0;
    }
    // The recursion's halved sums and the tail's running sum round by at most an ulp per
    // addition, about (n + Q) ulps relative in all (< 3e-11 within kMaxWork): a relative
    // margin of 1e-9 covers them.
    return std::min(1.0, at_least_[static_cast<std::size_t>(k) - first_] * (1.0 + 1e-9));
}

double rademacher_tail_bound(double z)
{
    if (!(z > 0.0))
    {
        return 1.0;
    }
    // Hoeffding: P(S >= z |a|) <= exp(-z^2 / 2). Pinelis: P(S >= z |a|) <= c (1 - Phi(z)) with
    // c = 2 e^3 / 9 ~ 4.46, tighter beyond z ~ 3.3. Both hold for every weight vector a.
    const double hoeffding = std::exp(-0.5 * z * z);
    const double pinelis = 2.0 * std::exp(3.0) / 9.0 * 0.5 * std::erfc(z / std::sqrt(2.0));
    return std::min({1.0, hoeffding, pinelis});
}

double binomial_tail_half(int n, int k)
{
    if (k <= 0)
    {
        return 1.0;
    }
    if (k > n)
    {
        return 0.0;
    }
    // Sum of C(n, i) / 2^n for i >= k, in log space to stay exact enough for any n.
    double total = 0.0;
    for (int i = k; i <= n; ++i)
    {
        const double log_term = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) -
                                n * std::log(2.0);
        total += std::exp(log_term);
    }
    return std::min(1.0, total);
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
    decision.bits_false_positive_probability = binomial_tail_half(decision.bit_count, decision.matches);

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
            if (std::find(extraction.further_weightings.begin(), extraction.further_weightings.end(), l) ==
                extraction.further_weightings.end())
            {
                damped.push_back(extraction.further_changes[l]);
            }
        }
    }
    const bool damped_only = !damped.empty();  // else (no damped reading) every statistic
    const SoftCorrelation soft(extraction.normalized_change, extraction.weights,
                               damped_only ? damped : extraction.further_changes, !damped_only, threads_);
    decision.coefficient_count = static_cast<int>(soft.size());
    decision.statistic_count = soft.statistic_count();
    const SoftScore scored = soft.score(
        [&](std::size_t c) { return signs_(static_cast<Eigen::Index>(c / 3), static_cast<Eigen::Index>(c % 3)); });
    decision.score = scored.z;
    decision.score_tail = scored.tail;
    decision.score_false_positive_probability = scored.probability;
    if (extraction.unread_statistics > 0)
    {
        // Paid for as if computed: the score is the best of a subset of them.
        decision.statistic_count += extraction.unread_statistics;
        decision.score_false_positive_probability = std::min(1.0, decision.statistic_count * scored.tail);
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
        decision.false_positive_probability =
            std::min({1.0, decision.score_false_positive_probability * score_level_factor(options.verdict),
                      decision.bits_false_positive_probability / kBitCountShare});
        decision.is_present = decision.false_positive_probability <= options.max_false_positive;
        break;
    }
    return decision;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// The verdicts and their statistics: the null model, the soft, combined and bits rules, the
// Rademacher bound and counted tails, the binomial tail.
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"
#include "watermark/nuisance.h"
#include "watermark_test_support.h"

namespace meshmark
{

using test::make_key;

// The verdict's bound must hold for suspects that do not carry the key's mark: over many keys,
// the share of an unmarked (noisy) copy's verdicts with a probability of at most alpha never
// exceeds alpha (docs/statistics.md has the 10,000-key study on the real meshes).
TEST(SpectralWatermarkTest, scores_of_unmarked_copies_follow_the_null_model)
{
    const TriangleMesh mesh = lumpy_ellipsoid(3);
    const double D = bounding_box(mesh.V).diagonal();
    Rng rng(11);
    Positions noisy = mesh.V;
    for (Eigen::Index i = 0; i < noisy.size(); ++i)
    {
        noisy.data()[i] += rng.uniform(-2e-3, 2e-3) * D;
    }
    const int trials = 120;
    double sum = 0.0;
    int below_half = 0;
    int below_tenth = 0;
    int positive = 0;
    int claimed = 0;
    for (int t = 0; t < trials; ++t)
    {
        const SpectralWatermark mark(mesh, make_key(mesh, 7000 + static_cast<std::uint64_t>(t)));
        const DetectOptions options;
        const Decision d = mark.decide(Detector(mark, mesh).extract(noisy, options), options);
        sum += d.score;
        positive += d.score > 0.0 ? 1 : 0;
        below_half += d.false_positive_probability <= 0.5 ? 1 : 0;
        below_tenth += d.false_positive_probability <= 0.1 ? 1 : 0;
        claimed += d.is_present ? 1 : 0;
    }
    // The best of three N(0, 1) scores: mean about 0.6 when they are correlated as here.
    EXPECT_GT(sum / trials, 0.0);
    EXPECT_LT(sum / trials, 1.2);
    EXPECT_GT(positive, trials / 3);  // the scores are not degenerate
    EXPECT_LE(below_half, 60 + 17);   // alpha = 0.5: at most 60 expected, + 3 sigma
    EXPECT_LE(below_tenth, 12 + 10);  // alpha = 0.1: at most 12 expected, + 3 sigma
    EXPECT_EQ(claimed, 0);
}

// Every coefficient's sign right but the magnitudes uneven (an attack that leaves a few
// coefficients far larger than the rest, as a bisection does): the score stays below 5, which
// the formula bound refuses whatever the weights, but a sum of random signs with these weights
// reaches it only when nearly every sign agrees, and the counted tail claims.
// An extraction of \p mark's coefficients with unit weights and changes value(c, embedded sign).
template <class Value>
Extraction unit_weight_extraction(const SpectralWatermark& mark, Value value)
{
    const auto coefficients = static_cast<std::size_t>(mark.embedded_signs().size());
    Extraction e;
    e.weights.assign(coefficients, 1.0);
    for (std::size_t c = 0; c < coefficients; ++c)
    {
        e.normalized_change.push_back(
            value(c, mark.embedded_signs()(static_cast<Eigen::Index>(c / 3),
                                           static_cast<Eigen::Index>(c % 3))));
    }
    return e;
}

TEST(SpectralWatermarkTest, soft_verdict_claims_every_sign_right_with_uneven_magnitudes)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 9));
    Extraction e = unit_weight_extraction(
        mark, [](std::size_t c, double sign) { return sign * (c % 7 == 0 ? 30.0 : 0.2); });
    e.bits_found.assign(mark.key().payload.size(), 2);  // no bit decided: the score alone
    DetectOptions correlation;
    correlation.verdict = VerdictRule::Correlation;
    const Decision soft = mark.decide(e, correlation);
    EXPECT_LT(soft.score, 5.0);
    EXPECT_GT(3.0 * rademacher_tail_bound(soft.score), 1e-6) << "the formula alone refuses";
    EXPECT_TRUE(soft.is_present);
    // (Measured: z 3.89, tail 1.3e-29: the 14 large coefficients and nearly every small one must
    // agree.)
    EXPECT_LT(soft.score_tail, 1e-15);
    EXPECT_TRUE(mark.decide(e, DetectOptions{}).is_present);
}

// Every payload bit read right while the coefficients look like noise to the soft score: the
// combined verdict claims through the bit count (2^-24, times 16); one bit wrong, it refuses.
TEST(SpectralWatermarkTest, combined_verdict_claims_a_perfect_bit_read_the_score_refuses)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 9));
    Rng rng(4);
    Extraction e = unit_weight_extraction(mark, [&](std::size_t, double) { return rng.normal(); });
    for (const std::uint8_t bit : mark.key().payload)
    {
        e.bits_found.push_back(bit);
    }
    DetectOptions correlation;
    correlation.verdict = VerdictRule::Correlation;
    const Decision soft = mark.decide(e, correlation);
    EXPECT_LT(soft.score, 3.0);
    EXPECT_FALSE(soft.is_present);
    const Decision combined = mark.decide(e, DetectOptions{});
    EXPECT_EQ(combined.score, soft.score);
    EXPECT_EQ(combined.matches, combined.bit_count);
    EXPECT_NEAR(combined.false_positive_probability / (16.0 * std::pow(0.5, 24)), 1.0, 1e-12);
    EXPECT_TRUE(combined.is_present);
    e.bits_found[0] = 1 - e.bits_found[0];
    EXPECT_FALSE(mark.decide(e, DetectOptions{}).is_present);  // 25 / 2^24 * 16 > 1e-6
}

TEST(SpectralWatermarkTest, bits_verdict_is_the_papers_rule)
{
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    const SpectralWatermark mark(mesh, make_key(mesh, 8));
    DetectOptions options;
    options.verdict = VerdictRule::Bits;
    const Decision d =
        mark.decide(Detector(mark, mesh).extract(mesh.V + mark.displacement(), options), options);
    EXPECT_TRUE(d.is_present);
    EXPECT_EQ(d.verdict, VerdictRule::Bits);
    EXPECT_EQ(d.false_positive_probability, d.bits_false_positive_probability);
    options.threshold = 1.0;
    EXPECT_TRUE(
        mark.decide(Detector(mark, mesh).extract(mesh.V + mark.displacement(), options), options)
            .is_present);
    EXPECT_FALSE(mark.decide(Detector(mark, mesh).extract(mesh.V, options), options).is_present);
    EXPECT_EQ(parse_verdict_rule("bits"), VerdictRule::Bits);
    EXPECT_EQ(parse_verdict_rule(to_string(VerdictRule::Correlation)), VerdictRule::Correlation);
    EXPECT_EQ(parse_verdict_rule(to_string(VerdictRule::Combined)), VerdictRule::Combined);
    EXPECT_THROW((void)parse_verdict_rule("R"), InvalidOption);
    options.max_false_positive = 0.0;
    EXPECT_THROW(options.validate(), InvalidOption);
}

// For equal weights the sum of n random signs is 2 Bin(n, 1/2) - n, so the exact tail is known:
// the bound must never fall below it, and must be reasonably tight in the range that matters.
TEST(RademacherBoundTest, never_below_the_exact_tail_of_equal_weights)
{
    for (const int n : {8, 24, 48, 96, 192})
    {
        for (int k = n / 2; k <= n; ++k)
        {
            const double z = (2.0 * k - n) / std::sqrt(static_cast<double>(n));
            const double exact = binomial_tail_half(n, k);
            EXPECT_GE(rademacher_tail_bound(z), exact * (1.0 - 1e-12)) << n << " " << k;
        }
    }
    EXPECT_EQ(rademacher_tail_bound(0.0), 1.0);
    EXPECT_EQ(rademacher_tail_bound(-3.0), 1.0);
    EXPECT_NEAR(rademacher_tail_bound(1.0), std::exp(-0.5), 1e-15);  // Hoeffding below z ~ 3.3
    // Pinelis beyond: (2 e^3 / 9) (1 - Phi(6)) = 4.4634 * 9.866e-10.
    EXPECT_NEAR(rademacher_tail_bound(6.0) / 4.4036e-9, 1.0, 1e-3);
    // Within a factor 5 of the normal tail at the default level (z ~ 5).
    EXPECT_LT(rademacher_tail_bound(5.0), 5.0 * 0.5 * std::erfc(5.0 / std::sqrt(2.0)));
}

// Equal weights: the sum is 2 Bin(n, 1/2) - n, so the computed tail must be the binomial tail
// exactly at every attainable score, and a score between two attainable ones (more than the
// resolution past one) must get the next one's tail: not the formula's, 1.9-4.5 times larger.
TEST(RademacherTailTest, is_the_binomial_tail_for_equal_weights)
{
    for (const int n : {8, 24, 96, 120})
    {
        const RademacherTail tail(std::vector<double>(static_cast<std::size_t>(n), 0.7));
        EXPECT_LE(tail.slack(), 0.02);
        for (int k = n / 2 + 1; k <= n; ++k)
        {
            const double z = (2.0 * k - n) / std::sqrt(static_cast<double>(n));
            const double exact = binomial_tail_half(n, k);
            EXPECT_GE(tail(z), exact * (1.0 - 1e-12)) << n << " " << k;
            EXPECT_LE(tail(z), binomial_tail_half(n, k - 1) * (1.0 + 1e-8)) << n << " " << k;
            if (k < n)
            {
                EXPECT_NEAR(tail(z + 0.03) / binomial_tail_half(n, k + 1), 1.0, 1e-8)
                    << n << " " << k;
            }
        }
        EXPECT_EQ(tail(std::sqrt(static_cast<double>(n)) + 0.03), 0.0)
            << "beyond every sign agreeing";
    }
    // 120 coefficients at z = 5: P(Bin(120, 1/2) >= 88) = 1.5e-7 against the formula's 1.3e-6.
    const RademacherTail tail(std::vector<double>(120, 1.0));
    EXPECT_NEAR(tail(5.0) / binomial_tail_half(120, 88), 1.0, 1e-8);
    EXPECT_LT(tail(5.0), rademacher_tail_bound(5.0) / 4.0);
    EXPECT_EQ(tail(0.0), 1.0);
    EXPECT_EQ(tail(-2.0), 1.0);
    EXPECT_EQ(RademacherTail(std::vector<double>(10, 0.0))(1.0), 1.0);
    EXPECT_THROW(RademacherTail(std::vector<double>(4, 1.0), 0.0), InvalidOption);
}

// Uneven weights, signs and zeros: every one of the 2^16 sign vectors counted. The computed
// tail is never below the exact one and never above the exact tail one resolution lower.
TEST(RademacherTailTest, brackets_the_exact_tail_of_any_weights)
{
    Rng rng(3);
    for (int trial = 0; trial < 6; ++trial)
    {
        std::vector<double> a(16);
        for (double& v : a)
        {
            v = trial % 2 == 0 ? rng.normal() : std::exp(2.0 * rng.normal());  // heavy tails too
        }
        a[5] = 0.0;
        double norm_sq = 0.0;
        for (const double v : a)
        {
            norm_sq += v * v;
        }
        std::vector<double> sums;
        for (std::uint32_t signs = 0; signs < (1U << 16U); ++signs)
        {
            double sum = 0.0;
            for (std::size_t i = 0; i < a.size(); ++i)
            {
                sum += ((signs >> i) & 1U) != 0 ? a[i] : -a[i];
            }
            sums.push_back(sum / std::sqrt(norm_sq));
        }
        auto exact = [&](double z)
        {
            return static_cast<double>(
                       std::count_if(sums.begin(), sums.end(), [z](double s) { return s >= z; })) /
                   static_cast<double>(sums.size());
        };
        const RademacherTail tail(a);
        for (double z = 0.25; z < 4.2; z += 0.05)
        {
            EXPECT_GE(tail(z), exact(z) * (1.0 - 1e-12)) << trial << " " << z;
            EXPECT_LE(tail(z), exact(z - 0.02 - 1e-9) * (1.0 + 1e-8)) << trial << " " << z;
        }
        // Each attainable sum: its own tail is at least 2^-16 (the sign vector that gave it).
        EXPECT_GE(tail(*std::max_element(sums.begin(), sums.end())), std::pow(0.5, 16));
    }
}

// 48 weights like an extraction's |x_c| (normal values), 4 million sign vectors drawn: at the
// scores where the counted tail is 1e-3 and 1e-4, the share of draws reaching them lies within
// 4 standard deviations of [the tail one resolution up, the counted tail].
TEST(RademacherTailTest, agrees_with_sampled_signs_for_48_normal_weights)
{
    Rng rng(11);
    std::vector<double> a(48);
    double norm_sq = 0.0;
    for (double& v : a)
    {
        v = rng.normal();
        norm_sq += v * v;
    }
    const RademacherTail tail(a);
    auto score_at = [&](double level) {  // the smallest z on a 0.001 grid with tail(z) <= level
        double z = 0.0;
        while (tail(z) > level)
        {
            z += 0.001;
        }
        return z;
    };
    const std::array<double, 2> levels{1e-3, 1e-4};
    std::array<double, 2> at{score_at(levels[0]), score_at(levels[1])};
    std::array<double, 2> hits{};
    std::array<double, 2>
        hits_up{};  // at z + 0.021: the counted tail there bounds these from above
    const double norm = std::sqrt(norm_sq);
    constexpr int kDraws = 4'000'000;
    for (int d = 0; d < kDraws; ++d)
    {
        const std::uint64_t bits = rng.bits();
        double sum = 0.0;
        for (std::size_t i = 0; i < a.size(); ++i)
        {
            sum += ((bits >> i) & 1U) != 0 ? a[i] : -a[i];
        }
        sum /= norm;
        for (std::size_t l = 0; l < levels.size(); ++l)
        {
            hits[l] += sum >= at[l] ? 1.0 : 0.0;
            hits_up[l] += sum >= at[l] + 0.021 ? 1.0 : 0.0;
        }
    }
    for (std::size_t l = 0; l < levels.size(); ++l)
    {
        const double p = tail(at[l]);
        const double sigma = std::sqrt(p * kDraws);
        EXPECT_LE(hits[l], p * kDraws + 4.0 * sigma)
            << "the counted tail is below the sampled share at " << at[l];
        // One resolution up, the exact tail is at most the counted one here: the sampled share
        // there may not exceed it, and the counted tail must not be far above the share below.
        EXPECT_LE(hits_up[l], p * kDraws + 4.0 * sigma);
        EXPECT_GE(hits[l], tail(at[l] + 0.021) * kDraws - 4.0 * sigma)
            << "the counted tail is loose at " << at[l];
    }
}

// Weights too many to count within RademacherTail::kMaxWork: the tail is 1 and a soft
// correlation over them falls back on the formula bound alone.
TEST(RademacherTailTest, leaves_too_many_weights_to_the_formula)
{
    EXPECT_TRUE(RademacherTail(std::vector<double>(400, 1.0)).is_counted());
    const RademacherTail many(std::vector<double>(600, 1.0));
    EXPECT_FALSE(many.is_counted());
    EXPECT_EQ(many(5.0), 1.0);
    std::vector<double> x(600, 1.0);
    const SoftCorrelation soft(x, std::vector<double>(600, 1.0));
    const SoftScore scored = soft.score([](std::size_t) { return 1.0; });
    EXPECT_NEAR(scored.z, std::sqrt(600.0), 1e-9);
    EXPECT_DOUBLE_EQ(scored.tail, rademacher_tail_bound(scored.z));
    EXPECT_DOUBLE_EQ(scored.probability, 3.0 * rademacher_tail_bound(scored.z));
}

// The statistics' tails are counted on several threads: the same score, tail and probability
// as on one, bit for bit, for uneven weights, several readings and signs mostly right.
TEST(SoftCorrelationTest, counts_the_same_tails_on_any_number_of_threads)
{
    Rng rng(0x7A11);
    const std::size_t n = 120;
    std::vector<double> x(n);
    std::vector<double> w(n);
    std::vector<std::vector<double>> damped(4, std::vector<double>(n));
    for (std::size_t c = 0; c < n; ++c)
    {
        x[c] = 1.0 + rng.normal();
        w[c] = 0.1 + rng.uniform() * 4.0;
        for (std::vector<double>& reading : damped)
        {
            reading[c] = 0.8 + 1.5 * rng.normal();
        }
    }
    const auto sign = [](std::size_t c) { return c % 7 == 3 ? -1.0 : 1.0; };
    const SoftScore one = SoftCorrelation(x, w, damped, true, 1).score(sign);
    EXPECT_GT(one.z, 4.0);
    EXPECT_LT(one.tail, 0.1 * rademacher_tail_bound(one.z)) << "the counted tail, not the formula";
    for (const int threads : {2, 3, 7})
    {
        const SoftScore many = SoftCorrelation(x, w, damped, true, threads).score(sign);
        EXPECT_EQ(many.z, one.z) << threads;
        EXPECT_EQ(many.tail, one.tail) << threads;
        EXPECT_EQ(many.probability, one.probability) << threads;
    }
}

TEST(BinomialTest, tail_matches_direct_sums)
{
    EXPECT_DOUBLE_EQ(binomial_tail_half(24, 0), 1.0);
    EXPECT_NEAR(binomial_tail_half(24, 24), std::pow(0.5, 24), 1e-22);
    EXPECT_NEAR(binomial_tail_half(24, 18), 190051.0 / 16777216.0, 1e-14);
    EXPECT_NEAR(binomial_tail_half(4, 2), 11.0 / 16.0, 1e-15);
    EXPECT_EQ(binomial_tail_half(24, 25), 0.0);
}

}  // namespace meshmark

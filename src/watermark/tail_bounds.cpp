// SPDX-License-Identifier: MIT
// Tail bounds of weighted sums of random signs: counted for the weights at hand
// (RademacherTail), the formula bound for any weights, and the binomial tail of the bit count.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/watermark/decision.h"

namespace meshmark
{

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
    // S the sum of q_i over the positive signs, sum_i s_i q_i = 2 S - Q) S >= ((z - e) / h + Q)
    // / 2.
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
        const double log_term = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) -
                                std::lgamma(n - i + 1.0) - n * std::log(2.0);
        total += std::exp(log_term);
    }
    return std::min(1.0, total);
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/verdict.h"

#include <array>
#include <cmath>
#include <cstdio>

namespace meshmark {

Verdict verdict_of(const DetectReport& report, double max_false_positive)
{
    Verdict v;
    v.max_false_positive_probability = max_false_positive;
    v.traced = report.recipients_traced > 0;
    if (!v.traced)
    {
        v.claimed = report.decision.is_present;
        v.false_positive_probability = report.decision.false_positive_probability;
        return v;
    }
    for (const RecipientScore& r : report.accused)
    {
        v.accused.push_back(r.name);
    }
    v.claimed = report.detected();
    v.false_positive_probability = report.accused.empty() ? report.owner_false_positive_probability
                                                          : report.accused.front().false_positive_probability;
    return v;
}

namespace {

// \p value with two significant digits, thousands grouped below a million ("12,000", "950").
std::string grouped(double value)
{
    const double magnitude = std::pow(10.0, std::floor(std::log10(value)) - 1.0);
    const auto rounded = static_cast<long long>(std::llround(std::round(value / magnitude) * magnitude));
    const std::string digits = std::to_string(rounded);
    std::string out;
    for (std::size_t i = 0; i < digits.size(); ++i)
    {
        if (i > 0 && (digits.size() - i) % 3 == 0)
        {
            out.push_back(',');
        }
        out.push_back(digits[i]);
    }
    return out;
}

// \p value (1 to 1000) with two significant digits and no trailing ".0": "5.4", "12", "500".
std::string two_digits(double value)
{
    const double magnitude = std::pow(10.0, std::floor(std::log10(value)) - 1.0);
    const double rounded = std::round(value / magnitude) * magnitude;
    std::array<char, 32> text{};
    std::snprintf(text.data(), text.size(), rounded >= 10.0 ? "%.0f" : "%.1f", rounded);
    std::string out = text.data();
    if (out.ends_with(".0"))
    {
        out.resize(out.size() - 2);
    }
    return out;
}

}  // namespace

std::string one_in(double p)
{
    if (!(p < 1.0))
    {
        return "every time";
    }
    if (p < 1e-300)
    {
        return "less than 1 in 10^300";
    }
    const double n = 1.0 / p;
    std::array<char, 64> text{};
    if (n < 10.0)
    {
        std::snprintf(text.data(), text.size(), "1 in %.1f", n);
        return text.data();
    }
    if (n < 1e6)
    {
        return "1 in " + grouped(n);
    }
    static constexpr std::array<const char*, 3> kNames = {"million", "billion", "trillion"};
    const int thousands = static_cast<int>(std::floor(std::log10(n) / 3.0));  // 2 = millions
    if (thousands - 2 < static_cast<int>(kNames.size()))
    {
        return "1 in " + two_digits(n / std::pow(10.0, 3.0 * thousands)) + " " +
               kNames[static_cast<std::size_t>(thousands - 2)];
    }
    const int exponent = static_cast<int>(std::floor(std::log10(n)));
    return "1 in " + two_digits(n / std::pow(10.0, exponent)) + " x 10^" + std::to_string(exponent);
}

std::string headline(const Verdict& verdict)
{
    std::array<char, 32> p{};
    std::snprintf(p.data(), p.size(), "%.2g", verdict.false_positive_probability);
    std::string out;
    if (verdict.claimed)
    {
        out = "Claimed: a copy of the original";
        if (!verdict.accused.empty())
        {
            out += verdict.accused.size() == 1 ? ", made from the copy issued to " : ", made from the copies issued to ";
            for (std::size_t i = 0; i < verdict.accused.size(); ++i)
            {
                if (i > 0)
                {
                    out.append(i + 1 == verdict.accused.size() ? " and " : ", ");
                }
                out.append(verdict.accused[i]);
            }
        }
        else if (verdict.traced)
        {
            out += " (no recipient's copy named: none of their codes reads strongly enough)";
        }
        out += ". The chance that a mesh without this mark gives this result is at most " +
               one_in(verdict.false_positive_probability) + " (" + p.data() + ").";
        return out;
    }
    std::array<char, 32> bound{};
    std::snprintf(bound.data(), bound.size(), "%.2g", verdict.max_false_positive_probability);
    const std::string times = verdict.false_positive_probability < 1.0 ? " times" : "";
    out = "Not shown: the mark is not read strongly enough to claim this copy. Chance alone gives a reading this "
          "strong " +
          one_in(verdict.false_positive_probability) + times + " (" + p.data() + "); a claim needs at most " +
          one_in(verdict.max_false_positive_probability) + " (" + bound.data() + ").";
    return out;
}

}  // namespace meshmark

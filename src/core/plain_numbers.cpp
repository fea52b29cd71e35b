// SPDX-License-Identifier: MIT
#include "meshmark/core/plain_numbers.h"

#include <array>
#include <cmath>
#include <cstdio>

namespace meshmark
{
namespace
{

std::string one_decimal(double value)
{
    std::array<char, 64> text{};
    std::snprintf(text.data(), text.size(), "%.1f", value);
    return text.data();
}

}  // namespace

std::string grouped_digits(std::uintmax_t value)
{
    // Appended, not inserted: GCC 12 warns (-Wrestrict) on string::insert of a literal here.
    const std::string digits = std::to_string(value);
    std::string out;
    for (std::size_t i = 0; i < digits.size(); ++i)
    {
        if (i > 0 && (digits.size() - i) % 3 == 0)
        {
            out += ',';
        }
        out += digits[i];
    }
    return out;
}

std::string one_in(double p)
{
    if (!(p < 1.0))
    {
        return "1 in 1";  // also NaN: no evidence
    }
    if (!(p >= 1e-300))
    {
        return "less than 1 in 10^300";
    }
    // N = 1/p to two significant digits: m x 10^(e-1), m in [10, 99].
    const double n = 1.0 / p;
    int e = static_cast<int>(std::floor(std::log10(n)));
    auto m = static_cast<long long>(std::llround(n / std::pow(10.0, e - 1)));
    if (m >= 100)
    {
        m /= 10;
        ++e;
    }
    const auto mantissa = [](long long digits, int decimals_shift)
    {
        // digits / 10^decimals_shift with at most one decimal, ".0" dropped.
        const double value = static_cast<double>(digits) / std::pow(10.0, decimals_shift);
        return std::fmod(value, 1.0) == 0.0 ? std::to_string(static_cast<long long>(value))
                                            : one_decimal(value);
    };
    if (e < 1)
    {
        return "1 in " + mantissa(m, 1);
    }
    if (e < 6)
    {
        return "1 in " +
               grouped_digits(static_cast<std::uintmax_t>(m) *
                              static_cast<std::uintmax_t>(std::llround(std::pow(10.0, e - 1))));
    }
    if (e < 15)
    {
        static const char* const kUnits[] = {"million", "billion", "trillion"};
        const int group = e / 3;  // 2, 3, 4
        return "1 in " + mantissa(m, 1 - (e - 3 * group)) + " " + kUnits[group - 2];
    }
    return "1 in " + (m == 10 ? std::string() : mantissa(m, 1) + " \u00d7 ") + "10^" +
           std::to_string(e);
}

}  // namespace meshmark

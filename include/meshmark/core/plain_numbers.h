// SPDX-License-Identifier: MIT
#pragma once

/// \file
/// \brief Numbers as a reader without statistics reads them (the verdict's sentence, the
/// evidence report).

#include <cstdint>
#include <string>

namespace meshmark
{

/// \brief \p value with its thousands grouped: "12,345,678".
[[nodiscard]] std::string grouped_digits(std::uintmax_t value);

/// \brief How often a chance of \p p comes true, as "1 in N": N = 1/p to two significant digits
/// in words ("1 in 90", "1 in 12,000", "1 in 3.2 billion", "1 in 4.5 × 10^21", "1 in 10^15");
/// "less than 1 in 10^300" below 1e-300 (and for 0); "1 in 1" for p >= 1 and NaN.
[[nodiscard]] std::string one_in(double p);

}  // namespace meshmark

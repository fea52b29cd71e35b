// SPDX-License-Identifier: MIT
// Private helper: numbers in messages and attack specs.
#pragma once

#include <charconv>
#include <string>

namespace meshmark::detail
{

/// Shortest text that reads back to exactly \p value (std::to_chars, locale-independent).
inline std::string format_number(double value)
{
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
    return {buffer, result.ptr};
}

}  // namespace meshmark::detail

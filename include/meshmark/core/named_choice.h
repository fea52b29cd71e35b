// SPDX-License-Identifier: MIT
#pragma once

#include <initializer_list>
#include <string>
#include <utility>

#include "meshmark/core/error.h"

namespace meshmark
{

/// \brief The value named \p name among \p choices (name, value pairs).
/// \throws InvalidOption "unknown WHAT 'NAME' (expected a, b or c)." when no choice has that name.
/// \details Shared by the option parsers of the embedding rule, basis, centers and verdict.
template <class Value>
[[nodiscard]] Value parse_named_choice(const std::string& name, const char* what,
                                       std::initializer_list<std::pair<const char*, Value>> choices)
{
    std::string expected;
    std::size_t index = 0;
    for (const auto& [choice, value] : choices)
    {
        if (name == choice)
        {
            return value;
        }
        if (index > 0)
        {
            expected += index + 1 == choices.size() ? " or " : ", ";
        }
        expected += choice;
        ++index;
    }
    throw InvalidOption("unknown " + std::string(what) + " '" + name + "' (expected " + expected +
                        ").");
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "report.h"

#include <array>
#include <charconv>
#include <cstdio>
#include <iostream>

namespace meshmark::cli
{

void print_json(const nlohmann::json& object)
{
    std::cout << object.dump() << std::endl;
}

std::string format_number(double value, int digits)
{
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.*g", digits, value);
    return buffer;
}

std::string shell_word(const std::string& word)
{
    const bool is_safe = !word.empty() && word.find_first_not_of(
                                              "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-+=.,/:@%") == std::string::npos;
    if (is_safe)
    {
        return word;
    }
    std::string out = "'";
    for (const char c : word)
    {
        out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    }
    return out + "'";
}

std::string shortest(double value)
{
    std::array<char, 32> text{};
    const auto end = std::to_chars(text.data(), text.data() + text.size(), value).ptr;
    return {text.data(), end};
}

}  // namespace meshmark::cli

// SPDX-License-Identifier: MIT
#pragma once

// Internal to the attacks module: one step of an attack spec (`NAME[=LEVEL][:KEY=VALUE]...`)
// read into its name, level and keys, each read checked (attack_spec.cpp).

#include <charconv>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "attacks/detail/format.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

inline std::string_view trim(std::string_view s)
{
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t'))
    {
        s.remove_prefix(1);
    }
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t'))
    {
        s.remove_suffix(1);
    }
    return s;
}

inline std::vector<std::string_view> split(std::string_view s, char separator)
{
    std::vector<std::string_view> parts;
    std::size_t start = 0;
    while (true)
    {
        const std::size_t end = s.find(separator, start);
        parts.push_back(trim(s.substr(start, end - start)));
        if (end == std::string_view::npos)
        {
            return parts;
        }
        start = end + 1;
    }
}

inline std::string quoted(std::string_view s)
{
    // Appended piece by piece: GCC 12 reports a false -Wrestrict on "'" + std::string(s).
    std::string result(1, '\'');
    result.append(s);
    result += '\'';
    return result;
}

// One step of a spec, split into name, optional level and keys. Every read either succeeds
// or throws InvalidOption naming the step; finish() rejects keys nobody read.
class StepReader
{
public:
    explicit StepReader(std::string_view text) : text_(text)
    {
        if (text.empty())
        {
            throw InvalidOption(
                "Empty attack step in the attack spec (two commas in a row, or a "
                "comma at an end?).");
        }
        const auto parts = split(text, ':');
        const std::size_t equals = parts.front().find('=');
        name_ = trim(parts.front().substr(0, equals));
        if (equals != std::string_view::npos)
        {
            level_ = trim(parts.front().substr(equals + 1));
            if (level_->empty())
            {
                fail("the level after '=' is missing.");
            }
        }
        for (std::size_t i = 1; i < parts.size(); ++i)
        {
            const std::size_t eq = parts[i].find('=');
            if (parts[i].empty() || eq == std::string_view::npos || eq == 0 ||
                eq + 1 == parts[i].size())
            {
                fail("expected KEY=VALUE after ':' but found " + quoted(parts[i]) + ".");
            }
            const auto key = trim(parts[i].substr(0, eq));
            for (const auto& [known, value] : keys_)
            {
                if (known == key)
                {
                    fail("the key " + quoted(key) + " is given twice.");
                }
            }
            keys_.emplace_back(key, trim(parts[i].substr(eq + 1)));
        }
        is_used_.assign(keys_.size(), false);
    }

    [[nodiscard]] std::string_view name() const { return name_; }
    [[nodiscard]] std::optional<std::string_view> level() const { return level_; }

    [[noreturn]] void fail(const std::string& problem) const
    {
        throw InvalidOption("Bad attack step " + quoted(text_) + ": " + problem);
    }

    void forbid_level() const
    {
        if (level_)
        {
            fail(std::string(name_) + " takes no level (found " + quoted(*level_) + ").");
        }
    }

    [[nodiscard]] double number(std::string_view text, std::string_view what) const
    {
        std::string_view digits = text;
        if (!digits.empty() && digits.front() == '+')
        {
            digits.remove_prefix(1);
        }
        double value = 0.0;
        const auto [end, error] =
            std::from_chars(digits.data(), digits.data() + digits.size(), value);
        if (error != std::errc() || end != digits.data() + digits.size() || digits.empty())
        {
            fail(std::string(what) + " " + quoted(text) + " is not a number.");
        }
        return value;
    }

    [[nodiscard]] int integer(std::string_view text, std::string_view what) const
    {
        int value = 0;
        const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (error != std::errc() || end != text.data() + text.size() || text.empty())
        {
            fail(std::string(what) + " " + quoted(text) + " is not a whole number.");
        }
        return value;
    }

    // The level read as a number or a whole number; nullopt when the step has none.
    [[nodiscard]] std::optional<double> level_number(std::string_view what) const
    {
        return level_ ? std::optional<double>(number(*level_, what)) : std::nullopt;
    }

    [[nodiscard]] std::optional<int> level_integer(std::string_view what) const
    {
        return level_ ? std::optional<int>(integer(*level_, what)) : std::nullopt;
    }

    [[nodiscard]] std::optional<std::string_view> take(std::string_view key)
    {
        for (std::size_t i = 0; i < keys_.size(); ++i)
        {
            if (keys_[i].first == key)
            {
                is_used_[i] = true;
                return keys_[i].second;
            }
        }
        return std::nullopt;
    }

    [[nodiscard]] std::optional<double> take_number(std::string_view key)
    {
        const auto value = take(key);
        return value ? std::optional<double>(number(*value, "the value of " + quoted(key)))
                     : std::nullopt;
    }

    [[nodiscard]] std::optional<int> take_integer(std::string_view key)
    {
        const auto value = take(key);
        return value ? std::optional<int>(integer(*value, "the value of " + quoted(key)))
                     : std::nullopt;
    }

    // Reads a word among `choices` and returns its enumerator.
    template <typename E>
    [[nodiscard]] E choice(std::string_view word, std::string_view what,
                           std::initializer_list<std::pair<std::string_view, E>> choices) const
    {
        std::string allowed;
        for (const auto& [name, value] : choices)
        {
            if (word == name)
            {
                return value;
            }
            allowed += (allowed.empty() ? "" : ", ") + std::string(name);
        }
        fail(std::string(what) + " " + quoted(word) + " is not one of " + allowed + ".");
    }

    // The value of `key` read as a word among `choices`; nullopt when the key is absent.
    template <typename E>
    [[nodiscard]] std::optional<E> take_choice(
        std::string_view key, std::initializer_list<std::pair<std::string_view, E>> choices)
    {
        const auto word = take(key);
        return word ? std::optional<E>(choice(*word, key, choices)) : std::nullopt;
    }

    // Rejects keys that no reader took, listing the ones the attack accepts.
    void finish(std::string_view allowed) const
    {
        for (std::size_t i = 0; i < keys_.size(); ++i)
        {
            if (!is_used_[i])
            {
                fail("unknown key " + quoted(keys_[i].first) + " for " + std::string(name_) +
                     (allowed.empty() ? std::string(", which takes no keys.")
                                      : "; allowed keys: " + std::string(allowed) + "."));
            }
        }
    }

private:
    std::string_view text_;
    std::string_view name_;
    std::optional<std::string_view> level_;
    std::vector<std::pair<std::string_view, std::string_view>> keys_;
    std::vector<bool> is_used_;
};

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#include "io/detail/numbers.h"

#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>

namespace meshmark::detail
{
namespace
{

// std::byteswap is C++23; this is the C++20 equivalent over the object's bytes.
template <typename T>
T load_as(const char* p, bool is_big_endian) noexcept
{
    std::array<char, sizeof(T)> raw{};
    std::memcpy(raw.data(), p, sizeof(T));
    if (is_big_endian != (std::endian::native == std::endian::big))
    {
        for (std::size_t i = 0; i < sizeof(T) / 2; ++i)
        {
            std::swap(raw[i], raw[sizeof(T) - 1 - i]);
        }
    }
    T value{};
    std::memcpy(&value, raw.data(), sizeof(T));
    return value;
}

template <typename T>
void store_as(char* p, T value, bool is_big_endian) noexcept
{
    std::array<char, sizeof(T)> raw{};
    std::memcpy(raw.data(), &value, sizeof(T));
    if (is_big_endian != (std::endian::native == std::endian::big))
    {
        for (std::size_t i = 0; i < sizeof(T) / 2; ++i)
        {
            std::swap(raw[i], raw[sizeof(T) - 1 - i]);
        }
    }
    std::memcpy(p, raw.data(), sizeof(T));
}

// Round to the nearest integer of type T; false when the value is out of T's range.
template <typename T>
bool rounded(double value, T& result) noexcept
{
    const double r = std::nearbyint(value);
    if (!(r >= static_cast<double>(std::numeric_limits<T>::min()) &&
          r <= static_cast<double>(std::numeric_limits<T>::max())))
    {
        return false;
    }
    result = static_cast<T>(r);
    return true;
}

template <typename T>
bool store_rounded(char* p, double value, bool is_big_endian) noexcept
{
    T v{};
    if (!rounded(value, v))
    {
        return false;
    }
    store_as<T>(p, v, is_big_endian);
    return true;
}

template <typename T>
bool append_rounded(std::string& out, double value)
{
    T v{};
    if (!rounded(value, v))
    {
        return false;
    }
    std::array<char, 32> buffer{};
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
    out.append(buffer.data(), result.ptr);
    return true;
}

// from_chars rejects a leading '+', which some writers emit.
std::string_view without_plus(std::string_view token) noexcept
{
    if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+')
    {
        token.remove_prefix(1);
    }
    return token;
}

}  // namespace

std::size_t scalar_size(ScalarType type) noexcept
{
    switch (type)
    {
        case ScalarType::Int8:
        case ScalarType::UInt8:
            return 1;
        case ScalarType::Int16:
        case ScalarType::UInt16:
            return 2;
        case ScalarType::Int32:
        case ScalarType::UInt32:
        case ScalarType::Float32:
            return 4;
        case ScalarType::Float64:
            return 8;
    }
    return 0;
}

bool is_integer(ScalarType type) noexcept
{
    return type != ScalarType::Float32 && type != ScalarType::Float64;
}

std::optional<ScalarType> scalar_type_from_name(std::string_view name) noexcept
{
    struct Entry
    {
        std::string_view name;
        ScalarType type;
    };
    static constexpr std::array<Entry, 16> kNames{{
        {"char", ScalarType::Int8},
        {"int8", ScalarType::Int8},
        {"uchar", ScalarType::UInt8},
        {"uint8", ScalarType::UInt8},
        {"short", ScalarType::Int16},
        {"int16", ScalarType::Int16},
        {"ushort", ScalarType::UInt16},
        {"uint16", ScalarType::UInt16},
        {"int", ScalarType::Int32},
        {"int32", ScalarType::Int32},
        {"uint", ScalarType::UInt32},
        {"uint32", ScalarType::UInt32},
        {"float", ScalarType::Float32},
        {"float32", ScalarType::Float32},
        {"double", ScalarType::Float64},
        {"float64", ScalarType::Float64},
    }};
    for (const auto& entry : kNames)
    {
        if (entry.name == name)
        {
            return entry.type;
        }
    }
    return std::nullopt;
}

double load_scalar_any(const char* p, ScalarType type, bool is_big_endian) noexcept
{
    switch (type)
    {
        case ScalarType::Float32:
            return static_cast<double>(load_as<float>(p, is_big_endian));
        case ScalarType::Float64:
            return load_as<double>(p, is_big_endian);
        default:
            return static_cast<double>(load_integer(p, type, is_big_endian));
    }
}

std::int64_t load_integer(const char* p, ScalarType type, bool is_big_endian) noexcept
{
    switch (type)
    {
        case ScalarType::Int8:
            return load_as<std::int8_t>(p, is_big_endian);
        case ScalarType::UInt8:
            return load_as<std::uint8_t>(p, is_big_endian);
        case ScalarType::Int16:
            return load_as<std::int16_t>(p, is_big_endian);
        case ScalarType::UInt16:
            return load_as<std::uint16_t>(p, is_big_endian);
        case ScalarType::Int32:
            return load_as<std::int32_t>(p, is_big_endian);
        case ScalarType::UInt32:
            return load_as<std::uint32_t>(p, is_big_endian);
        case ScalarType::Float32:
        case ScalarType::Float64:
            break;
    }
    return 0;
}

bool store_scalar(char* p, ScalarType type, bool is_big_endian, double value) noexcept
{
    switch (type)
    {
        case ScalarType::Int8:
            return store_rounded<std::int8_t>(p, value, is_big_endian);
        case ScalarType::UInt8:
            return store_rounded<std::uint8_t>(p, value, is_big_endian);
        case ScalarType::Int16:
            return store_rounded<std::int16_t>(p, value, is_big_endian);
        case ScalarType::UInt16:
            return store_rounded<std::uint16_t>(p, value, is_big_endian);
        case ScalarType::Int32:
            return store_rounded<std::int32_t>(p, value, is_big_endian);
        case ScalarType::UInt32:
            return store_rounded<std::uint32_t>(p, value, is_big_endian);
        case ScalarType::Float32:
            store_as<float>(p, static_cast<float>(value), is_big_endian);
            return true;
        case ScalarType::Float64:
            store_as<double>(p, value, is_big_endian);
            return true;
    }
    return false;
}

void store_float(char* p, float value, bool is_big_endian) noexcept
{
    store_as<float>(p, value, is_big_endian);
}

void append_shortest(std::string& out, double value)
{
    std::array<char, 32> buffer{};
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    out.append(buffer.data(), result.ptr);
}

void append_shortest(std::string& out, float value)
{
    std::array<char, 32> buffer{};
    const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
    out.append(buffer.data(), result.ptr);
}

bool append_typed(std::string& out, ScalarType type, double value)
{
    switch (type)
    {
        case ScalarType::Int8:
            return append_rounded<std::int8_t>(out, value);
        case ScalarType::UInt8:
            return append_rounded<std::uint8_t>(out, value);
        case ScalarType::Int16:
            return append_rounded<std::int16_t>(out, value);
        case ScalarType::UInt16:
            return append_rounded<std::uint16_t>(out, value);
        case ScalarType::Int32:
            return append_rounded<std::int32_t>(out, value);
        case ScalarType::UInt32:
            return append_rounded<std::uint32_t>(out, value);
        case ScalarType::Float32:
            append_shortest(out, static_cast<float>(value));
            return true;
        case ScalarType::Float64:
            append_shortest(out, value);
            return true;
    }
    return false;
}

int significant_digits(std::string_view token) noexcept
{
    int count = 0;
    bool leading = true;
    for (const char c : token)
    {
        if (c == 'e' || c == 'E')
        {
            break;
        }
        if (c < '0' || c > '9')
        {
            continue;
        }
        if (leading && c == '0')
        {
            continue;
        }
        leading = false;
        ++count;
    }
    return count;
}

void append_like_token(std::string& out, std::string_view original, double value)
{
    // float32 carries 9 significant digits at most (FLT_DECIMAL_DIG): a token that short was
    // most likely written from a float, so the rewritten value keeps float precision.
    constexpr int kFloatDecimalDigits = 9;
    if (significant_digits(original) <= kFloatDecimalDigits)
    {
        append_shortest(out, static_cast<float>(value));
    }
    else
    {
        append_shortest(out, value);
    }
}

bool parse_double(std::string_view token, double& value) noexcept
{
    token = without_plus(token);
    const char* end = token.data() + token.size();
    const auto result = std::from_chars(token.data(), end, value);
    return result.ec == std::errc() && result.ptr == end;
}

bool parse_float(std::string_view token, float& value) noexcept
{
    token = without_plus(token);
    const char* end = token.data() + token.size();
    const auto result = std::from_chars(token.data(), end, value);
    return result.ec == std::errc() && result.ptr == end;
}

bool parse_integer(std::string_view token, std::int64_t& value) noexcept
{
    // Fast path for the indices that fill mesh files: up to 18 plain digits cannot overflow.
    constexpr std::size_t kSafeDigits = 18;
    if (!token.empty() && token.size() <= kSafeDigits && token[0] != '-' && token[0] != '+')
    {
        std::int64_t result = 0;
        for (const char c : token)
        {
            if (c < '0' || c > '9')
            {
                return false;
            }
            result = result * 10 + (c - '0');
        }
        value = result;
        return true;
    }
    token = without_plus(token);
    const char* end = token.data() + token.size();
    const auto result = std::from_chars(token.data(), end, value);
    return result.ec == std::errc() && result.ptr == end;
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>

namespace meshmark::detail
{

/// Scalar types of binary and typed-ASCII files (the PLY set).
enum class ScalarType : std::uint8_t
{
    Int8,
    UInt8,
    Int16,
    UInt16,
    Int32,
    UInt32,
    Float32,
    Float64,
};

/// Size in bytes of one value of \p type.
[[nodiscard]] std::size_t scalar_size(ScalarType type) noexcept;

/// True for the integer types.
[[nodiscard]] bool is_integer(ScalarType type) noexcept;

/// Type for a PLY type name (char, uchar, ..., int8, uint8, ..., float32, float64).
[[nodiscard]] std::optional<ScalarType> scalar_type_from_name(std::string_view name) noexcept;

/// load_scalar() for any type (out of line).
[[nodiscard]] double load_scalar_any(const char* p, ScalarType type, bool is_big_endian) noexcept;

/// The value of the binary scalar at \p p (any alignment), widened to double.
/// \details A float32 in the machine's byte order, the usual case, is read inline: a call and
/// a switch per value were 8% of the CPU time of a 20M-vertex out-of-core embed.
[[nodiscard]] inline double load_scalar(const char* p, ScalarType type, bool is_big_endian) noexcept
{
    if (type == ScalarType::Float32 && is_big_endian == (std::endian::native == std::endian::big))
    {
        float value = 0.0F;
        std::memcpy(&value, p, sizeof(value));
        return static_cast<double>(value);
    }
    return load_scalar_any(p, type, is_big_endian);
}

/// The value of the binary integer at \p p; \pre is_integer(type).
[[nodiscard]] std::int64_t load_integer(const char* p, ScalarType type,
                                        bool is_big_endian) noexcept;

/// \brief Store \p value at \p p as \p type; integer types round to nearest.
/// \return false (nothing stored) when the value does not fit the type.
[[nodiscard]] bool store_scalar(char* p, ScalarType type, bool is_big_endian,
                                double value) noexcept;

/// Store a float32 at \p p in the given byte order.
void store_float(char* p, float value, bool is_big_endian) noexcept;

/// Append the shortest text that reads back to exactly \p value (std::to_chars).
void append_shortest(std::string& out, double value);
/// Append the shortest text that reads back to exactly \p value as a float.
void append_shortest(std::string& out, float value);

/// \brief Append \p value as text in the PLY type \p type: shortest float or double digits,
/// or the rounded integer. \return false (nothing appended) when the value does not fit.
[[nodiscard]] bool append_typed(std::string& out, ScalarType type, double value);

/// Number of significant digits of a decimal token (leading zeros and exponent excluded).
[[nodiscard]] int significant_digits(std::string_view token) noexcept;

/// \brief Append \p value with the precision its original token \p original suggests:
/// shortest float32 digits when the token had <= 9 significant digits, else float64 digits.
void append_like_token(std::string& out, std::string_view original, double value);

/// Parse a whole token as a double (a leading '+' is accepted); false on any other text.
[[nodiscard]] bool parse_double(std::string_view token, double& value) noexcept;
/// Parse a whole token as a float (a leading '+' is accepted).
[[nodiscard]] bool parse_float(std::string_view token, float& value) noexcept;
/// Parse a whole token as a decimal integer (a leading '+' is accepted).
[[nodiscard]] bool parse_integer(std::string_view token, std::int64_t& value) noexcept;

}  // namespace meshmark::detail

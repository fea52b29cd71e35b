// SPDX-License-Identifier: MIT
// Preserving writers for text and binary position layouts: the original bytes with only the
// changed coordinates replaced (STL facets are handled in stl.cpp).
#include <cstring>
#include <string>
#include <variant>

#include "io/detail/formats.h"
#include "io/detail/support.h"

namespace meshmark::detail {

namespace {

// Bitwise comparison: a coordinate is rewritten only if its double changed at all.
bool is_changed(double a, double b) noexcept
{
    return std::memcmp(&a, &b, sizeof(double)) != 0;
}

const char* type_name(ScalarType type) noexcept
{
    switch (type)
    {
        case ScalarType::Int8:
            return "char";
        case ScalarType::UInt8:
            return "uchar";
        case ScalarType::Int16:
            return "short";
        case ScalarType::UInt16:
            return "ushort";
        case ScalarType::Int32:
            return "int";
        case ScalarType::UInt32:
            return "uint";
        case ScalarType::Float32:
            return "float";
        case ScalarType::Float64:
            return "double";
    }
    return "?";
}

[[noreturn]] void fail_range(const std::filesystem::path& path, std::size_t vertex, ScalarType type,
                             double value)
{
    std::string text;
    append_shortest(text, value);
    fail_io(path, "cannot store coordinate " + text + " of vertex " + std::to_string(vertex) +
                      " in the file's '" + type_name(type) + "' position property");
}

std::string preserved_text(const std::filesystem::path& path, const std::string& bytes,
                           const TextPositions& slots, const Positions& original,
                           const Positions& positions)
{
    const auto n = static_cast<std::size_t>(positions.size());
    const double* old_values = original.data();
    const double* new_values = positions.data();
    std::string out;
    out.reserve(bytes.size() + bytes.size() / 4);
    std::size_t cursor = 0;
    for (std::size_t k = 0; k < n; ++k)
    {
        if (!is_changed(old_values[k], new_values[k]))
        {
            continue;
        }
        const auto& span = slots.tokens[k];
        const auto offset = static_cast<std::size_t>(span.offset);
        out.append(bytes, cursor, offset - cursor);
        const auto& type = slots.declared_types[k % 3];
        if (type)
        {
            if (!append_typed(out, *type, new_values[k]))
            {
                fail_range(path, k / 3, *type, new_values[k]);
            }
        }
        else
        {
            append_like_token(out, std::string_view(bytes).substr(offset, span.length),
                              new_values[k]);
        }
        cursor = offset + span.length;
    }
    out.append(bytes, cursor);
    return out;
}

std::string preserved_binary(const std::filesystem::path& path, const std::string& bytes,
                             const BinaryPositions& slots, const Positions& original,
                             const Positions& positions)
{
    std::string out = bytes;
    const auto n = static_cast<std::size_t>(positions.rows());
    for (std::size_t i = 0; i < n; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double value = positions.data()[3 * i + d];
            if (!is_changed(original.data()[3 * i + d], value))
            {
                continue;
            }
            if (!store_scalar(out.data() + slots.offset(i, d), slots.types[d], slots.is_big_endian,
                              value))
            {
                fail_range(path, i, slots.types[d], value);
            }
        }
    }
    return out;
}

}  // namespace

std::string preserved_bytes(const std::filesystem::path& path, const FileLayout& layout,
                            const Positions& original, const Positions& positions)
{
    if (const auto* text = std::get_if<TextPositions>(&layout.positions))
    {
        return preserved_text(path, layout.bytes, *text, original, positions);
    }
    if (const auto* binary = std::get_if<BinaryPositions>(&layout.positions))
    {
        return preserved_binary(path, layout.bytes, *binary, original, positions);
    }
    return preserved_stl_bytes(path, layout, std::get<StlFacets>(layout.positions), original,
                               positions);
}

}  // namespace meshmark::detail

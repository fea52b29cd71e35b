// SPDX-License-Identifier: MIT
// PLY internals shared by the header parser and the binary and ASCII body readers.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "io/detail/file_layout.h"
#include "io/detail/support.h"

namespace meshmark::detail
{

enum class PlyEncoding
{
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
};

struct PlyProperty
{
    std::string name;
    ScalarType type = ScalarType::Float32;  ///< Value type; for a list, the index type.
    bool is_list = false;
    ScalarType count_type = ScalarType::UInt8;
};

enum class Role
{
    Skip,
    Vertex,
    Faces,
    Strips,
};

struct PlyElement
{
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
    std::size_t line = 0;  ///< Header line that declares it.
    Role role = Role::Skip;
    std::array<std::size_t, 3> axes{};  ///< Vertex: property index of x, y, z.
    std::size_t list = 0;               ///< Faces/strips: property index of the index list.
};

struct PlyHeader
{
    PlyEncoding encoding = PlyEncoding::Ascii;
    std::vector<PlyElement> elements;
    std::size_t body_offset = 0;
    std::size_t body_line = 0;  ///< Line number of the first body line (ASCII).

    /// Records in the vertex element (0 if there is none).
    [[nodiscard]] std::uint64_t vertex_count() const noexcept
    {
        for (const auto& element : elements)
        {
            if (element.role == Role::Vertex)
            {
                return element.count;
            }
        }
        return 0;
    }
};

/// \brief Parse a PLY header and mark the elements meshmark reads (vertex, face, tristrips).
/// \throws IoError naming \p path on a malformed header or an unsupported layout.
[[nodiscard]] PlyHeader parse_ply_header(const std::filesystem::path& path, std::string_view bytes);

// Decodes triangle strips: -1 restarts a strip, odd triangles are flipped to keep the
// winding, and triangles with a repeated index are skipped (they only serve to join runs).
class StripDecoder
{
public:
    explicit StripDecoder(TriangleBuffer& triangles) : triangles_(triangles) {}
    void restart() noexcept { run_ = 0; }
    void push(std::int32_t index)
    {
        if (run_ >= 2)
        {
            const bool is_odd = ((run_ - 2) & 1U) != 0;
            if (a_ != b_ && b_ != index && a_ != index)
            {
                triangles_.push(is_odd ? b_ : a_, is_odd ? a_ : b_, index);
            }
        }
        a_ = b_;
        b_ = index;
        ++run_;
    }

private:
    TriangleBuffer& triangles_;
    std::int32_t a_ = 0;
    std::int32_t b_ = 0;
    std::size_t run_ = 0;
};

// Checks and narrows the indices of one face or strip record, then triangulates it.
class ListSink
{
public:
    ListSink(const std::filesystem::path& path, const PlyElement& element,
             std::uint64_t vertex_count, TriangleBuffer& triangles)
        : path_(path),
          element_(element),
          vertex_count_(vertex_count),
          triangles_(triangles),
          strips_(triangles)
    {
    }

    // Start of record `record` with `n` indices.
    void begin(std::uint64_t record, std::uint64_t n)
    {
        record_ = record;
        position_ = 0;
        polygon_.clear();
        strips_.restart();
        if (element_.role == Role::Faces)
        {
            polygon_.reserve(static_cast<std::size_t>(n));
        }
    }

    /// Check and narrow the next index; InvalidMesh naming the record when out of range.
    void add(std::int64_t index);

    void end() { triangles_.push_polygon(polygon_.data(), polygon_.size()); }

private:
    const std::filesystem::path& path_;
    const PlyElement& element_;
    std::uint64_t vertex_count_;
    TriangleBuffer& triangles_;
    std::vector<std::int32_t> polygon_;  // Reused across records: no per-face allocation.
    StripDecoder strips_;
    std::uint64_t record_ = 0;
    std::uint64_t position_ = 0;
};

/// Read a binary body: positions into \p V (where they sit into \p slots), triangles.
void read_ply_binary_body(const std::filesystem::path& path, const PlyHeader& header,
                          std::string_view bytes, Positions& V, TriangleBuffer& triangles,
                          BinaryPositions& slots);

/// Read an ASCII body: positions into \p V (their token spans into \p slots), triangles.
void read_ply_ascii_body(const std::filesystem::path& path, const PlyHeader& header,
                         std::string_view bytes, Positions& V, TriangleBuffer& triangles,
                         TextPositions& slots);

/// Bytes of one record of \p element in a binary PLY when its lists are empty; \p is_fixed
/// tells whether every record has that size (no list property).
[[nodiscard]] std::uint64_t min_record_size(const PlyElement& element, bool& is_fixed);

}  // namespace meshmark::detail

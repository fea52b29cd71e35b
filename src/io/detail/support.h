// SPDX-License-Identifier: MIT
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

/// Throw IoError "<path>: <what>." (what is one clause, without the final period).
[[noreturn]] void fail_io(const std::filesystem::path& path, const std::string& what);
/// Throw InvalidMesh "<path>: <what>.".
[[noreturn]] void fail_mesh(const std::filesystem::path& path, const std::string& what);

/// A token for a message: quoted, cut to 40 characters, control bytes escaped.
[[nodiscard]] std::string quoted(std::string_view token);

/// The whole file, read with one read into memory; IoError when missing or unreadable.
[[nodiscard]] std::string read_file_bytes(const std::filesystem::path& path);

/// \brief Where a file written into \p output_folder finds \p resource, a file that its source
/// in \p source_folder names by the relative \p name (a glTF's image, an OBJ's material
/// library): std::nullopt when \p name still resolves from there (the same folder, a file with
/// the same bytes at that place, or no such resource to reach), else the relative path from
/// \p output_folder to the source's file (empty when there is none). A \p link_folder, when
/// given, is where the output will be read from (a cluster worker's staging writes elsewhere):
/// the relative path starts there, and the same folder as the source's means no relink.
[[nodiscard]] std::optional<std::filesystem::path> relinked(
    const std::filesystem::path& source_folder, const std::filesystem::path& output_folder,
    const std::filesystem::path& name, const std::filesystem::path& link_folder = {});

/// Spaces that separate tokens within a line (everything but '\n').
[[nodiscard]] constexpr bool is_blank(char c) noexcept
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

/// Successive lines of a text (without their '\n'), with 1-based line numbers.
class LineCursor
{
public:
    explicit LineCursor(std::string_view text, std::size_t start = 0, std::size_t line = 0)
        : text_(text), next_(start), line_(line)
    {
    }
    /// Advance to the next line; false at the end of the text.
    bool next(std::string_view& line) noexcept;
    [[nodiscard]] std::size_t line_number() const noexcept { return line_; }
    /// Offset just past the current line's '\n' (or the end of the text).
    [[nodiscard]] std::size_t next_offset() const noexcept { return next_; }

private:
    std::string_view text_;
    std::size_t next_;
    std::size_t line_;
};

/// Whitespace-separated tokens of one line.
class TokenCursor
{
public:
    explicit TokenCursor(std::string_view line) noexcept : line_(line) {}
    /// Next token; false when the line has no more.
    bool next(std::string_view& token) noexcept;

private:
    std::string_view line_;
    std::size_t pos_ = 0;
};

/// Whitespace-separated tokens across lines (ASCII PLY bodies), counting lines.
class TokenStream
{
public:
    TokenStream(std::string_view text, std::size_t start, std::size_t line) noexcept
        : text_(text), pos_(start), line_(line)
    {
    }
    /// Next token; empty at the end of the text.
    std::string_view next() noexcept;
    /// Line of the last token returned (1-based).
    [[nodiscard]] std::size_t line() const noexcept { return line_; }
    [[nodiscard]] std::size_t remaining() const noexcept { return text_.size() - pos_; }

private:
    std::string_view text_;
    std::size_t pos_;
    std::size_t line_;
};

/// \brief Triangles appended one at a time into a geometrically growing Faces matrix.
/// \details Storage is reserved uninitialized and handed over without a copy by take(), which
/// matters for meshes with millions of faces.
class TriangleBuffer
{
public:
    /// Make room for \p triangles triangles in total.
    void reserve(std::size_t triangles)
    {
        if (triangles > capacity())
        {
            F_.conservativeResize(static_cast<Eigen::Index>(triangles), 3);
        }
    }
    void push(std::int32_t a, std::int32_t b, std::int32_t c)
    {
        if (size_ == capacity())
        {
            constexpr std::size_t kMinCapacity = 64;
            reserve(std::max(kMinCapacity, 2 * capacity()));
        }
        std::int32_t* p = F_.data() + 3 * size_;
        p[0] = a;
        p[1] = b;
        p[2] = c;
        ++size_;
    }
    /// \brief A polygon of \p n checked indices as its fan (i0, ik, ik+1), none if n < 3.
    /// \details A polygon of 4 or more corners is remembered: fill_polygons, once the positions
    /// are known, replaces the fan of one that is not convex by a triangulation inside it.
    void push_polygon(const std::int32_t* indices, std::size_t n)
    {
        if (n > 3)
        {
            constexpr std::size_t kMost = std::numeric_limits<std::uint32_t>::max();
            if (size_ <= kMost && n <= kMost)  // else kept as a fan (beyond 4 billion triangles)
            {
                polygons_.push_back(
                    {static_cast<std::uint32_t>(size_), static_cast<std::uint32_t>(n)});
            }
        }
        for (std::size_t k = 1; k + 1 < n; ++k)
        {
            push(indices[0], indices[k], indices[k + 1]);
        }
    }
    /// A polygon pushed as a fan: its first triangle and its number of corners (8 bytes a
    /// polygon: a million quads cost 8 MB).
    using Polygon = PolygonRows;
    [[nodiscard]] const std::vector<Polygon>& polygons() const noexcept { return polygons_; }
    /// Remember that triangle \p t was (a, b, c), its polygon's fan, before another took its row.
    void keep_fan(std::size_t t, std::int32_t a, std::int32_t b, std::int32_t c)
    {
        fans_.push_back({static_cast<Eigen::Index>(t), a, b, c});
    }
    /// The fans kept so far (TriangleMesh::fans); none are kept afterwards.
    [[nodiscard]] std::vector<FanTriangle> take_fans() { return std::move(fans_); }
    /// The polygons pushed so far (TriangleMesh::polygons); none are kept afterwards.
    [[nodiscard]] std::vector<PolygonRows> take_polygons() { return std::move(polygons_); }
    /// Corners of triangle \p t (t < size()).
    [[nodiscard]] std::int32_t* triangle(std::size_t t) noexcept { return F_.data() + 3 * t; }
    [[nodiscard]] std::size_t size() const noexcept { return size_; }
    /// The triangles pushed so far; the buffer is empty afterwards.
    [[nodiscard]] Faces take()
    {
        F_.conservativeResize(static_cast<Eigen::Index>(size_), 3);
        size_ = 0;
        polygons_ = {};
        fans_ = {};
        return std::move(F_);
    }

private:
    [[nodiscard]] std::size_t capacity() const noexcept
    {
        return static_cast<std::size_t>(F_.rows());
    }
    Faces F_;
    std::size_t size_ = 0;
    std::vector<Polygon> polygons_;
    std::vector<FanTriangle> fans_;
};

/// A mesh from flat positions \p xyz (3 per vertex) and the triangles of \p triangles.
[[nodiscard]] TriangleMesh make_mesh(const std::vector<double>& xyz, TriangleBuffer& triangles);
/// A mesh from flat positions \p xyz and flat corner indices \p corners (3 per triangle, each
/// below xyz.size() / 3): the other instances of instanced glTF meshes and 3MF objects.
[[nodiscard]] TriangleMesh make_mesh(const std::vector<double>& xyz,
                                     const std::vector<std::size_t>& corners);

/// Throw InvalidMesh naming \p path and the vertex if any coordinate is NaN or infinite.
void check_finite(const std::filesystem::path& path, const Positions& V);

/// Largest vertex count that 32-bit indices address.
inline constexpr std::uint64_t kMaxVertices = 2147483647U;

}  // namespace meshmark::detail

namespace meshmark::detail
{

/// \brief Triangulate inside each polygon of \p triangles that is not convex, in place.
/// \details \p xyz holds 3 coordinates per vertex. A polygon pushed with push_polygon is first
/// its fan from corner 0, which lays triangles outside a concave outline (an L, a letter, a
/// gear's rim): seen in its own plane, such a polygon gets a constrained Delaunay triangulation
/// of the same n - 2 triangles on its own corners instead. A polygon whose triangulation would
/// need other points (an outline crossing itself), or with a corner on another of its sides,
/// keeps its fan. The fan of each polygon triangulated otherwise is kept (take_fans).
void fill_polygons(const double* xyz, TriangleBuffer& triangles);

/// "outside 0..n-1" for index messages ("but the file has no vertices" when n == 0).
[[nodiscard]] std::string index_range(std::uint64_t vertex_count);

}  // namespace meshmark::detail

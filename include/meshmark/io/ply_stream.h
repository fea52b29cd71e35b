// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace meshmark
{

/// \brief Which vertices the triangles of a file reference (PlyStream::scan_faces()).
/// \details The referenced vertices are the "active rows" of a watermark, in vertex order; a
/// file without triangles (a point cloud) has every vertex active.
struct ReferencedVertices
{
    /// Vertices per entry of active_before.
    static constexpr std::size_t kSelectBlock = std::size_t{1} << 16U;

    std::vector<std::uint8_t> flags;           ///< 1 byte per vertex; empty: every vertex.
    std::vector<std::uint64_t> active_before;  ///< Active vertices before each kSelectBlock block.
    std::uint64_t active = 0;                  ///< Number of active vertices.
    std::uint64_t triangles = 0;               ///< Triangles, as read_mesh_file triangulates.

    [[nodiscard]] bool is_active(std::uint64_t vertex) const noexcept
    {
        return flags.empty() || flags[vertex] != 0;
    }
    /// The vertex of active row \p row (\pre row < active).
    [[nodiscard]] std::uint64_t select(std::uint64_t row) const;
};

/// \brief A PLY file opened for out-of-core passes: its header parsed once, the layout of its
/// vertex records, and positioned reads (pread), so that several threads may read at once.
/// \details The passes stream a binary PLY (either byte order) whose vertex records have a
/// fixed size (no list property) and follow only fixed-size elements: memory stays
/// O(#V bytes) plus the windows of the readers. Any PLY can be opened to ask refusal() and the
/// counts; the passes (scan_faces, position, PlyVertexReader, PlyDisplacedCopy) require an
/// empty refusal().
class PlyStream
{
public:
    /// \brief Open \p path and parse its header.
    /// \throws IoError (cannot open or read the file; malformed header or unsupported layout).
    explicit PlyStream(const std::filesystem::path& path);
    ~PlyStream();
    PlyStream(PlyStream&&) noexcept;
    PlyStream& operator=(PlyStream&&) noexcept;

    [[nodiscard]] const std::filesystem::path& path() const noexcept;
    [[nodiscard]] std::uint64_t file_size() const noexcept;
    /// Records of the vertex element (0 if there is none).
    [[nodiscard]] std::uint64_t vertex_count() const noexcept;
    /// Records of the face and triangle-strip elements.
    [[nodiscard]] std::uint64_t face_records() const noexcept;
    /// \brief Memory read_mesh_file needs for this file, in bytes (estimate): the file, 24 B of
    /// positions per vertex and 12 B per face record (one triangle each).
    [[nodiscard]] std::uint64_t read_memory_bytes() const noexcept;

    /// \brief Why the file cannot be streamed (one clause), or empty when it can: ASCII, a list
    /// property in the vertex element or in an element before it, no vertex element.
    /// \throws IoError when the layout streams but the file ends inside the vertex records.
    [[nodiscard]] std::string refusal() const;

    /// \brief One pass over the elements after the vertices: faces and strips triangulated
    /// exactly as read_mesh_file does (same checks, same errors), other elements skipped;
    /// reads \p window_bytes at a time.
    /// \throws IoError (truncated, negative list length), InvalidMesh (index out of range).
    [[nodiscard]] ReferencedVertices scan_faces(std::size_t window_bytes) const;

    /// The position of vertex \p vertex (one positioned read of its record).
    [[nodiscard]] std::array<double, 3> position(std::uint64_t vertex) const;

    struct Impl;  ///< Internal (src/io).

private:
    friend class PlyVertexReader;
    friend class PlyDisplacedCopy;
    std::unique_ptr<Impl> impl_;
};

/// \brief Sequential reader of vertex positions from a vertex on, refilled \p window_bytes at
/// a time; one per thread. Positions are delivered in blocks, as doubles (x, y, z per vertex).
class PlyVertexReader
{
public:
    PlyVertexReader(const PlyStream& file, std::uint64_t first_vertex, std::size_t window_bytes);
    ~PlyVertexReader();
    PlyVertexReader(const PlyVertexReader&) = delete;
    PlyVertexReader& operator=(const PlyVertexReader&) = delete;

    /// The vertex the next read starts at.
    [[nodiscard]] std::uint64_t vertex() const noexcept;
    /// The positions of the next \p count vertices into \p xyz (3 per vertex).
    void read(std::size_t count, double* xyz);
    /// The positions of the next \p count vertices active in \p referenced into \p xyz (3 per
    /// row) and, if \p rows is given, their vertex indices into \p rows; the inactive vertices
    /// on the way are passed over.
    void read_active(const ReferencedVertices& referenced, std::size_t count, double* xyz,
                     std::int32_t* rows = nullptr);
    /// Pass over the next \p count active vertices (and the inactive ones on the way).
    void skip_active(const ReferencedVertices& referenced, std::size_t count);

    struct Impl;  ///< Internal (src/io).

private:
    std::unique_ptr<Impl> impl_;
};

/// \brief Writes a copy of a PLY whose active vertices move by a displacement, streamed: the
/// bytes before the vertex records, each vertex record with its changed coordinates patched
/// in, and the bytes after them, in slices of about 1 MiB.
/// \details A coordinate becomes `position + displacement` (as `marked = field; marked += V`)
/// converted to the file's type exactly as write_mesh_file converts it; a value whose double
/// did not change keeps its bytes, so the result is write_mesh_file's for the same positions.
class PlyDisplacedCopy
{
public:
    /// Write everything before the vertex records of \p file to \p out. \p output names the
    /// file being written in messages.
    PlyDisplacedCopy(const PlyStream& file, const ReferencedVertices& referenced,
                     const std::filesystem::path& output, std::ostream& out,
                     std::size_t window_bytes);
    ~PlyDisplacedCopy();
    PlyDisplacedCopy(const PlyDisplacedCopy&) = delete;
    PlyDisplacedCopy& operator=(const PlyDisplacedCopy&) = delete;

    /// \brief The displacements of the next \p rows active vertices (3 per row); inactive
    /// vertices before them are copied unchanged.
    /// \throws InvalidMesh (a coordinate becomes NaN or infinite), IoError (it does not fit
    /// the file's integer position type).
    void add(std::size_t rows, const double* displacement);
    /// The vertices after the last active one and the rest of the file, unchanged.
    void finish();

    struct Impl;  ///< Internal (src/io).

private:
    std::unique_ptr<Impl> impl_;
};

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// Internals of the PLY streaming API (include/meshmark/io/ply_stream.h) and the one routine
// that patches a changed coordinate into a binary record, shared by every binary writer.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "io/detail/numbers.h"
#include "io/detail/ply.h"
#include "io/detail/support.h"
#include "meshmark/io/ply_stream.h"

namespace meshmark::detail
{

/// A read-only file descriptor with positioned reads (thread-safe: pread has no shared offset).
class InputFile
{
public:
    /// \throws IoError naming \p path when it cannot be opened or stat'ed.
    explicit InputFile(const std::filesystem::path& path);
    ~InputFile();
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    [[nodiscard]] std::uint64_t size() const noexcept { return size_; }
    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

    /// Reads [offset, offset + n); at most what the file holds. Returns the bytes read.
    std::size_t read_some(std::uint64_t offset, std::size_t n, char* out) const;
    /// Reads [offset, offset + n); IoError when the file ends first.
    void read_exactly(std::uint64_t offset, std::size_t n, char* out) const;

private:
    std::filesystem::path path_;
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

/// Sequential reader of a byte range, refilled in windows.
class SequentialReader
{
public:
    SequentialReader(const InputFile& file, std::uint64_t begin, std::size_t window)
        : file_(file), next_(begin), buffer_(std::max<std::size_t>(window, 4096))
    {
    }
    /// At least n bytes available at data(); false when the file ends first.
    bool ensure(std::size_t n)
    {
        if (end_ - pos_ >= n)
        {
            return true;
        }
        return refill(n);
    }
    [[nodiscard]] const char* data() const noexcept { return buffer_.data() + pos_; }
    void skip(std::size_t n) noexcept { pos_ += n; }
    [[nodiscard]] std::uint64_t offset() const noexcept { return next_ - (end_ - pos_); }

private:
    bool refill(std::size_t n);

    const InputFile& file_;
    std::uint64_t next_;
    std::vector<char> buffer_;
    std::size_t pos_ = 0;
    std::size_t end_ = 0;
};

/// Bitwise comparison: a coordinate is rewritten only if its double changed at all.
[[nodiscard]] inline bool is_changed(double a, double b) noexcept
{
    return std::memcmp(&a, &b, sizeof(double)) != 0;
}

/// IoError: \p value of coordinate of \p vertex does not fit the file's \p type.
[[noreturn]] void fail_coordinate_range(const std::filesystem::path& path, std::uint64_t vertex,
                                        ScalarType type, double value);

/// \brief The coordinate patch of every binary writer: \p value replaces the coordinate
/// stored at \p p as \p type when its double differs from \p old_value at all (so unchanged
/// values keep their bytes).
/// \throws InvalidMesh naming \p path when \p value is NaN or infinite, IoError when it does
/// not fit \p type (integer types); nothing is stored then.
inline void patch_coordinate(char* p, ScalarType type, bool is_big_endian, double old_value,
                             double value, const std::filesystem::path& path, std::uint64_t vertex)
{
    if (!std::isfinite(value))
    {
        fail_mesh(path, "vertex " + std::to_string(vertex) +
                            " has a non-finite coordinate (NaN or infinity)");
    }
    if (is_changed(old_value, value) && !store_scalar(p, type, is_big_endian, value))
    {
        fail_coordinate_range(path, vertex, type, value);
    }
}

}  // namespace meshmark::detail

namespace meshmark
{

/// Where things sit in a PLY opened for streaming.
struct PlyStream::Impl
{
    explicit Impl(const std::filesystem::path& path);

    detail::InputFile file;
    detail::PlyHeader header;
    std::string refusal;     ///< Why it cannot be streamed; empty when it can.
    std::string truncation;  ///< IoError text when the vertex records run past the end.
    std::size_t vertex_element = 0;
    std::uint64_t vertex_offset = 0;  ///< First vertex record.
    std::uint64_t vertex_count = 0;
    std::uint64_t face_records = 0;
    std::uint64_t stride = 0;
    std::uint64_t vertex_end = 0;  ///< One past the vertex records.
    std::array<std::uint64_t, 3> field_offsets{};
    std::array<detail::ScalarType, 3> types{};
    bool is_big_endian = false;

    /// The position in a vertex record.
    void load(const char* record, double* xyz) const noexcept
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            xyz[d] = detail::load_scalar(record + field_offsets[d], types[d], is_big_endian);
        }
    }
};

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// Out-of-core embedding of a binary PLY. Uses the io module's internal PLY header parser and
// scalar codecs (src/io/detail), like streamed_write.cpp: the passes need byte offsets and the
// file's own types, which the public io interface does not expose.
//
// Passes (each one sequential over the file, reading windows with pread):
//   1. elements after the vertex element: faces triangulated exactly as the reader does, to
//      mark the referenced vertices (1 byte per vertex) and count the triangles;
//   2. vertex section x 4: canonical frame (CanonicalFrameBuilder, the code canonical_frame
//      runs), with the fingerprint hash, finiteness check and bounding box in the first;
//   3. keyed centers (random_centers over the active rows, positions read one record each);
//   4. RbfBasis pass 1 through a RowPositionSource (one cursor per chunk);
//   5. synthesis, chunk by chunk in row order, patched into the vertex records on their way
//      to the output, between the header and the rest of the file copied through.
#include "embed_streamed.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "io/detail/numbers.h"
#include "io/detail/ply.h"
#include "io/detail/support.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/threads.h"
#include "timer.h"

namespace meshmark::detail {
namespace {

constexpr std::size_t kHeaderLimit = std::size_t{1} << 20U;
constexpr std::size_t kSelectBlock = std::size_t{1} << 16U;  // vertices per select anchor
constexpr std::size_t kOutputSlice = std::size_t{1} << 20U;

// A read-only file descriptor with positioned reads (thread-safe: pread has no shared offset).
class InputFile
{
public:
    explicit InputFile(const std::filesystem::path& path) : path_(path)
    {
        fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd_ < 0)
        {
            fail_io(path, std::string("cannot open for reading (") + std::strerror(errno) + ")");
        }
        struct stat info
        {
        };
        if (::fstat(fd_, &info) != 0)
        {
            const int error = errno;
            ::close(fd_);
            fail_io(path, std::string("cannot stat (") + std::strerror(error) + ")");
        }
        size_ = static_cast<std::uint64_t>(info.st_size);
    }
    ~InputFile() { ::close(fd_); }
    InputFile(const InputFile&) = delete;
    InputFile& operator=(const InputFile&) = delete;

    [[nodiscard]] std::uint64_t size() const noexcept { return size_; }
    [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

    // Reads [offset, offset + n); at most what the file holds. Returns the bytes read.
    std::size_t read_some(std::uint64_t offset, std::size_t n, char* out) const
    {
        std::size_t done = 0;
        while (done < n)
        {
            const auto got = ::pread(fd_, out + done, n - done, static_cast<off_t>(offset + done));
            if (got < 0)
            {
                if (errno == EINTR)
                {
                    continue;
                }
                fail_io(path_, std::string("read failed (") + std::strerror(errno) + ")");
            }
            if (got == 0)
            {
                break;
            }
            done += static_cast<std::size_t>(got);
        }
        return done;
    }
    void read_exactly(std::uint64_t offset, std::size_t n, char* out) const
    {
        if (read_some(offset, n, out) != n)
        {
            fail_io(path_, "truncated binary data: the file ends before byte " + std::to_string(offset + n));
        }
    }

private:
    std::filesystem::path path_;
    int fd_ = -1;
    std::uint64_t size_ = 0;
};

// Where things sit in a streamable binary PLY.
struct Layout
{
    PlyHeader header;
    std::size_t vertex_element = 0;
    std::uint64_t vertex_offset = 0;  // first vertex record
    std::uint64_t vertex_count = 0;
    std::uint64_t stride = 0;
    std::uint64_t vertex_end = 0;  // one past the vertex section
    std::array<std::uint64_t, 3> field_offsets{};
    std::array<ScalarType, 3> types{};
    bool is_big_endian = false;
};

// The start of the file, enough for any header: the parser stops at its end_header line.
std::string read_header_bytes(const InputFile& file)
{
    std::string bytes(static_cast<std::size_t>(std::min<std::uint64_t>(file.size(), kHeaderLimit)), '\0');
    bytes.resize(file.read_some(0, bytes.size(), bytes.data()));
    return bytes;
}

// The layout, or the reason the file cannot be streamed in *refusal.
Layout analyse(const InputFile& file, std::string* refusal)
{
    Layout layout;
    const std::string bytes = read_header_bytes(file);
    layout.header = parse_ply_header(file.path(), bytes);
    if (layout.header.encoding == PlyEncoding::Ascii)
    {
        *refusal = "it is an ASCII PLY (only binary PLY files are streamed)";
        return layout;
    }
    layout.is_big_endian = layout.header.encoding == PlyEncoding::BinaryBigEndian;
    std::uint64_t offset = layout.header.body_offset;
    for (std::size_t e = 0; e < layout.header.elements.size(); ++e)
    {
        const auto& element = layout.header.elements[e];
        bool is_fixed = false;
        const auto size = min_record_size(element, is_fixed);
        if (element.role == Role::Vertex)
        {
            if (!is_fixed)
            {
                *refusal = "its vertex element has a list property, so vertex records vary in size";
                return layout;
            }
            layout.vertex_element = e;
            layout.vertex_offset = offset;
            layout.vertex_count = element.count;
            layout.stride = size;
            for (std::size_t d = 0; d < 3; ++d)
            {
                layout.types[d] = element.properties[element.axes[d]].type;
                for (std::size_t p = 0; p < element.axes[d]; ++p)
                {
                    layout.field_offsets[d] += scalar_size(element.properties[p].type);
                }
            }
            const auto available = file.size() > offset ? file.size() - offset : 0;
            if (size > 0 && element.count > available / size)
            {
                fail_io(file.path(), "truncated binary data: element 'vertex' declares " +
                                         std::to_string(element.count) + " records of " + std::to_string(size) +
                                         " bytes, but only " + std::to_string(available) +
                                         " bytes follow byte offset " + std::to_string(offset));
            }
            layout.vertex_end = offset + element.count * size;
            return layout;
        }
        if (!is_fixed)
        {
            *refusal = "element '" + element.name + "' before the vertices has a list property";
            return layout;
        }
        offset += element.count * size;
    }
    *refusal = "it has no vertex element";
    return layout;
}

// Sequential reader of a byte range, refilled in windows.
class SequentialReader
{
public:
    SequentialReader(const InputFile& file, std::uint64_t begin, std::size_t window)
        : file_(file), next_(begin), buffer_(std::max<std::size_t>(window, 4096))
    {
    }
    // At least n bytes available at data(); false when the file ends first.
    bool ensure(std::size_t n)
    {
        if (end_ - pos_ >= n)
        {
            return true;
        }
        if (n > buffer_.size())
        {
            buffer_.resize(n);
        }
        std::memmove(buffer_.data(), buffer_.data() + pos_, end_ - pos_);
        end_ -= pos_;
        pos_ = 0;
        const auto got = file_.read_some(next_, buffer_.size() - end_, buffer_.data() + end_);
        next_ += got;
        end_ += got;
        return end_ - pos_ >= n;
    }
    [[nodiscard]] const char* data() const noexcept { return buffer_.data() + pos_; }
    void skip(std::size_t n) noexcept { pos_ += n; }
    [[nodiscard]] std::uint64_t offset() const noexcept { return next_ - (end_ - pos_); }

private:
    const InputFile& file_;
    std::uint64_t next_;
    std::vector<char> buffer_;
    std::size_t pos_ = 0;
    std::size_t end_ = 0;
};

// Which vertices the triangles reference, and how many triangles there are.
struct Referenced
{
    std::vector<std::uint8_t> flags;           // empty: every vertex (no triangles)
    std::vector<std::uint64_t> active_before;  // active rows before each kSelectBlock block
    std::uint64_t active = 0;
    std::uint64_t triangles = 0;

    [[nodiscard]] bool is_active(std::uint64_t v) const noexcept { return flags.empty() || flags[v] != 0; }

    // The vertex of active row i.
    [[nodiscard]] std::uint64_t select(std::uint64_t i) const
    {
        if (flags.empty())
        {
            return i;
        }
        const auto block = static_cast<std::size_t>(
            std::upper_bound(active_before.begin(), active_before.end(), i) - active_before.begin() - 1);
        std::uint64_t count = active_before[block];
        for (std::uint64_t v = block * kSelectBlock;; ++v)
        {
            if (flags[v] != 0)
            {
                if (count == i)
                {
                    return v;
                }
                ++count;
            }
        }
    }
};

[[noreturn]] void fail_truncated(const InputFile& file, const PlyElement& element, std::uint64_t record,
                                 std::uint64_t offset)
{
    fail_io(file.path(), "truncated binary data: record " + std::to_string(record) + " of element '" +
                             element.name + "' runs past the end of the file (byte offset " +
                             std::to_string(offset) + ", file size " + std::to_string(file.size()) + ")");
}

// Pass over the elements after the vertices: faces and strips triangulated by the reader's own
// ListSink, everything else skipped (it is copied through unread).
Referenced scan_faces(const InputFile& file, const Layout& layout, std::size_t window)
{
    Referenced result;
    const auto n = layout.vertex_count;
    std::vector<std::uint8_t> flags(static_cast<std::size_t>(n), 0);
    SequentialReader in(file, layout.vertex_end, window);
    TriangleBuffer triangles;
    const auto drain = [&]() {
        const Faces F = triangles.take();
        const std::int32_t* p = F.data();
        for (Eigen::Index i = 0; i < F.size(); ++i)
        {
            flags[static_cast<std::size_t>(p[i])] = 1;
        }
        result.triangles += static_cast<std::uint64_t>(F.rows());
    };
    for (std::size_t e = layout.vertex_element + 1; e < layout.header.elements.size(); ++e)
    {
        const auto& element = layout.header.elements[e];
        const bool is_list_element = element.role == Role::Faces || element.role == Role::Strips;
        ListSink sink(file.path(), element, n, triangles);
        // The usual face record, a 1-byte count 3 and three 4-byte integer indices, is checked
        // and marked here directly (the generic loop below costs ~20 ns a face: 0.84 s for 40M).
        // Anything else, including an index out of range, takes the generic loop, which reads
        // the record again and reports it as before.
        const bool is_plain_triangles =
            element.role == Role::Faces && element.properties.size() == 1 && element.properties[0].is_list &&
            scalar_size(element.properties[0].count_type) == 1 &&
            (element.properties[0].type == ScalarType::Int32 || element.properties[0].type == ScalarType::UInt32);
        const bool is_signed = is_plain_triangles && element.properties[0].type == ScalarType::Int32;
        constexpr std::size_t kPlainTriangle = 13;
        for (std::uint64_t r = 0; r < element.count; ++r)
        {
            if (is_plain_triangles && in.ensure(kPlainTriangle) && in.data()[0] == 3)
            {
                std::array<std::uint32_t, 3> index{};
                std::memcpy(index.data(), in.data() + 1, sizeof(index));
                bool in_range = true;
                for (std::uint32_t& v : index)
                {
                    if (layout.is_big_endian != (std::endian::native == std::endian::big))
                    {
                        v = __builtin_bswap32(v);
                    }
                    // A negative Int32 is a huge uint32: out of range as well.
                    in_range = in_range && v < n && (!is_signed || v <= 0x7fffffffU);
                }
                if (in_range)
                {
                    for (const std::uint32_t v : index)
                    {
                        flags[v] = 1;
                    }
                    ++result.triangles;
                    in.skip(kPlainTriangle);
                    continue;
                }
            }
            for (std::size_t p = 0; p < element.properties.size(); ++p)
            {
                const auto& property = element.properties[p];
                const auto size = scalar_size(property.type);
                if (!property.is_list)
                {
                    if (!in.ensure(size))
                    {
                        fail_truncated(file, element, r, in.offset());
                    }
                    in.skip(size);
                    continue;
                }
                const auto count_size = scalar_size(property.count_type);
                if (!in.ensure(count_size))
                {
                    fail_truncated(file, element, r, in.offset());
                }
                const auto length = load_integer(in.data(), property.count_type, layout.is_big_endian);
                if (length < 0)
                {
                    fail_io(file.path(), "negative list length " + std::to_string(length) + " at byte offset " +
                                             std::to_string(in.offset()) + " (record " + std::to_string(r) +
                                             " of element '" + element.name + "')");
                }
                in.skip(count_size);
                const auto bytes = static_cast<std::uint64_t>(length) * size;
                if (bytes > file.size() || !in.ensure(static_cast<std::size_t>(bytes)))
                {
                    fail_truncated(file, element, r, in.offset());
                }
                if (is_list_element && p == element.list)
                {
                    sink.begin(r, static_cast<std::uint64_t>(length));
                    for (std::int64_t k = 0; k < length; ++k)
                    {
                        sink.add(load_integer(in.data() + static_cast<std::size_t>(k) * size, property.type,
                                              layout.is_big_endian));
                    }
                    sink.end();
                }
                in.skip(static_cast<std::size_t>(bytes));
            }
            if (triangles.size() >= (std::size_t{1} << 16U))
            {
                drain();
            }
        }
        drain();
    }
    if (result.triangles > 0)
    {
        result.flags = std::move(flags);
        result.active_before.reserve(static_cast<std::size_t>(n / kSelectBlock + 1));
        std::uint64_t count = 0;
        for (std::uint64_t v = 0; v < n; ++v)
        {
            if (v % kSelectBlock == 0)
            {
                result.active_before.push_back(count);
            }
            count += result.flags[static_cast<std::size_t>(v)];
        }
        result.active = count;
    }
    else
    {
        result.active = n;
    }
    return result;
}

// Reads vertex records sequentially from a vertex, in windows.
class VertexReader
{
public:
    VertexReader(const InputFile& file, const Layout& layout, std::uint64_t first, std::size_t window)
        : layout_(layout),
          in_(file, layout.vertex_offset + first * layout.stride,
              static_cast<std::size_t>(std::max<std::uint64_t>(1, window / layout.stride) * layout.stride)),
          vertex_(first)
    {
    }
    // The record of the next vertex (valid until the next call).
    const char* next()
    {
        if (!in_.ensure(static_cast<std::size_t>(layout_.stride)))
        {
            fail_io(std::filesystem::path(), "truncated vertex section");  // excluded by analyse()
        }
        const char* record = in_.data();
        in_.skip(static_cast<std::size_t>(layout_.stride));
        ++vertex_;
        return record;
    }
    [[nodiscard]] std::uint64_t vertex() const noexcept { return vertex_; }  // of the next record
    void position(const char* record, double* xyz) const noexcept
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            xyz[d] = load_scalar(record + layout_.field_offsets[d], layout_.types[d], layout_.is_big_endian);
        }
    }

private:
    const Layout& layout_;
    SequentialReader in_;
    std::uint64_t vertex_;
};

class FileRowCursor : public RowPositionCursor
{
public:
    FileRowCursor(const InputFile& file, const Layout& layout, const Referenced& referenced,
                  std::uint64_t first_vertex, std::size_t window)
        : referenced_(referenced), reader_(file, layout, first_vertex, window)
    {
    }
    void read(std::size_t count, double* xyz) override
    {
        for (std::size_t i = 0; i < count;)
        {
            const auto v = reader_.vertex();
            const char* record = reader_.next();
            if (referenced_.is_active(v))
            {
                reader_.position(record, xyz + 3 * i);
                ++i;
            }
        }
    }
    void skip(std::size_t count) override
    {
        for (std::size_t i = 0; i < count;)
        {
            i += referenced_.is_active(reader_.vertex()) ? 1U : 0U;
            (void)reader_.next();
        }
    }

private:
    const Referenced& referenced_;
    VertexReader reader_;
};

class FileRowSource : public RowPositionSource
{
public:
    FileRowSource(const InputFile& file, const Layout& layout, const Referenced& referenced, std::size_t window)
        : file_(file), layout_(layout), referenced_(referenced), window_(window)
    {
    }
    [[nodiscard]] std::size_t size() const override { return static_cast<std::size_t>(referenced_.active); }
    [[nodiscard]] std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const override
    {
        return std::make_unique<FileRowCursor>(file_, layout_, referenced_, referenced_.select(begin), window_);
    }

private:
    const InputFile& file_;
    const Layout& layout_;
    const Referenced& referenced_;
    std::size_t window_;
};

// One pass over the vertex records, calling fn(vertex, xyz, is_active) in order.
template <class Fn>
void for_each_vertex(const InputFile& file, const Layout& layout, const Referenced& referenced,
                     std::size_t window, const Fn& fn)
{
    VertexReader reader(file, layout, 0, window);
    std::array<double, 3> xyz{};
    for (std::uint64_t v = 0; v < layout.vertex_count; ++v)
    {
        reader.position(reader.next(), xyz.data());
        fn(v, xyz, referenced.is_active(v));
    }
}

constexpr std::uint64_t byteswap64(std::uint64_t x) noexcept
{
    std::uint64_t y = 0;
    for (int i = 0; i < 8; ++i)
    {
        y = (y << 8U) | ((x >> (8U * static_cast<unsigned>(i))) & 0xFFU);
    }
    return y;
}

bool is_changed(double a, double b) noexcept { return std::memcmp(&a, &b, sizeof(double)) != 0; }

void copy_range(const InputFile& file, std::uint64_t begin, std::uint64_t end, std::ostream& out)
{
    std::vector<char> buffer(kOutputSlice);
    while (begin < end)
    {
        const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(buffer.size(), end - begin));
        file.read_exactly(begin, n, buffer.data());
        out.write(buffer.data(), static_cast<std::streamsize>(n));
        begin += n;
    }
}

// Writes the vertex section: each record copied, its coordinates replaced by field + original
// exactly where write_binary_ply_streamed would change them (unchanged values keep their bytes).
class VertexWriter
{
public:
    VertexWriter(const InputFile& file, const Layout& layout, const Referenced& referenced,
                 const std::filesystem::path& output, std::ostream& out, std::size_t window)
        : layout_(layout), referenced_(referenced), output_(output), out_(out), reader_(file, layout, 0, window)
    {
        slice_.reserve(kOutputSlice + layout.stride);
    }

    // The field of the next `rows` active rows; inactive vertices before them pass unchanged.
    void add(std::size_t rows, const double* field)
    {
        for (std::size_t i = 0; i < rows;)
        {
            if (referenced_.is_active(reader_.vertex()))
            {
                summary_.add(field + 3 * i);
                emit(field + 3 * i);
                ++i;
            }
            else
            {
                emit(kZero.data());
            }
        }
    }
    // The inactive vertices after the last active one; flushes.
    void finish()
    {
        while (reader_.vertex() < layout_.vertex_count)
        {
            emit(kZero.data());
        }
        flush();
    }
    [[nodiscard]] const DisplacementSummary& summary() const noexcept { return summary_; }

private:
    static constexpr std::array<double, 3> kZero{0.0, 0.0, 0.0};

    void emit(const double* d)
    {
        const auto v = reader_.vertex();
        const char* record = reader_.next();
        const std::size_t at = slice_.size();
        slice_.insert(slice_.end(), record, record + layout_.stride);
        char* target = slice_.data() + at;
        for (std::size_t axis = 0; axis < 3; ++axis)
        {
            const double old_value = load_scalar(record + layout_.field_offsets[axis], layout_.types[axis],
                                                 layout_.is_big_endian);
            const double value = d[axis] + old_value;  // as `marked = field; marked += V`
            if (!std::isfinite(value))
            {
                fail_mesh(output_, "vertex " + std::to_string(v) + " has a non-finite coordinate (NaN or infinity)");
            }
            if (!is_changed(old_value, value))
            {
                continue;
            }
            if (!store_scalar(target + layout_.field_offsets[axis], layout_.types[axis], layout_.is_big_endian,
                              value))
            {
                std::string text;
                append_shortest(text, value);
                fail_io(output_, "cannot store coordinate " + text + " of vertex " + std::to_string(v) +
                                     " in the file's position property type");
            }
        }
        if (slice_.size() >= kOutputSlice)
        {
            flush();
        }
    }
    void flush()
    {
        out_.write(slice_.data(), static_cast<std::streamsize>(slice_.size()));
        slice_.clear();
    }

    const Layout& layout_;
    const Referenced& referenced_;
    const std::filesystem::path& output_;
    std::ostream& out_;
    VertexReader reader_;
    std::vector<char> slice_;
    DisplacementSummary summary_;
};

}  // namespace

std::string stream_refusal(const std::filesystem::path& input, const std::filesystem::path& output)
{
    if (format_from_extension(input) != MeshFormat::Ply)
    {
        return "it is not a PLY file";
    }
    if (format_from_extension(output) != MeshFormat::Ply)
    {
        return "the output is not a PLY file (a format conversion needs the mesh in memory)";
    }
    const InputFile file(input);
    std::string refusal;
    (void)analyse(file, &refusal);
    return refusal;
}

std::uint64_t in_memory_embed_bytes(const std::filesystem::path& input)
{
    const InputFile file(input);
    const std::string bytes = read_header_bytes(file);
    std::uint64_t vertices = 0;
    std::uint64_t faces = 0;
    if (format_from_extension(input) == MeshFormat::Ply)
    {
        const auto header = parse_ply_header(input, bytes);
        for (const auto& element : header.elements)
        {
            if (element.role == Role::Vertex)
            {
                vertices = element.count;
            }
            else if (element.role == Role::Faces || element.role == Role::Strips)
            {
                faces += element.count;
            }
        }
    }
    // The file's bytes, positions and the marked copy (2 x 24 B), active rows and flags (5 B)
    // per vertex, 12 B per triangle, and the process's base.
    constexpr std::uint64_t kBase = std::uint64_t{32} << 20U;
    return file.size() + 53 * vertices + 12 * faces + kBase;
}

EmbedReport embed_file_streamed(const std::filesystem::path& input, const std::filesystem::path& output,
                                const std::filesystem::path& key_path, Key key,
                                const EmbedFileOptions& options, const StreamTuning& tuning)
{
    EmbedReport report;
    report.streamed = true;
    PhaseTimer timer(report.seconds, options.progress);
    // Fractions within a phase; 1 (the end of a phase) is for the timer's lap alone.
    const auto progress = [&](const char* phase, double fraction) {
        if (options.progress && fraction < 1.0)
        {
            options.progress(phase, fraction);
        }
    };
    const std::size_t window = std::max<std::size_t>(tuning.window_bytes, 64);

    // Header and faces.
    timer.begin("scan");
    const InputFile file(input);
    std::string refusal;
    const Layout layout = analyse(file, &refusal);
    if (!refusal.empty())
    {
        throw InvalidOption(input.string() + ": cannot be embedded out of core: " + refusal + ".");
    }
    // Fingerprint, finiteness, bounding box and canonical frame: three passes over the vertices
    // through the flags of the referenced ones.
    struct FrameResult
    {
        std::uint64_t hash = 0;
        BoundingBox box;
        CanonicalFrameBuilder frame;
    };
    const auto frame_passes = [&](const Referenced& referenced, bool report_progress) {
        FrameResult result;
        result.hash = splitmix64(0 ^ (layout.vertex_count * 3 * sizeof(double) * 0x9E3779B97F4A7C15ULL));
        bool has_box = false;
        int pass = 0;
        // Active rows go to the builder in blocks (add_rows: add()'s sums without its per-row
        // dispatch).
        constexpr std::int32_t kBlock = 4096;
        Positions block(kBlock, 3);
        std::vector<std::int32_t> block_rows(kBlock);
        std::iota(block_rows.begin(), block_rows.end(), 0);
        std::int32_t filled = 0;
        const auto feed = [&]() {
            result.frame.add_rows(block, std::span<const std::int32_t>(block_rows.data(), static_cast<std::size_t>(filled)));
            filled = 0;
        };
        while (result.frame.pass() != CanonicalFrameBuilder::Pass::Done)
        {
            const bool is_first = result.frame.pass() == CanonicalFrameBuilder::Pass::Centroid;
            for_each_vertex(file, layout, referenced, window,
                            [&](std::uint64_t v, const std::array<double, 3>& xyz, bool is_active) {
                                if (is_first)
                                {
                                    for (const double value : xyz)
                                    {
                                        if (!std::isfinite(value))
                                        {
                                            fail_mesh(input, "vertex " + std::to_string(v) +
                                                                 " has a non-finite coordinate (NaN or infinity)");
                                        }
                                        std::uint64_t word = 0;
                                        std::memcpy(&word, &value, sizeof(word));
                                        if constexpr (std::endian::native == std::endian::big)
                                        {
                                            word = byteswap64(word);  // hash_bytes packs little-endian
                                        }
                                        result.hash = splitmix64(result.hash ^ word);
                                    }
                                }
                                if (!is_active)
                                {
                                    return;
                                }
                                if (is_first)
                                {
                                    const Eigen::Vector3d p(xyz[0], xyz[1], xyz[2]);
                                    if (!has_box)
                                    {
                                        result.box.min = p;
                                        result.box.max = p;
                                        has_box = true;
                                    }
                                    result.box.min = result.box.min.cwiseMin(p);
                                    result.box.max = result.box.max.cwiseMax(p);
                                }
                                block(filled, 0) = xyz[0];
                                block(filled, 1) = xyz[1];
                                block(filled, 2) = xyz[2];
                                if (++filled == kBlock)
                                {
                                    feed();
                                }
                            });
            feed();
            result.frame.next_pass();
            if (report_progress)
            {
                progress("frame", ++pass / 3.0);
            }
        }
        return result;
    };

    // With two threads or more, the frame passes run beside the face scan on the guess that
    // every vertex is referenced (the usual case: then they are exactly the passes the flags
    // would give); when the scan finds unreferenced vertices they run again after it. Errors
    // keep their order: the scan's, then the basis size, then the vertices'.
    const bool overlap = resolve_threads(options.threads) > 1;
    Referenced referenced;
    std::optional<FrameResult> guess;
    std::exception_ptr guess_error;
    if (overlap)
    {
        std::exception_ptr scan_error;
        std::thread scanner([&]() {
            try
            {
                referenced = scan_faces(file, layout, window);
            }
            catch (...)
            {
                scan_error = std::current_exception();
            }
        });
        Referenced everything;  // no flags: every vertex
        everything.active = layout.vertex_count;
        try
        {
            guess = frame_passes(everything, false);
        }
        catch (...)
        {
            guess_error = std::current_exception();
        }
        scanner.join();
        if (scan_error)
        {
            std::rethrow_exception(scan_error);
        }
    }
    else
    {
        referenced = scan_faces(file, layout, window);
    }
    report.input_format = MeshFormat::Ply;
    report.output_format = MeshFormat::Ply;
    report.vertex_count = static_cast<std::int64_t>(layout.vertex_count);
    report.face_count = static_cast<std::int64_t>(referenced.triangles);
    timer.lap("scan");

    timer.begin("frame");
    key.options.validate();
    if (static_cast<std::int64_t>(referenced.active) < key.options.basis_size)
    {
        throw InvalidMesh("the mesh has " + std::to_string(referenced.active) + " usable vertices, fewer than the " +
                          std::to_string(key.options.basis_size) + " basis functions (use a smaller --basis-size).");
    }
    if (guess_error)
    {
        std::rethrow_exception(guess_error);
    }
    if (!guess || referenced.active != layout.vertex_count)
    {
        guess = frame_passes(referenced, true);
    }
    const std::uint64_t hash = guess->hash;
    const BoundingBox box = guess->box;
    const CanonicalFrameBuilder& frame = guess->frame;
    key.original.vertex_count = static_cast<std::int64_t>(layout.vertex_count);
    key.original.face_count = static_cast<std::int64_t>(referenced.triangles);
    key.original.position_hash = hash;
    timer.lap("frame");

    // Centers and basis (pass 1 over the file).
    timer.begin("basis");
    const auto read_position = [&](std::int32_t row) {
        std::vector<char> record(static_cast<std::size_t>(layout.stride));
        file.read_exactly(layout.vertex_offset + static_cast<std::uint64_t>(row) * layout.stride, record.size(),
                          record.data());
        std::array<double, 3> xyz{};
        for (std::size_t d = 0; d < 3; ++d)
        {
            xyz[d] = load_scalar(record.data() + layout.field_offsets[d], layout.types[d], layout.is_big_endian);
        }
        return xyz;
    };
    std::vector<std::int32_t> centers = random_centers(
        static_cast<std::size_t>(referenced.active),
        [&](std::size_t i) { return static_cast<std::int32_t>(referenced.select(i)); }, read_position,
        key.options.basis_size, derive_seed(key.seed, "centers"));
    Eigen::MatrixX3d center_positions(static_cast<Eigen::Index>(centers.size()), 3);
    for (std::size_t j = 0; j < centers.size(); ++j)
    {
        const auto xyz = read_position(centers[j]);
        center_positions.row(static_cast<Eigen::Index>(j)) = Eigen::RowVector3d(xyz[0], xyz[1], xyz[2]);
    }
    const CanonicalFrame& canonical = frame.frame();
    const double sigma = key.options.sigma_factor * canonical.diagonal / 2.0;
    const FileRowSource source(file, layout, referenced, window);
    RbfBasis basis(source, center_positions, sigma, canonical.origin, options.threads,
                   static_cast<std::size_t>(key.options.gram_rows));
    const std::size_t chunk_bytes = basis.max_chunk_rows() * 3 * sizeof(double);
    const SpectralWatermark mark(key, canonical, std::move(centers), std::move(basis),
                                 static_cast<std::size_t>(referenced.active));
    timer.lap("basis");

    // Synthesis streamed into the output: header, patched vertex records, the rest as is.
    timer.begin("write");
    const int threads = resolve_threads(options.threads);
    const std::size_t budget = options.memory_budget_mib > 0
                                   ? static_cast<std::size_t>(options.memory_budget_mib) << 20U
                                   : std::size_t{256} << 20U;
    // At most a quarter of the budget for the chunks in flight: two rounds (one computed, one
    // written) of in_flight chunks.
    const std::size_t in_flight = std::clamp<std::size_t>(budget / 8 / std::max<std::size_t>(chunk_bytes, 1), 1,
                                                          static_cast<std::size_t>(threads));
    const Eigen::MatrixX3d change = mark.coefficient_change();
    const auto active = static_cast<double>(referenced.active);
    write_mesh_and_key(key_path, key, [&]() {
        write_file_atomically(output, [&](std::ostream& out) {
            copy_range(file, 0, layout.vertex_offset, out);
            VertexWriter writer(file, layout, referenced, output, out, window);
            double orthogonality = 0.0;
            dynamic_cast<const RbfBasis&>(mark.basis()).synthesize_streamed(
                change, source, in_flight,
                [&](std::size_t begin, std::size_t rows, const double* field) {
                    writer.add(rows, field);
                    progress("write", static_cast<double>(begin + rows) / active);
                },
                &orthogonality);
            writer.finish();
            copy_range(file, layout.vertex_end, file.size(), out);
            mark.describe(writer.summary(), box.diagonal(), orthogonality, &report.stats);
        });
    });
    timer.lap("write");
    report.key = std::move(key);
    return report;
}

}  // namespace meshmark::detail

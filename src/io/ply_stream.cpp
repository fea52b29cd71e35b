// SPDX-License-Identifier: MIT
// The PLY streaming API: the header parsed once into the layout of the vertex records, positioned
// reads, sequential vertex readers and the displaced copy (the face scan is in
// ply_stream_scan.cpp).
#include "meshmark/io/ply_stream.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/detail/ply_stream.h"

namespace meshmark
{
namespace detail
{

InputFile::InputFile(const std::filesystem::path& path) : path_(path)
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

InputFile::~InputFile()
{
    ::close(fd_);
}

std::size_t InputFile::read_some(std::uint64_t offset, std::size_t n, char* out) const
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

void InputFile::read_exactly(std::uint64_t offset, std::size_t n, char* out) const
{
    if (read_some(offset, n, out) != n)
    {
        fail_io(path_,
                "truncated binary data: the file ends before byte " + std::to_string(offset + n));
    }
}

bool SequentialReader::refill(std::size_t n)
{
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

namespace
{

constexpr std::size_t kHeaderLimit = std::size_t{1} << 20U;
constexpr std::size_t kOutputSlice = std::size_t{1} << 20U;

// The start of the file, enough for any header: the parser stops at its end_header line.
std::string read_header_bytes(const InputFile& file)
{
    std::string bytes(static_cast<std::size_t>(std::min<std::uint64_t>(file.size(), kHeaderLimit)),
                      '\0');
    bytes.resize(file.read_some(0, bytes.size(), bytes.data()));
    return bytes;
}

void copy_range(const InputFile& file, std::uint64_t begin, std::uint64_t end, std::ostream& out)
{
    std::vector<char> buffer(kOutputSlice);
    while (begin < end)
    {
        const auto n =
            static_cast<std::size_t>(std::min<std::uint64_t>(buffer.size(), end - begin));
        file.read_exactly(begin, n, buffer.data());
        out.write(buffer.data(), static_cast<std::streamsize>(n));
        begin += n;
    }
}

// The vertex records from a vertex on, one at a time, read in windows of whole records.
class VertexRecords
{
public:
    VertexRecords(const PlyStream::Impl& layout, std::uint64_t first, std::size_t window)
        : layout_(layout),
          in_(layout.file, layout.vertex_offset + first * layout.stride,
              static_cast<std::size_t>(std::max<std::uint64_t>(1, window / layout.stride) *
                                       layout.stride)),
          vertex_(first)
    {
    }
    // The record of the next vertex (valid until the next call).
    const char* next()
    {
        if (!in_.ensure(static_cast<std::size_t>(layout_.stride)))
        {
            fail_io(layout_.file.path(), "truncated vertex section");  // excluded by refusal()
        }
        const char* record = in_.data();
        in_.skip(static_cast<std::size_t>(layout_.stride));
        ++vertex_;
        return record;
    }
    [[nodiscard]] std::uint64_t vertex() const noexcept { return vertex_; }  // of the next record

private:
    const PlyStream::Impl& layout_;
    SequentialReader in_;
    std::uint64_t vertex_;
};

}  // namespace
}  // namespace detail

// Analysis: the header, then the elements up to the vertices (their sizes give its offset).
PlyStream::Impl::Impl(const std::filesystem::path& path) : file(path)
{
    header = detail::parse_ply_header(path, detail::read_header_bytes(file));
    for (const auto& element : header.elements)
    {
        if (element.role == detail::Role::Vertex)
        {
            vertex_count = element.count;
        }
        else if (element.role == detail::Role::Faces || element.role == detail::Role::Strips)
        {
            face_records += element.count;
        }
    }
    if (header.encoding == detail::PlyEncoding::Ascii)
    {
        refusal = "it is an ASCII PLY (only binary PLY files are streamed)";
        return;
    }
    is_big_endian = header.encoding == detail::PlyEncoding::BinaryBigEndian;
    std::uint64_t offset = header.body_offset;
    for (std::size_t e = 0; e < header.elements.size(); ++e)
    {
        const auto& element = header.elements[e];
        bool is_fixed = false;
        const auto size = detail::min_record_size(element, is_fixed);
        if (element.role == detail::Role::Vertex)
        {
            if (!is_fixed)
            {
                refusal = "its vertex element has a list property, so vertex records vary in size";
                return;
            }
            vertex_element = e;
            vertex_offset = offset;
            stride = size;
            for (std::size_t d = 0; d < 3; ++d)
            {
                types[d] = element.properties[element.axes[d]].type;
                for (std::size_t p = 0; p < element.axes[d]; ++p)
                {
                    field_offsets[d] += detail::scalar_size(element.properties[p].type);
                }
            }
            const auto available = file.size() > offset ? file.size() - offset : 0;
            if (size > 0 && element.count > available / size)
            {
                truncation = "truncated binary data: element 'vertex' declares " +
                             std::to_string(element.count) + " records of " + std::to_string(size) +
                             " bytes, but only " + std::to_string(available) +
                             " bytes follow byte offset " + std::to_string(offset);
            }
            vertex_end = offset + element.count * size;
            return;
        }
        if (!is_fixed)
        {
            refusal = "element '" + element.name + "' before the vertices has a list property";
            return;
        }
        offset += element.count * size;
    }
    refusal = "it has no vertex element";
}

std::uint64_t ReferencedVertices::select(std::uint64_t row) const
{
    if (flags.empty())
    {
        return row;
    }
    const auto block =
        static_cast<std::size_t>(std::upper_bound(active_before.begin(), active_before.end(), row) -
                                 active_before.begin() - 1);
    std::uint64_t count = active_before[block];
    for (std::uint64_t v = block * kSelectBlock;; ++v)
    {
        if (flags[v] != 0)
        {
            if (count == row)
            {
                return v;
            }
            ++count;
        }
    }
}

PlyStream::PlyStream(const std::filesystem::path& path) : impl_(std::make_unique<Impl>(path)) {}
PlyStream::~PlyStream() = default;
PlyStream::PlyStream(PlyStream&&) noexcept = default;
PlyStream& PlyStream::operator=(PlyStream&&) noexcept = default;

const std::filesystem::path& PlyStream::path() const noexcept
{
    return impl_->file.path();
}
std::uint64_t PlyStream::file_size() const noexcept
{
    return impl_->file.size();
}
std::uint64_t PlyStream::vertex_count() const noexcept
{
    return impl_->vertex_count;
}
std::uint64_t PlyStream::face_records() const noexcept
{
    return impl_->face_records;
}

std::uint64_t PlyStream::read_memory_bytes() const noexcept
{
    return impl_->file.size() + 24 * impl_->vertex_count + 12 * impl_->face_records;
}

std::string PlyStream::refusal() const
{
    if (impl_->refusal.empty() && !impl_->truncation.empty())
    {
        detail::fail_io(impl_->file.path(), impl_->truncation);
    }
    return impl_->refusal;
}

std::array<double, 3> PlyStream::position(std::uint64_t vertex) const
{
    std::vector<char> record(static_cast<std::size_t>(impl_->stride));
    impl_->file.read_exactly(impl_->vertex_offset + vertex * impl_->stride, record.size(),
                             record.data());
    std::array<double, 3> xyz{};
    impl_->load(record.data(), xyz.data());
    return xyz;
}

struct PlyVertexReader::Impl
{
    const PlyStream::Impl& layout;
    detail::VertexRecords records;
};

PlyVertexReader::PlyVertexReader(const PlyStream& file, std::uint64_t first_vertex,
                                 std::size_t window_bytes)
    : impl_(std::make_unique<Impl>(
          Impl{*file.impl_, detail::VertexRecords(*file.impl_, first_vertex, window_bytes)}))
{
}
PlyVertexReader::~PlyVertexReader() = default;

std::uint64_t PlyVertexReader::vertex() const noexcept
{
    return impl_->records.vertex();
}

void PlyVertexReader::read(std::size_t count, double* xyz)
{
    for (std::size_t i = 0; i < count; ++i)
    {
        impl_->layout.load(impl_->records.next(), xyz + 3 * i);
    }
}

void PlyVertexReader::read_active(const ReferencedVertices& referenced, std::size_t count,
                                  double* xyz, std::int32_t* rows)
{
    for (std::size_t i = 0; i < count;)
    {
        const auto vertex = impl_->records.vertex();
        const char* record = impl_->records.next();
        if (referenced.is_active(vertex))
        {
            impl_->layout.load(record, xyz + 3 * i);
            if (rows != nullptr)
            {
                rows[i] = static_cast<std::int32_t>(vertex);
            }
            ++i;
        }
    }
}

void PlyVertexReader::skip_active(const ReferencedVertices& referenced, std::size_t count)
{
    for (std::size_t i = 0; i < count;)
    {
        i += referenced.is_active(impl_->records.vertex()) ? 1U : 0U;
        (void)impl_->records.next();
    }
}

struct PlyDisplacedCopy::Impl
{
    static constexpr std::array<double, 3> kZero{0.0, 0.0, 0.0};

    // The next vertex record, displaced by d, into the slice.
    void emit(const double* d)
    {
        const auto v = records.vertex();
        const char* record = records.next();
        const std::size_t at = slice.size();
        slice.insert(slice.end(), record, record + layout.stride);
        char* target = slice.data() + at;
        for (std::size_t axis = 0; axis < 3; ++axis)
        {
            const double old_value = detail::load_scalar(record + layout.field_offsets[axis],
                                                         layout.types[axis], layout.is_big_endian);
            detail::patch_coordinate(target + layout.field_offsets[axis], layout.types[axis],
                                     layout.is_big_endian, old_value,
                                     d[axis] + old_value,  // as `marked = field; marked += V`
                                     output, v);
        }
        if (slice.size() >= detail::kOutputSlice)
        {
            flush();
        }
    }
    void flush()
    {
        out.write(slice.data(), static_cast<std::streamsize>(slice.size()));
        slice.clear();
    }

    const PlyStream::Impl& layout;
    const ReferencedVertices& referenced;
    const std::filesystem::path& output;
    std::ostream& out;
    detail::VertexRecords records;
    std::vector<char> slice;
};

PlyDisplacedCopy::PlyDisplacedCopy(const PlyStream& file, const ReferencedVertices& referenced,
                                   const std::filesystem::path& output, std::ostream& out,
                                   std::size_t window_bytes)
    : impl_(std::make_unique<Impl>(Impl{*file.impl_,
                                        referenced,
                                        output,
                                        out,
                                        detail::VertexRecords(*file.impl_, 0, window_bytes),
                                        {}}))
{
    impl_->slice.reserve(detail::kOutputSlice + impl_->layout.stride);
    detail::copy_range(impl_->layout.file, 0, impl_->layout.vertex_offset, out);
}
PlyDisplacedCopy::~PlyDisplacedCopy() = default;

void PlyDisplacedCopy::add(std::size_t rows, const double* displacement)
{
    Impl& copy = *impl_;
    for (std::size_t i = 0; i < rows;)
    {
        if (copy.referenced.is_active(copy.records.vertex()))
        {
            copy.emit(displacement + 3 * i);
            ++i;
        }
        else
        {
            copy.emit(Impl::kZero.data());
        }
    }
}

void PlyDisplacedCopy::finish()
{
    Impl& copy = *impl_;
    while (copy.records.vertex() < copy.layout.vertex_count)
    {
        copy.emit(Impl::kZero.data());
    }
    copy.flush();
    detail::copy_range(copy.layout.file, copy.layout.vertex_end, copy.layout.file.size(), copy.out);
}

}  // namespace meshmark

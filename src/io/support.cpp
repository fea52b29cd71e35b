// SPDX-License-Identifier: MIT
#include "io/detail/support.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "meshmark/core/error.h"
#include "meshmark/io/file_bytes.h"

namespace meshmark::detail
{
namespace
{

// Closes a POSIX descriptor on every path out of read_file_bytes.
class Descriptor
{
public:
    explicit Descriptor(int fd) noexcept : fd_(fd) {}
    Descriptor(const Descriptor&) = delete;
    Descriptor& operator=(const Descriptor&) = delete;
    ~Descriptor()
    {
        if (fd_ >= 0)
        {
            ::close(fd_);
        }
    }
    [[nodiscard]] int get() const noexcept { return fd_; }

private:
    int fd_;
};

}  // namespace

namespace
{

// A clause that may end with a library's own period ("...attributes."): one period in all.
std::string clause(std::string what)
{
    while (!what.empty() && (what.back() == '.' || what.back() == ' ' || what.back() == '\n'))
    {
        what.pop_back();
    }
    return what;
}

}  // namespace

void fail_io(const std::filesystem::path& path, const std::string& what)
{
    throw IoError(path.string() + ": " + clause(what) + ".");
}

void fail_mesh(const std::filesystem::path& path, const std::string& what)
{
    throw InvalidMesh(path.string() + ": " + clause(what) + ".");
}

std::string quoted(std::string_view token)
{
    constexpr std::size_t kMaxShown = 40;
    std::string result = "'";
    for (std::size_t i = 0; i < token.size() && i < kMaxShown; ++i)
    {
        const auto c = static_cast<unsigned char>(token[i]);
        if (c < 0x20 || c >= 0x7f)
        {
            constexpr std::string_view kHex = "0123456789abcdef";
            result += "\\x";
            result += kHex[c >> 4U];
            result += kHex[c & 0xfU];
        }
        else
        {
            result += static_cast<char>(c);
        }
    }
    if (token.size() > kMaxShown)
    {
        result += "...";
    }
    result += "'";
    return result;
}

std::optional<std::filesystem::path> relinked(const std::filesystem::path& source_folder,
                                              const std::filesystem::path& output_folder,
                                              const std::filesystem::path& name,
                                              const std::filesystem::path& link_folder)
{
    namespace fs = std::filesystem;
    const fs::path from_folder = source_folder.empty() ? fs::path(".") : source_folder;
    const fs::path to_folder = output_folder.empty() ? fs::path(".") : output_folder;
    std::error_code error;
    const fs::path from = from_folder / name;
    const fs::path reader_folder = link_folder.empty() ? to_folder : link_folder;
    if (fs::equivalent(from_folder, reader_folder, error) || !fs::is_regular_file(from, error))
    {
        return std::nullopt;
    }
    const fs::path there = to_folder / name;
    if (fs::is_regular_file(there, error) && read_file_bytes(there) == read_file_bytes(from))
    {
        return std::nullopt;
    }
    fs::path reach =
        fs::relative(fs::absolute(from, error), fs::absolute(reader_folder, error), error);
    return error ? fs::path() : reach;
}

// POSIX open/fstat/read rather than iostreams: one allocation of the exact size and one
// read call (looped only if the kernel returns less), which is what the speed target needs.
std::string read_file_bytes(const std::filesystem::path& path)
{
    const Descriptor fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd.get() < 0)
    {
        const int err = errno;
        fail_io(path, err == ENOENT
                          ? std::string("no such file")
                          : std::string("cannot open the file (") + std::strerror(err) + ")");
    }
    struct stat info
    {
    };
    if (::fstat(fd.get(), &info) != 0)
    {
        fail_io(path, std::string("cannot read the file (") + std::strerror(errno) + ")");
    }
    if (S_ISDIR(info.st_mode))
    {
        fail_io(path, "is a directory, not a mesh file");
    }
    std::string bytes(static_cast<std::size_t>(info.st_size), '\0');
    std::size_t done = 0;
    while (done < bytes.size())
    {
        const auto n = ::read(fd.get(), bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR)
        {
            continue;
        }
        if (n < 0)
        {
            fail_io(path, std::string("cannot read the file (") + std::strerror(errno) + ")");
        }
        if (n == 0)
        {
            bytes.resize(done);  // The file shrank while being read.
            break;
        }
        done += static_cast<std::size_t>(n);
    }
    return bytes;
}

bool LineCursor::next(std::string_view& line) noexcept
{
    if (next_ >= text_.size())
    {
        return false;
    }
    const auto end = text_.find('\n', next_);
    const auto stop = end == std::string_view::npos ? text_.size() : end;
    line = text_.substr(next_, stop - next_);
    next_ = end == std::string_view::npos ? text_.size() : end + 1;
    ++line_;
    return true;
}

bool TokenCursor::next(std::string_view& token) noexcept
{
    while (pos_ < line_.size() && is_blank(line_[pos_]))
    {
        ++pos_;
    }
    if (pos_ >= line_.size())
    {
        return false;
    }
    const auto start = pos_;
    while (pos_ < line_.size() && !is_blank(line_[pos_]))
    {
        ++pos_;
    }
    token = line_.substr(start, pos_ - start);
    return true;
}

namespace
{

// Character classes for the token scanner: a table lookup per byte keeps the hot loop of
// ASCII bodies (tens of millions of bytes) free of comparison chains.
enum CharClass : unsigned char
{
    kToken = 0,
    kBlank = 1,
    kNewline = 2,
};

constexpr std::array<unsigned char, 256> make_char_classes()
{
    std::array<unsigned char, 256> classes{};
    for (const char c : {' ', '\t', '\r', '\f', '\v'})
    {
        classes[static_cast<unsigned char>(c)] = kBlank;
    }
    classes[static_cast<unsigned char>('\n')] = kNewline;
    return classes;
}

constexpr auto kCharClasses = make_char_classes();

}  // namespace

std::string_view TokenStream::next() noexcept
{
    const char* p = text_.data() + pos_;
    const char* end = text_.data() + text_.size();
    while (p != end)
    {
        const auto cls = kCharClasses[static_cast<unsigned char>(*p)];
        if (cls == kToken)
        {
            break;
        }
        line_ += cls == kNewline ? 1 : 0;
        ++p;
    }
    const char* start = p;
    while (p != end && kCharClasses[static_cast<unsigned char>(*p)] == kToken)
    {
        ++p;
    }
    pos_ = static_cast<std::size_t>(p - text_.data());
    return {start, static_cast<std::size_t>(p - start)};
}

TriangleMesh make_mesh(const std::vector<double>& xyz, const std::vector<std::size_t>& corners)
{
    TriangleBuffer triangles;
    triangles.reserve(corners.size() / 3);
    for (std::size_t t = 0; t + 2 < corners.size(); t += 3)
    {
        triangles.push(static_cast<std::int32_t>(corners[t]),
                       static_cast<std::int32_t>(corners[t + 1]),
                       static_cast<std::int32_t>(corners[t + 2]));
    }
    return make_mesh(xyz, triangles);
}

TriangleMesh make_mesh(const std::vector<double>& xyz, TriangleBuffer& triangles)
{
    TriangleMesh mesh;
    mesh.V.resize(static_cast<Eigen::Index>(xyz.size() / 3), 3);
    if (!xyz.empty())
    {
        std::memcpy(mesh.V.data(), xyz.data(), xyz.size() * sizeof(double));
    }
    fill_polygons(xyz.data(), triangles);
    mesh.fans = triangles.take_fans();
    mesh.polygons = triangles.take_polygons();
    mesh.F = triangles.take();
    return mesh;
}

void check_finite(const std::filesystem::path& path, const Positions& V)
{
    const double* p = V.data();
    const auto n = static_cast<std::size_t>(V.size());
    for (std::size_t i = 0; i < n; ++i)
    {
        if (!std::isfinite(p[i]))
        {
            fail_mesh(path, "vertex " + std::to_string(i / 3) +
                                " has a non-finite coordinate (NaN or infinity)");
        }
    }
}

}  // namespace meshmark::detail

namespace meshmark::detail
{

std::string index_range(std::uint64_t vertex_count)
{
    if (vertex_count == 0)
    {
        return "but the file has no vertices";
    }
    return "outside 0.." + std::to_string(vertex_count - 1);
}

}  // namespace meshmark::detail

namespace meshmark
{

std::string read_file(const std::filesystem::path& path)
{
    return detail::read_file_bytes(path);
}

}  // namespace meshmark

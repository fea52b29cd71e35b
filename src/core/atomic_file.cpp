// SPDX-License-Identifier: MIT
#include "meshmark/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ext/stdio_filebuf.h>
#include <string>

#include "meshmark/core/error.h"

namespace meshmark {
namespace {

// Removes the temporary file unless released: the cleanup path of every failure.
class TemporaryFile
{
public:
    explicit TemporaryFile(std::string path) : path_(std::move(path)) {}
    TemporaryFile(const TemporaryFile&) = delete;
    TemporaryFile& operator=(const TemporaryFile&) = delete;
    ~TemporaryFile()
    {
        if (!path_.empty())
        {
            ::unlink(path_.c_str());
        }
    }
    void release() { path_.clear(); }
    [[nodiscard]] const std::string& path() const { return path_; }

private:
    std::string path_;
};

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what, int err)
{
    throw IoError(path.string() + ": cannot write the file (" + what + ": " + std::strerror(err) +
                  ").");
}

}  // namespace

void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write,
                           const AtomicWriteOptions& options)
{
    if (!options.allow_overwrite && std::filesystem::exists(path))
    {
        throw IoError(path.string() + ": the file already exists; refusing to overwrite it.");
    }
    const auto directory = path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
    std::string name = path.filename().string();
    name.insert(0, 1, '.');
    name.append(".tmp-XXXXXX");
    std::string pattern = (directory / name).string();
    const int fd = ::mkstemp(pattern.data());
    if (fd < 0)
    {
        fail(path, "cannot create a temporary file in " + directory.string(), errno);
    }
    TemporaryFile temporary(pattern);
    ::fchmod(fd, static_cast<mode_t>(options.permissions));
    {
        __gnu_cxx::stdio_filebuf<char> buffer(fd, std::ios::out | std::ios::binary, 1 << 20);
        std::ostream stream(&buffer);
        write(stream);
        stream.flush();
        if (!stream)
        {
            fail(path, "write failed", errno != 0 ? errno : EIO);
        }
        if (::fsync(fd) != 0)
        {
            fail(path, "fsync failed", errno);
        }
        // The filebuf closes fd when it goes out of scope.
    }
    if (::rename(temporary.path().c_str(), path.c_str()) != 0)
    {
        fail(path, "rename failed", errno);
    }
    temporary.release();
    // Make the rename itself durable.
    const int dir_fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY);
    if (dir_fd >= 0)
    {
        ::fsync(dir_fd);
        ::close(dir_fd);
    }
}

bool is_same_file(const std::filesystem::path& a, const std::filesystem::path& b)
{
    std::error_code ec;
    const bool same = std::filesystem::equivalent(a, b, ec);
    return !ec && same;
}

}  // namespace meshmark

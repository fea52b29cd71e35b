// SPDX-License-Identifier: MIT
#include "meshmark/core/atomic_file.h"

#include <cerrno>
#include <cstring>
#include <string>
#include <vector>

#include <ext/stdio_filebuf.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

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

void sync_directory(const std::filesystem::path& directory)
{
    const int dir_fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir_fd >= 0)
    {
        ::fsync(dir_fd);
        ::close(dir_fd);
    }
}

}  // namespace

void create_parent_directories(const std::filesystem::path& path)
{
    // The missing folders, innermost first.
    std::vector<std::filesystem::path> missing;
    std::error_code ec;
    for (std::filesystem::path folder = path.parent_path();
         !folder.empty() && !std::filesystem::exists(folder, ec); folder = folder.parent_path())
    {
        missing.push_back(folder);
        if (folder == folder.parent_path())
        {
            break;  // a root that does not exist
        }
    }
    const std::filesystem::path parent = path.parent_path();
    if (!parent.empty() && missing.empty() && !std::filesystem::is_directory(parent, ec))
    {
        throw IoError(path.string() + ": cannot create its folder " + parent.string() +
                      " (a file of that name is in the way).");
    }
    for (auto folder = missing.rbegin(); folder != missing.rend(); ++folder)
    {
        if (!std::filesystem::create_directory(*folder, ec) && ec)
        {
            throw IoError(path.string() + ": cannot create its folder " + folder->string() + " (" +
                          ec.message() + ").");
        }
        // Made durable in its parent, like a file's rename.
        sync_directory(folder->parent_path().empty() ? std::filesystem::path(".")
                                                     : folder->parent_path());
    }
}

void write_file_atomically(const std::filesystem::path& path,
                           const std::function<void(std::ostream&)>& write,
                           const AtomicWriteOptions& options)
{
    if (!options.allow_overwrite && std::filesystem::exists(path))
    {
        throw IoError(path.string() + ": the file already exists; refusing to overwrite it.");
    }
    create_parent_directories(path);
    const auto directory =
        path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
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
    sync_directory(directory);  // the rename itself made durable
}

FileIdentity file_identity(const std::filesystem::path& path)
{
    struct stat st = {};
    if (::stat(path.c_str(), &st) != 0)
    {
        return {};
    }
    return {static_cast<std::uint64_t>(st.st_dev), static_cast<std::uint64_t>(st.st_ino)};
}

bool is_same_file(const std::filesystem::path& a, const std::filesystem::path& b)
{
    std::error_code ec;
    const bool same = std::filesystem::equivalent(a, b, ec);
    return !ec && same;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// The exclusive lock on a key file. Written over flock(2) directly: Boost.Interprocess's
// file_lock uses fcntl record locks on Linux, which are held per process (two threads of one
// process would both "hold" it, and closing any descriptor of the file drops it), and it has
// no way to clean its lock file up; what is needed here is a dozen system calls.
#include "meshmark/core/file_lock.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <thread>
#include <utility>

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include "meshmark/core/error.h"

namespace meshmark
{

std::filesystem::path lock_companion(const std::filesystem::path& path)
{
    std::string name(1, '.');  // (appended: GCC 12 warns falsely on "." + std::string)
    name += path.filename().string();
    name += ".lock";
    return path.parent_path() / name;
}

FileLock::FileLock(FileLock&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      companion_(std::move(other.companion_)),
      waited_(other.waited_)
{
}

FileLock& FileLock::operator=(FileLock&& other) noexcept
{
    if (this != &other)
    {
        unlock();
        fd_ = std::exchange(other.fd_, -1);
        companion_ = std::move(other.companion_);
        waited_ = other.waited_;
    }
    return *this;
}

FileLock::~FileLock()
{
    unlock();
}

void FileLock::unlock() noexcept
{
    if (fd_ < 0)
    {
        return;
    }
    // Removed while still held: a waiter that then wins the lock on the removed file sees that
    // its path no longer names it and starts again on a new one (lock_file).
    ::unlink(companion_.c_str());
    ::close(fd_);  // drops the flock
    fd_ = -1;
}

FileLock lock_file(const std::filesystem::path& path, const FileLockOptions& options)
{
    const std::filesystem::path companion = lock_companion(path);
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    const auto deadline = start + options.timeout;
    auto pause = std::chrono::microseconds(500);
    bool told = false;
    for (;;)
    {
        const int fd = ::open(companion.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
        if (fd < 0)
        {
            const int error = errno;
            throw IoError(path.string() + ": cannot create the lock file " +
                          companion.filename().string() + " beside it (" + std::strerror(error) +
                          ").");
        }
        if (::flock(fd, LOCK_EX | LOCK_NB) == 0)
        {
            // Ours, unless the holder we waited for removed this file on release (or another
            // one was created since): then the lock guards nothing; try again.
            struct stat held = {};
            struct stat named = {};
            if (::fstat(fd, &held) == 0 && ::stat(companion.c_str(), &named) == 0 &&
                held.st_dev == named.st_dev && held.st_ino == named.st_ino)
            {
                const double waited = std::chrono::duration<double>(Clock::now() - start).count();
                return FileLock(fd, companion, waited);
            }
            ::close(fd);
            continue;
        }
        const int error = errno;
        ::close(fd);
        if (error != EWOULDBLOCK && error != EINTR)
        {
            throw IoError(path.string() + ": cannot lock it (" + std::strerror(error) + ").");
        }
        if (Clock::now() >= deadline)
        {
            const double waited = std::chrono::duration<double>(Clock::now() - start).count();
            char seconds[32];
            std::snprintf(seconds, sizeof seconds, "%.1f", waited);
            throw IoError(path.string() + ": still in use by another meshmark call after " +
                          seconds +
                          " s of waiting; try again later or wait longer (--lock-timeout).");
        }
        if (!told && options.on_wait)
        {
            options.on_wait();
            told = true;
        }
        // Polled with a growing pause (0.5 ms to 20 ms): flock has no timed wait, and the
        // sections it guards last milliseconds.
        std::this_thread::sleep_for(std::min<Clock::duration>(pause, deadline - Clock::now()));
        pause = std::min(pause * 2, std::chrono::microseconds(20'000));
    }
}

}  // namespace meshmark

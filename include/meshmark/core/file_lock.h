// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>

namespace meshmark
{

/// How long lock_file waits for a lock another process or thread holds, by default (the
/// sections it guards last milliseconds; a minute is chosen by hand; no study on record).
inline constexpr std::chrono::milliseconds kDefaultLockTimeout{60'000};

/// Options of lock_file.
struct FileLockOptions
{
    /// Longest wait for the lock; zero = try once. On expiry lock_file throws IoError.
    std::chrono::milliseconds timeout = kDefaultLockTimeout;
    /// Called once, when the lock is found held (before waiting): a caller's progress note.
    std::function<void()> on_wait;
};

/// \brief An exclusive lock on a file path, held by this object (movable, not copyable).
/// \details The lock is an flock(2) on a hidden companion file ".<name>.lock" in the same
/// directory. flock is taken per open file description, so it excludes other threads of the
/// same process as well as other processes, and the kernel drops it when its holder dies
/// (kill -9 included): a crashed holder never leaves the path locked. The companion file is
/// removed on release; a waiter that wins a companion removed meanwhile tries again, so two
/// holders never coexist. Local file systems only: flock is not reliable on every network file
/// system.
class FileLock
{
public:
    FileLock() = default;
    FileLock(FileLock&& other) noexcept;
    FileLock& operator=(FileLock&& other) noexcept;
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;
    ~FileLock();

    /// Release now (also done by the destructor).
    void unlock() noexcept;
    [[nodiscard]] bool is_locked() const { return fd_ >= 0; }
    /// Seconds spent waiting for the lock.
    [[nodiscard]] double waited_seconds() const { return waited_; }

private:
    friend FileLock lock_file(const std::filesystem::path&, const FileLockOptions&);
    FileLock(int fd, std::filesystem::path companion, double waited)
        : fd_(fd), companion_(std::move(companion)), waited_(waited)
    {
    }
    int fd_ = -1;
    std::filesystem::path companion_;
    double waited_ = 0.0;
};

/// The companion file whose flock guards \p path: ".<name>.lock" next to it.
[[nodiscard]] std::filesystem::path lock_companion(const std::filesystem::path& path);

/// \brief Take the exclusive lock on \p path (which need not exist), waiting up to the timeout.
/// \throws IoError naming \p path when the wait expires (with the time waited) or the companion
/// file cannot be created (its directory missing or not writable).
[[nodiscard]] FileLock lock_file(const std::filesystem::path& path,
                                 const FileLockOptions& options = {});

}  // namespace meshmark

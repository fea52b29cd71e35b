// SPDX-License-Identifier: MIT
#include "meshmark/core/file_lock.h"

#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include "meshmark/core/error.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

using namespace std::chrono_literals;

TEST(FileLockTest, excludes_other_threads_and_cleans_its_companion_up)
{
    const auto dir = test::temp_dir("lock1");
    const auto key = dir / "fam.json";
    // Eight threads add one to a counter under the lock, reading and writing it with a pause
    // between: without mutual exclusion increments are lost.
    int counter = 0;
    std::atomic<int> inside{0};
    std::atomic<int> most_inside{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t)
    {
        threads.emplace_back(
            [&]
            {
                for (int i = 0; i < 25; ++i)
                {
                    const FileLock lock = lock_file(key);
                    const int now = ++inside;
                    most_inside = std::max(most_inside.load(), now);
                    const int seen = counter;
                    std::this_thread::sleep_for(100us);
                    counter = seen + 1;
                    --inside;
                }
            });
    }
    for (auto& thread : threads)
    {
        thread.join();
    }
    EXPECT_EQ(counter, 200);
    EXPECT_EQ(most_inside.load(), 1);
    EXPECT_FALSE(std::filesystem::exists(lock_companion(key)));
}

TEST(FileLockTest, a_held_lock_times_out_with_a_sentence_naming_the_file)
{
    const auto dir = test::temp_dir("lock2");
    const auto key = dir / "fam.json";
    const FileLock held = lock_file(key);
    bool told = false;
    try
    {
        (void)lock_file(key, {.timeout = 50ms, .on_wait = [&] { told = true; }});
        FAIL() << "locked twice";
    }
    catch (const IoError& e)
    {
        const std::string what = e.what();
        EXPECT_NE(what.find(key.string()), std::string::npos) << what;
        EXPECT_NE(what.find("--lock-timeout"), std::string::npos) << what;
    }
    EXPECT_TRUE(told);
}

TEST(FileLockTest, a_killed_holder_releases_the_lock)
{
    const auto dir = test::temp_dir("lock3");
    const auto key = dir / "fam.json";
    int ready[2];
    ASSERT_EQ(::pipe(ready), 0);
    const pid_t child = ::fork();
    ASSERT_GE(child, 0);
    if (child == 0)
    {
        const FileLock lock = lock_file(key);
        const char byte = 1;
        (void)!::write(ready[1], &byte, 1);
        ::pause();  // killed here, the lock held
        ::_exit(0);
    }
    char byte = 0;
    ASSERT_EQ(::read(ready[0], &byte, 1), 1);
    EXPECT_THROW((void)lock_file(key, {.timeout = 20ms}), IoError);  // held by the child
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    // The companion file stays behind (nobody removed it), and locks at once.
    EXPECT_TRUE(std::filesystem::exists(lock_companion(key)));
    const FileLock lock = lock_file(key, {.timeout = 1s});
    EXPECT_TRUE(lock.is_locked());
    EXPECT_LT(lock.waited_seconds(), 0.5);
    ::close(ready[0]);
    ::close(ready[1]);
}

TEST(FileLockTest, a_missing_folder_is_one_clear_error)
{
    const auto dir = test::temp_dir("lock4");
    EXPECT_THROW((void)lock_file(dir / "missing" / "fam.json"), IoError);
}

}  // namespace
}  // namespace meshmark

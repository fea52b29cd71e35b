// SPDX-License-Identifier: MIT
#include "meshmark/core/atomic_file.h"

#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <sys/stat.h>

#include "meshmark/core/error.h"
#include "support/test_paths.h"

namespace meshmark
{

namespace
{
std::string slurp(const std::filesystem::path& p)
{
    std::ifstream in(p, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}
std::size_t entries(const std::filesystem::path& dir)
{
    return static_cast<std::size_t>(std::distance(std::filesystem::directory_iterator(dir), {}));
}
}  // namespace

TEST(AtomicFileTest, writes_complete_file_with_requested_mode)
{
    const auto dir = test::temp_dir("atomic1");
    const auto path = dir / "out.txt";
    write_file_atomically(path, [](std::ostream& out) { out << "hello"; }, {.permissions = 0600});
    EXPECT_EQ(slurp(path), "hello");
    struct stat st
    {
    };
    ASSERT_EQ(::stat(path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777U, 0600U);
    EXPECT_EQ(entries(dir), 1U);
}

TEST(AtomicFileTest, failing_writer_leaves_previous_content_and_no_temporary)
{
    const auto dir = test::temp_dir("atomic2");
    const auto path = dir / "out.txt";
    write_file_atomically(path, [](std::ostream& out) { out << "old"; });
    EXPECT_THROW(write_file_atomically(path,
                                       [](std::ostream& out)
                                       {
                                           out << "partial";
                                           throw IoError("boom");
                                       }),
                 IoError);
    EXPECT_EQ(slurp(path), "old");
    EXPECT_EQ(entries(dir), 1U);
}

TEST(AtomicFileTest, refuses_overwrite_when_asked)
{
    const auto dir = test::temp_dir("atomic3");
    const auto path = dir / "out.txt";
    write_file_atomically(path, [](std::ostream& out) { out << "x"; });
    EXPECT_THROW(write_file_atomically(path, [](std::ostream& out) { out << "y"; },
                                       {.allow_overwrite = false}),
                 IoError);
    EXPECT_EQ(slurp(path), "x");
}

TEST(AtomicFileTest, creates_missing_folders_and_names_one_that_cannot_be)
{
    const auto dir = test::temp_dir("atomic4");
    write_file_atomically(dir / "copies" / "deeper" / "f.txt",
                          [](std::ostream& out) { out << "y"; });
    EXPECT_EQ(slurp(dir / "copies" / "deeper" / "f.txt"), "y");
    EXPECT_EQ(entries(dir / "copies"), 1U);
    // A file where a folder should be: one sentence naming it, nothing written.
    write_file_atomically(dir / "plain", [](std::ostream& out) { out << "z"; });
    try
    {
        write_file_atomically(dir / "plain" / "sub" / "f.txt",
                              [](std::ostream& out) { out << "y"; });
        FAIL() << "wrote under a file";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find((dir / "plain").string()), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(slurp(dir / "plain"), "z");
}

}  // namespace meshmark

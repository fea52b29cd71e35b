// SPDX-License-Identifier: MIT
// Negative fixtures and hostile inputs: each fails with a typed error naming the file.
#include "meshmark/core/error.h"

#include <chrono>

#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{

using test::fixture;

namespace
{

template <typename E>
void expect_read_error(const std::filesystem::path& path, std::vector<std::string> parts)
{
    parts.push_back(path.string());
    test::expect_error<E>([&] { static_cast<void>(read_mesh_file(path)); }, parts);
}

}  // namespace

TEST(IoErrorTest, rejects_missing_file_naming_it)
{
    expect_read_error<IoError>(fixture("does_not_exist.ply"), {"no such file"});
}

TEST(IoErrorTest, rejects_malformed_ply_header)
{
    expect_read_error<IoError>(fixture("bad_header.ply"), {"line 4", "'flot'"});
}

TEST(IoErrorTest, rejects_truncated_binary_ply)
{
    expect_read_error<IoError>(fixture("truncated_binary.ply"),
                               {"truncated", "vertex", "50 bytes"});
}

TEST(IoErrorTest, rejects_truncated_binary_stl)
{
    expect_read_error<IoError>(fixture("truncated_binary.stl"), {"truncated", "12 facets", "234"});
}

TEST(IoErrorTest, rejects_out_of_range_obj_face_naming_it)
{
    expect_read_error<InvalidMesh>(fixture("face_index_out_of_range.obj"),
                                   {"face 2", "line 8", "vertex index 9"});
}

TEST(IoErrorTest, rejects_nan_coordinate)
{
    expect_read_error<InvalidMesh>(fixture("nan_coordinate.off"), {"vertex 1", "non-finite"});
}

TEST(IoErrorTest, rejects_huge_vertex_counts_fast)
{
    // 2^31 - 1 vertices claimed over a few bytes: refused before anything is allocated.
    const auto start = std::chrono::steady_clock::now();
    expect_read_error<IoError>(fixture("huge_count_header.ply"), {"2147483647", "vertex"});
    expect_read_error<IoError>(fixture("huge_count_binary.ply"), {"2147483647", "truncated"});
    const auto dir = test::temp_dir("io_huge");
    test::put_bytes(dir / "h.off", "OFF\n2147483647 2147483647 0\n0 0 0\n");
    expect_read_error<IoError>(dir / "h.off", {"2147483647 vertices"});
    test::put_bytes(dir / "h2.ply",
                    "ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\n"
                    "property float x\nproperty float y\nproperty float z\nend_header\n");
    expect_read_error<IoError>(dir / "h2.ply", {"2147483648", "32-bit"});
    test::put_bytes(dir / "h3.ply",
                    "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                    "property float x\nproperty float y\nproperty float z\nelement face 1\n"
                    "property list int int vertex_indices\nend_header\n\xff\xff\xff\x7f");
    expect_read_error<IoError>(dir / "h3.ply", {"truncated", "face"});
    const auto elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start);
    EXPECT_LT(elapsed.count(), 1.0);
}

TEST(IoErrorTest, rejects_out_of_range_ply_face_index_naming_the_face)
{
    const auto dir = test::temp_dir("io_ply_index");
    test::put_bytes(dir / "c.ply", test::replaced_once(test::file_bytes(fixture("cube_ascii.ply")),
                                                       "4 1 2 6 5", "4 1 2 8 5"));
    expect_read_error<InvalidMesh>(dir / "c.ply", {"face 5", "vertex index 8", "0..7"});
    // The binary fast path names the face the same way.
    auto binary = test::file_bytes(fixture("cube_binary_le.ply"));
    binary[binary.size() - 1] = '\x7f';  // High byte of the last index of face 5.
    test::put_bytes(dir / "b.ply", binary);
    expect_read_error<InvalidMesh>(dir / "b.ply", {"face 5", "vertex index"});
}

TEST(IoErrorTest, rejects_bad_tokens_with_line_numbers)
{
    const auto dir = test::temp_dir("io_tokens");
    test::put_bytes(dir / "t.ply", test::replaced_once(test::file_bytes(fixture("cube_ascii.ply")),
                                                       "1 1 1.1", "1 1 1,1"));
    expect_read_error<IoError>(dir / "t.ply", {"line 17", "'1,1'", "vertex 6"});
    test::put_bytes(dir / "t.obj", "v 0 0 0\nv 1 0 0\nv 0 x 0\nf 1 2 3\n");
    expect_read_error<IoError>(dir / "t.obj", {"line 3", "'x'"});
    test::put_bytes(dir / "f.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/ 3\n");
    expect_read_error<IoError>(dir / "f.obj", {"line 4", "'2/'"});
    test::put_bytes(dir / "t.stl",
                    "solid s\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n"
                    "vertex 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid s\n");
    expect_read_error<IoError>(dir / "t.stl", {"line 5"});
}

TEST(IoErrorTest, rejects_unsupported_layouts)
{
    const auto dir = test::temp_dir("io_layout");
    test::put_bytes(dir / "nox.ply",
                    "ply\nformat ascii 1.0\nelement vertex 1\nproperty float u\n"
                    "property float y\nproperty float z\nend_header\n0 0 0\n");
    expect_read_error<IoError>(dir / "nox.ply", {"no scalar 'x' property"});
    test::put_bytes(dir / "nov.ply",
                    "ply\nformat ascii 1.0\nelement point 1\nproperty float x\n"
                    "end_header\n0\n");
    expect_read_error<IoError>(dir / "nov.ply", {"no 'vertex' element"});
    test::put_bytes(dir / "notply.ply", "solid x\n");
    expect_read_error<IoError>(dir / "notply.ply", {"not a PLY file"});
    test::put_bytes(dir / "noend.ply", "ply\nformat ascii 1.0\nelement vertex 0\n");
    expect_read_error<IoError>(dir / "noend.ply", {"end_header"});
    test::put_bytes(dir / "four.off", "4OFF\n1 0 0\n0 0 0 0\n");
    expect_read_error<IoError>(dir / "four.off", {"not an OFF file"});
    test::put_bytes(dir / "short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n");
    expect_read_error<IoError>(dir / "short.off", {"end of file", "3 vertices"});
    test::put_bytes(dir / "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
    expect_read_error<InvalidMesh>(dir / "zero.obj", {"face 0", "index 0"});
    test::put_bytes(dir / "neg.obj", "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n");
    expect_read_error<InvalidMesh>(dir / "neg.obj", {"face 0", "-3", "only 2 vertices"});
    test::put_bytes(dir / "strip.ply",
                    "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                    "property float y\nproperty float z\nelement tristrips 1\n"
                    "property list int int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n0 1 0\n4 0 1 2 -2\n");
    expect_read_error<InvalidMesh>(dir / "strip.ply", {"tristrips record 0", "-2"});
}

TEST(IoErrorTest, rejects_a_directory)
{
    const auto dir = test::temp_dir("io_dir");
    std::filesystem::create_directories(dir / "d.ply");
    expect_read_error<IoError>(dir / "d.ply", {"directory"});
}

}  // namespace meshmark

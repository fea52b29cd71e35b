// SPDX-License-Identifier: MIT
// Hostile sizes: headers and texts that claim or contain far more than they should must be
// rejected quickly, with a clear meshmark::Error, and without allocating what they claim.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>
#include <sys/resource.h>

#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/watermark/key.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

/// Peak resident set size of this process in MiB (Linux reports ru_maxrss in KiB).
long peak_rss_mib()
{
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return usage.ru_maxrss / 1024;
}

/// Runs \p action, which must throw an \p E whose message contains \p needle, in under
/// 2 s and growing the peak RSS by less than 200 MiB.
template <class E>
void expect_fast_error(const std::function<void()>& action, const std::string& needle)
{
    const long rss_before = peak_rss_mib();
    const auto start = std::chrono::steady_clock::now();
    try
    {
        action();
        ADD_FAILURE() << "no exception; expected one mentioning '" << needle << "'";
    }
    catch (const E& e)
    {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(seconds, 2.0);
    EXPECT_LT(peak_rss_mib() - rss_before, 200);
}

fs::path put(const fs::path& path, const std::string& bytes)
{
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
}

std::string ply_header(const std::string& format, const std::string& vertices,
                       const std::string& faces)
{
    return "ply\nformat " + format + " 1.0\nelement vertex " + vertices +
           "\nproperty float x\nproperty float y\nproperty float z\nelement face " + faces +
           "\nproperty list uchar int vertex_indices\nend_header\n";
}

TEST(HostileInput, PlyClaiming2Pow31VerticesOrFacesFailsFast)
{
    const fs::path dir = test::temp_dir("hostile_ply_counts");
    const std::string triangle = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    for (const char* format : {"ascii", "binary_little_endian", "binary_big_endian"})
    {
        SCOPED_TRACE(format);
        const auto v = put(dir / "v.ply", ply_header(format, "2147483648", "1") + triangle);
        expect_fast_error<IoError>([&] { static_cast<void>(read_mesh_file(v)); }, "v.ply");
        const auto f = put(dir / "f.ply", ply_header(format, "3", "2147483648") + triangle);
        expect_fast_error<IoError>([&] { static_cast<void>(read_mesh_file(f)); }, "f.ply");
        const auto both = put(dir / "b.ply", ply_header(format, "4294967295", "4294967295"));
        expect_fast_error<IoError>([&] { static_cast<void>(read_mesh_file(both)); }, "b.ply");
    }
}

TEST(HostileInput, PlyFaceListOf255Indices)
{
    const fs::path dir = test::temp_dir("hostile_ply_list");
    std::string vertices;
    for (int i = 0; i < 255; ++i)
    {
        vertices += std::to_string(i) + " " + std::to_string(i % 7) + " 0\n";
    }
    std::string polygon = "255";
    for (int i = 0; i < 255; ++i)
    {
        polygon += " " + std::to_string(i);
    }
    // A complete 255-gon is valid: fan-triangulated into 253 triangles.
    const auto ok =
        put(dir / "ok.ply", ply_header("ascii", "255", "1") + vertices + polygon + "\n");
    EXPECT_EQ(read_mesh(ok).face_count(), 253);
    // A length of 255 followed by three indices is truncated, not read past the end.
    const auto short_list =
        put(dir / "short.ply", ply_header("ascii", "3", "1") + "0 0 0\n1 0 0\n0 1 0\n255 0 1 2\n");
    expect_fast_error<IoError>([&] { static_cast<void>(read_mesh_file(short_list)); }, "short.ply");
    std::string binary = ply_header("binary_little_endian", "3", "1");
    binary.append(36, '\0');
    binary += '\xff';
    binary.append(12, '\0');
    const auto short_binary = put(dir / "short_bin.ply", binary);
    expect_fast_error<IoError>([&] { static_cast<void>(read_mesh_file(short_binary)); },
                               "short_bin.ply");
}

TEST(HostileInput, DeeplyNestedKeyJsonFailsFast)
{
    const std::string open(100000, '[');
    expect_fast_error<IoError>([&] { static_cast<void>(parse_key(open, "deep.key")); }, "deep.key");
    const std::string closed = open + std::string(100000, ']');
    expect_fast_error<IoError>([&] { static_cast<void>(parse_key(closed, "deep.key")); }, "deep");
    std::string objects;
    for (int i = 0; i < 50000; ++i)
    {
        objects += "{\"a\":";
    }
    expect_fast_error<IoError>([&] { static_cast<void>(parse_key(objects, "obj.key")); },
                               "obj.key");
}

TEST(HostileInput, HugeKeyJsonFailsFast)
{
    // 17 MiB of valid JSON: a key is < 1 KiB, a family key of 100,000 recipients about 6 MiB,
    // so this is refused before parsing.
    const std::string huge =
        "{\"format\":\"meshmark-key\",\"pad\":\"" + std::string(17U << 20U, 'x') + "\"}";
    expect_fast_error<IoError>([&] { static_cast<void>(parse_key(huge, "huge.key")); },
                               "too large");
    const fs::path dir = test::temp_dir("hostile_key");
    const auto path = put(dir / "huge.key", huge);
    expect_fast_error<IoError>([&] { static_cast<void>(read_key(path)); }, "too large");
}

TEST(HostileInput, KeyFieldsOfTheWrongKindAreIoErrors)
{
    // Each of these once escaped as a nlohmann exception or relied on an unchecked conversion.
    for (const char* text : {R"({"format":1})", R"({"format":null,"version":1})", R"([1,2,3])",
                             R"("meshmark-key")", R"({"format":"meshmark-key","version":1e300})",
                             R"({"format":"meshmark-key","version":1.5})",
                             R"({"format":"meshmark-key","version":18446744073709551615})"})
    {
        SCOPED_TRACE(text);
        expect_fast_error<IoError>([&] { static_cast<void>(parse_key(text, "k.key")); }, "k.key");
    }
}

}  // namespace
}  // namespace meshmark

// SPDX-License-Identifier: MIT
// Mutated copies of tiny valid files in every format (byte flips, truncations, deleted and
// duplicated ranges, extreme numbers in place of numbers): the reader must either return a
// consistent mesh or throw a meshmark::Error, never anything else. The slow, CLI-level version
// of this study is bench/reliability/mutate.py (docs/reliability.md).
#include <array>
#include <cctype>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "support/test_paths.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using Bytes = std::vector<char>;

Bytes bytes_of(const fs::path& path)
{
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::size_t below(Rng& rng, std::size_t n)
{
    return static_cast<std::size_t>(rng.below(static_cast<std::uint64_t>(n)));
}

bool is_number_char(char c)
{
    return std::isdigit(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '-' || c == 'e';
}

/// One random mutation of \p in (\p in is not empty).
Bytes mutate(Rng& rng, const Bytes& in)
{
    Bytes out = in;
    const std::size_t n = in.size();
    switch (rng.below(5))
    {
        case 0:  // flip a few bytes
            for (std::uint64_t i = 0, k = 1 + rng.below(4); i < k; ++i)
            {
                out[below(rng, n)] = static_cast<char>(rng.below(256));
            }
            break;
        case 1:  // truncate
            out.resize(below(rng, n));
            break;
        case 2:  // delete a range
        {
            const std::size_t a = below(rng, n);
            const std::size_t b = std::min(n, a + 1 + below(rng, 64));
            out.erase(out.begin() + static_cast<std::ptrdiff_t>(a),
                      out.begin() + static_cast<std::ptrdiff_t>(b));
            break;
        }
        case 3:  // duplicate a range
        {
            const std::size_t a = below(rng, n);
            const std::size_t b = std::min(n, a + 1 + below(rng, 64));
            out.insert(out.begin() + static_cast<std::ptrdiff_t>(b),
                       in.begin() + static_cast<std::ptrdiff_t>(a),
                       in.begin() + static_cast<std::ptrdiff_t>(b));
            break;
        }
        default:  // replace the number (or bytes) at a random place by an extreme value
        {
            static const std::array<std::string, 8> extremes = {
                "0", "-1", "2147483648", "4294967295", "1e309", "nan", "99999999999999999999", ""};
            std::size_t a = below(rng, n);
            std::size_t b = a;
            while (a > 0 && is_number_char(in[a - 1]))
            {
                --a;
            }
            while (b < n && is_number_char(in[b]))
            {
                ++b;
            }
            const std::string& value = extremes[below(rng, extremes.size())];
            out.erase(out.begin() + static_cast<std::ptrdiff_t>(a),
                      out.begin() + static_cast<std::ptrdiff_t>(b));
            out.insert(out.begin() + static_cast<std::ptrdiff_t>(a), value.begin(), value.end());
            break;
        }
    }
    return out;
}

enum class Outcome
{
    read,
    rejected,
    escaped,
};

/// Read \p data as a file named \p path; a read mesh must have every index in range.
Outcome read_bytes(const fs::path& path, const Bytes& data, std::string& what)
{
    {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(data.data(), static_cast<std::streamsize>(data.size()));
    }
    try
    {
        const MeshFile file = read_mesh_file(path);
        const TriangleMesh& mesh = file.mesh;
        if (mesh.face_count() > 0 &&
            (mesh.F.minCoeff() < 0 || mesh.F.maxCoeff() >= mesh.vertex_count()))
        {
            what = "a face index is out of range";
            return Outcome::escaped;
        }
        return Outcome::read;
    }
    catch (const Error&)
    {
        return Outcome::rejected;
    }
    catch (const std::exception& e)
    {
        what = e.what();
        return Outcome::escaped;
    }
}

TEST(MutatedFiles, EveryFormatReadsOrRejectsWithMeshmarkErrors)
{
    const fs::path fuzz_dir = fs::path(MESHMARK_FUZZ_DIR) / "corpus";
    const std::vector<fs::path> seeds = {
        test::data_dir() / "cube_ascii.ply",     test::data_dir() / "cube_binary_le.ply",
        test::data_dir() / "cube_binary_be.ply", test::data_dir() / "cube.off",
        test::data_dir() / "quad_faces.obj",     test::data_dir() / "cube_ascii.stl",
        test::data_dir() / "cube_binary.stl",    fuzz_dir / "fuzz_read_gltf" / "cube.gltf",
        fuzz_dir / "fuzz_read_glb" / "cube.glb", fuzz_dir / "fuzz_read_3mf" / "cube.3mf",
    };
    const fs::path dir = test::temp_dir("mutated_files");
    constexpr std::size_t mutants_per_seed = 25;
    Rng rng(20261122);
    std::size_t total_rejected = 0;
    for (const auto& seed : seeds)
    {
        const Bytes original = bytes_of(seed);
        ASSERT_FALSE(original.empty()) << seed;
        const fs::path path = dir / ("mutant" + seed.extension().string());
        std::string what;
        // The unmutated seed reads, so the loop below exercises a working reader.
        ASSERT_EQ(read_bytes(path, original, what), Outcome::read) << seed << ": " << what;
        // An empty file is refused, except OBJ, where it is a valid file with no vertices.
        const Outcome empty = read_bytes(path, Bytes{}, what);
        EXPECT_EQ(empty, seed.extension() == ".obj" ? Outcome::read : Outcome::rejected)
            << seed << " emptied";
        std::size_t rejected = 0;
        for (std::size_t i = 0; i < mutants_per_seed; ++i)
        {
            const Outcome outcome = read_bytes(path, mutate(rng, original), what);
            EXPECT_NE(outcome, Outcome::escaped) << seed << " mutant " << i << ": " << what;
            rejected += outcome == Outcome::rejected ? 1 : 0;
        }
        RecordProperty(seed.filename().string(), static_cast<int>(rejected));
        total_rejected += rejected;
    }
    // Half the mutation kinds (truncation, deletion, extreme counts) break most tiny files.
    EXPECT_GE(total_rejected, seeds.size() * mutants_per_seed / 5);
    std::error_code ignored;
    fs::remove_all(dir, ignored);
}

}  // namespace
}  // namespace meshmark

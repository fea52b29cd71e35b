// SPDX-License-Identifier: MIT
// Replays every input of fuzz/corpus/<target> and fuzz/regressions/<target> through the same
// entry point as the libFuzzer target: only meshmark::Error may reject an input; any other
// exception (or, under the sanitizer job, any sanitizer report) fails the test.
#include <algorithm>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "fuzz_entry.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

std::vector<fs::path> inputs_of(const std::string& target)
{
    std::vector<fs::path> files;
    for (const char* kind : {"corpus", "regressions"})
    {
        const fs::path dir = fs::path(MESHMARK_FUZZ_DIR) / kind / target;
        if (!fs::is_directory(dir))
        {
            continue;
        }
        for (const auto& entry : fs::directory_iterator(dir))
        {
            if (entry.is_regular_file())
            {
                files.push_back(entry.path());
            }
        }
    }
    std::sort(files.begin(), files.end());
    return files;
}

std::vector<std::uint8_t> bytes_of(const fs::path& path)
{
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Target
{
    std::string name;
    bool (*run)(const std::uint8_t*, std::size_t);
};

bool read_ply(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".ply");
}
bool read_obj(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".obj");
}
bool read_off(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".off");
}
bool read_stl(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".stl");
}
bool read_gltf(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".gltf");
}
bool read_glb(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".glb");
}
bool read_3mf(const std::uint8_t* d, std::size_t n)
{
    return fuzz::read_mesh_bytes(d, n, ".3mf");
}

class FuzzReplay : public ::testing::TestWithParam<Target>
{
};

TEST_P(FuzzReplay, EveryInputIsReadOrRejectedWithMeshmarkError)
{
    const Target& target = GetParam();
    const auto files = inputs_of(target.name);
    // The seed corpus holds valid inputs, so an empty list means the folder moved.
    ASSERT_GE(files.size(), 3U) << "no corpus for " << target.name << " under "
                                << MESHMARK_FUZZ_DIR;
    int accepted = 0;
    for (const auto& file : files)
    {
        const auto data = bytes_of(file);
        try
        {
            accepted += target.run(data.data(), data.size()) ? 1 : 0;
        }
        catch (const std::exception& e)
        {
            ADD_FAILURE() << file << ": escaped with a non-meshmark exception: " << e.what();
        }
    }
    // Seeds include well-formed files (tiny fixtures, hand-made inputs): an entry point that
    // rejected everything would not be exercising the parser.
    EXPECT_GE(accepted, 1) << target.name << " accepted none of " << files.size() << " inputs";
}

// The attack-spec target needs the attacks library, which the sanitizer job leaves out
// (MESHMARK_FUZZ_REPLAY_ATTACKS, tests/unit/fuzz_regressions/CMakeLists.txt).
#ifdef MESHMARK_FUZZ_REPLAY_ATTACKS
#define MESHMARK_ATTACK_SPEC_TARGET                       \
    , Target                                              \
    {                                                     \
        "fuzz_attack_spec", fuzz::parse_attack_spec_bytes \
    }
#else
#define MESHMARK_ATTACK_SPEC_TARGET
#endif
INSTANTIATE_TEST_SUITE_P(
    Targets, FuzzReplay,
    ::testing::Values(Target{"fuzz_read_ply", read_ply}, Target{"fuzz_read_obj", read_obj},
                      Target{"fuzz_read_off", read_off}, Target{"fuzz_read_stl", read_stl},
                      Target{"fuzz_read_gltf", read_gltf}, Target{"fuzz_read_glb", read_glb},
                      Target{"fuzz_read_3mf", read_3mf},
                      Target{"fuzz_parse_key", fuzz::parse_key_bytes} MESHMARK_ATTACK_SPEC_TARGET),
    [](const ::testing::TestParamInfo<Target>& param_info) { return param_info.param.name; });

}  // namespace
}  // namespace meshmark

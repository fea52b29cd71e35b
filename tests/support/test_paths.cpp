// SPDX-License-Identifier: MIT
#include "support/test_paths.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <system_error>
#include <vector>

#include <unistd.h>

namespace meshmark::test
{

std::filesystem::path data_dir()
{
    return MESHMARK_TEST_DATA_DIR;
}

std::filesystem::path mesh_dir()
{
    if (const char* env = std::getenv("MESHMARK_MESH_DIR"); env != nullptr && *env != '\0')
    {
        return env;
    }
    return MESHMARK_DEFAULT_MESH_DIR;
}

std::vector<std::filesystem::path> shared_meshes()
{
    std::vector<std::filesystem::path> result;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator(mesh_dir(), ec))
    {
        const auto ext = entry.path().extension().string();
        if (ext == ".ply" || ext == ".obj" || ext == ".off" || ext == ".stl")
        {
            result.push_back(entry.path());
        }
    }
    std::sort(result.begin(), result.end());
    return result;
}

std::vector<std::filesystem::path> shared_meshes_up_to(long max_vertices)
{
    // Vertex counts from the SOURCES.md table: "| file | model | format | V | ...".
    std::map<std::string, long> counts;
    std::ifstream sources(mesh_dir() / "SOURCES.md");
    const std::regex row(R"(^\| ([^ |]+\.(ply|obj|off|stl)) \|[^|]*\|[^|]*\| (\d+))");
    std::string line;
    while (std::getline(sources, line))
    {
        std::smatch match;
        if (std::regex_search(line, match, row))
        {
            counts[match[1].str()] = std::stol(match[3].str());
        }
    }
    std::vector<std::filesystem::path> result;
    for (const auto& path : shared_meshes())
    {
        const auto it = counts.find(path.filename().string());
        if (it == counts.end() || it->second <= max_vertices)
        {
            result.push_back(path);
        }
    }
    return result;
}

std::filesystem::path cli_path()
{
    return MESHMARK_CLI_PATH;
}

namespace
{

// The folders temp_dir() made, removed when the process exits normally (static destruction),
// unless MESHMARK_KEEP_TEST_DIRS is set (to look at what a failing test wrote).
class TempDirs
{
public:
    void add(const std::filesystem::path& dir)
    {
        const std::lock_guard<std::mutex> lock(mutex_);
        dirs_.push_back(dir);
    }
    TempDirs() = default;
    TempDirs(const TempDirs&) = delete;
    TempDirs& operator=(const TempDirs&) = delete;
    ~TempDirs()
    {
        const char* keep = std::getenv("MESHMARK_KEEP_TEST_DIRS");
        if (keep != nullptr && *keep != '\0')
        {
            return;
        }
        for (const auto& dir : dirs_)
        {
            std::error_code ignored;
            std::filesystem::remove_all(dir, ignored);
        }
    }

private:
    std::mutex mutex_;
    std::vector<std::filesystem::path> dirs_;
};

TempDirs& temp_dirs()
{
    static TempDirs dirs;
    return dirs;
}

}  // namespace

std::filesystem::path temp_dir(const std::string& name)
{
    auto dir = std::filesystem::temp_directory_path() /
               ("meshmark-test-" + std::to_string(::getpid()) + "-" + name);
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    temp_dirs().add(dir);
    return dir;
}

}  // namespace meshmark::test

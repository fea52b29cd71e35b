// SPDX-License-Identifier: MIT
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <unistd.h>

#include "fuzz_entry.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::fuzz
{

namespace
{

/// One file per process and extension, reused for every input (libFuzzer runs millions).
std::filesystem::path temp_path(const std::string& extension)
{
    const auto name = "meshmark_fuzz_" + std::to_string(::getpid()) + extension;
    return std::filesystem::temp_directory_path() / name;
}

}  // namespace

bool read_mesh_bytes(const std::uint8_t* data, std::size_t size, const std::string& extension)
{
    const auto path = temp_path(extension);
    {
        std::ofstream out(path, std::ios::binary | std::ios::trunc);
        out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
        if (!out)
        {
            throw std::runtime_error("cannot write the fuzz input file " + path.string());
        }
    }
    bool accepted = false;
    try
    {
        const MeshFile file = read_mesh_file(path);
        accepted = file.mesh.vertex_count() >= 0;
    }
    catch (const Error&)
    {
        accepted = false;
    }
    std::error_code ignored;
    std::filesystem::remove(path, ignored);
    return accepted;
}

}  // namespace meshmark::fuzz

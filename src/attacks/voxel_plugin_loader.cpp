// SPDX-License-Identifier: MIT
// Finds and opens the OpenVDB plugin libmeshmark_voxel.so (detail/voxel_plugin.h). dlopen and
// dladdr are the platform's own loader interface; there is nothing to take from a library here.
#include <cstddef>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <dlfcn.h>
#include <link.h>

#include "attacks/detail/voxel_plugin.h"
#include "meshmark/core/error.h"

// Set by src/attacks/CMakeLists.txt: the plugin's directory under the configured install
// prefix, and the install library directory relative to a prefix.
#ifndef MESHMARK_VOXEL_PLUGIN_INSTALL_DIR
#define MESHMARK_VOXEL_PLUGIN_INSTALL_DIR ""
#endif
#ifndef MESHMARK_INSTALL_LIBDIR
#define MESHMARK_INSTALL_LIBDIR "lib"
#endif

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// Parents of the loader's own directory in which `lib/meshmark/` is looked for: enough for
// <prefix>/bin/meshmark and <prefix>/lib/python3/dist-packages/meshmark/_meshmark*.so.
constexpr int kParentLevels = 4;

// The file (program or shared object) that holds this function, with symbolic links resolved;
// empty when the system cannot tell.
fs::path this_object()
{
    Dl_info info{};
    link_map* map = nullptr;
    if (dladdr1(reinterpret_cast<void*>(&this_object), &info, reinterpret_cast<void**>(&map),
                RTLD_DL_LINKMAP) == 0)
    {
        return {};
    }
    // The main program's link map has no name (dli_fname is then argv[0], which may be relative
    // to another directory or found by PATH): the kernel knows its path.
    const bool main_program = map == nullptr || map->l_name == nullptr || map->l_name[0] == '\0';
    const fs::path path = main_program ? fs::path("/proc/self/exe") : fs::path(info.dli_fname);
    std::error_code error;
    fs::path resolved = fs::canonical(path, error);
    return error ? fs::path() : resolved;
}

void add(std::vector<fs::path>& dirs, const fs::path& dir)
{
    if (dir.empty())
    {
        return;
    }
    const fs::path normal = dir.lexically_normal();
    for (const fs::path& d : dirs)
    {
        if (d == normal)
        {
            return;
        }
    }
    dirs.push_back(normal);
}

// The directories searched, in order (detail/voxel_plugin.h), and where that is in words.
struct Search
{
    std::vector<fs::path> dirs;
    std::string description;
};

Search search_dirs()
{
    Search search;
    auto& dirs = search.dirs;
    if (const char* env = std::getenv("MESHMARK_PLUGIN_DIR"); env != nullptr && env[0] != '\0')
    {
        add(dirs, env);
        search.description = "in MESHMARK_PLUGIN_DIR (" + std::string(env) + ")";
        return search;
    }
    const fs::path object = this_object();
    std::vector<std::string> places;
    if (!object.empty())
    {
        places.push_back("next to " + object.string());
        places.push_back("in lib/meshmark/ of its folder and of its parents");
        fs::path dir = object.parent_path();
        add(dirs, dir);
        for (int level = 0; level <= kParentLevels && !dir.empty(); ++level)
        {
            add(dirs, dir / "lib" / "meshmark");
            add(dirs, dir / MESHMARK_INSTALL_LIBDIR / "meshmark");
            if (dir == dir.root_path())
            {
                break;
            }
            dir = dir.parent_path();
        }
    }
    if (const char* dir = MESHMARK_VOXEL_PLUGIN_INSTALL_DIR; dir[0] != '\0')
    {
        add(dirs, dir);
        places.push_back(std::string("in ") + dir);
    }
    for (std::size_t i = 0; i < places.size(); ++i)
    {
        search.description += (i == 0 ? "" : i + 1 == places.size() ? ", or " : ", ") + places[i];
    }
    return search;
}

// The entry point, or the sentence that says why there is none.
struct Loaded
{
    VoxelRemeshFunction function = nullptr;
    std::string error;
};

Loaded load()
{
    const Search search = search_dirs();
    for (const fs::path& dir : search.dirs)
    {
        const fs::path file = dir / kVoxelPluginFile;
        std::error_code error;
        if (!fs::is_regular_file(file, error))
        {
            continue;
        }
        // Kept open for the life of the process (OpenVDB registers types globally).
        void* handle = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr)
        {
            const char* why = dlerror();
            return {nullptr, "voxel remeshing could not load " + file.string() + " (" +
                                 (why != nullptr ? why : "unknown error") +
                                 "): reinstall meshmark with its OpenVDB dependencies."};
        }
        void* symbol = dlsym(handle, kVoxelPluginSymbol);
        if (symbol == nullptr)
        {
            return {nullptr, "voxel remeshing found " + file.string() + " but it has no " +
                                 kVoxelPluginSymbol +
                                 " (it belongs to another meshmark version): reinstall meshmark."};
        }
        return {reinterpret_cast<VoxelRemeshFunction>(symbol), {}};
    }
    return {nullptr, std::string("voxel remeshing needs ") + kVoxelPluginFile +
                         " (OpenVDB), which was not found " +
                         (search.description.empty() ? "anywhere" : search.description) +
                         ": reinstall meshmark."};
}

}  // namespace

VoxelRemeshFunction voxel_plugin()
{
    // Initialized once, by the first caller; the others wait (a function-local static).
    static const Loaded loaded = load();
    if (loaded.function == nullptr)
    {
        throw Error(loaded.error);
    }
    return loaded.function;
}

}  // namespace meshmark::detail

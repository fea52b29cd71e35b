// SPDX-License-Identifier: MIT
// The interop suite's harness (interop_support.h): tool discovery and runs, the corpus cache
// (a file lock, so that parallel ctest processes make each entry once), the node-helper checks.
#include "interop_support.h"

#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <sys/file.h>
#include <unistd.h>

#include "support/test_paths.h"

namespace meshmark::test::interop
{
namespace
{

// PATH is searched here, in the parent, so that the child runs execv on a full path (execvp is
// not async-signal-safe, and the tests fork while OpenMP threads may exist).
fs::path find_in_path(const std::string& name)
{
    const char* path = std::getenv("PATH");
    std::stringstream folders(path != nullptr ? path : "/usr/local/bin:/usr/bin:/bin");
    std::string folder;
    while (std::getline(folders, folder, ':'))
    {
        const fs::path candidate = fs::path(folder.empty() ? "." : folder) / name;
        if (::access(candidate.c_str(), X_OK) == 0 && !fs::is_directory(candidate))
        {
            return candidate;
        }
    }
    return {};
}

fs::path node_bin(const std::string& name)
{
    const fs::path path = kInteropDir / "node_modules" / ".bin" / name;
    return ::access(path.c_str(), X_OK) == 0 ? path : fs::path{};
}

// An exclusive flock on a file, released on destruction.
class FileLock
{
public:
    explicit FileLock(const fs::path& path) : fd_(::open(path.c_str(), O_CREAT | O_RDWR, 0644))
    {
        if (fd_ >= 0)
        {
            while (::flock(fd_, LOCK_EX) != 0 && errno == EINTR)
            {
            }
        }
    }
    ~FileLock()
    {
        if (fd_ >= 0)
        {
            ::close(fd_);
        }
    }
    FileLock(const FileLock&) = delete;
    FileLock& operator=(const FileLock&) = delete;

private:
    int fd_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------
// Tools

bool in_ci()
{
    const char* ci = std::getenv("CI");
    return ci != nullptr && *ci != '\0' && std::string(ci) != "false" && std::string(ci) != "0";
}

Tools::Tools()
    : node(find_in_path("node")),
      gltfpack(find_in_path("gltfpack")),
      xvfb_run(find_in_path("xvfb-run")),
      prusa_slicer(find_in_path("prusa-slicer")),
      blender(find_in_path("blender")),
      assimp(find_in_path("assimp")),
      // Debian's interpreter, not the first python3 on PATH (a pyenv one lacks Debian's modules).
      open3d_python(fs::exists("/usr/bin/python3") &&
                            fs::exists("/usr/lib/python3/dist-packages/open3d")
                        ? fs::path("/usr/bin/python3")
                        : fs::path()),
      gltf_transform(node_bin("gltf-transform")),
      gltf_pipeline(node_bin("gltf-pipeline"))
{
}

const Tools& tools()
{
    static const Tools instance;
    return instance;
}

std::string missing_tools(const std::vector<std::string>& needed)
{
    std::string missing;
    auto note = [&](bool present, const std::string& what)
    {
        if (!present)
        {
            missing += (missing.empty() ? "" : ", ") + what;
        }
    };
    const Tools& t = tools();
    std::set<std::string> seen;
    for (const auto& name : needed)
    {
        if (!seen.insert(name).second)
        {
            continue;
        }
        if (name == "meshmark")
        {
            note(!cli_path().empty() && fs::exists(cli_path()), "the meshmark program (not built)");
        }
        else if (name == "node")
        {
            note(!t.node.empty(), "node");
            // The helpers' packages (npm ci in tests/interop, scripts/setup.sh).
            for (const char* package : {"@gltf-transform/core", "@gltf-transform/extensions",
                                        "draco3dgltf", "meshoptimizer", "gltf-validator"})
            {
                note(fs::exists(kInteropDir / "node_modules" / package / "package.json"),
                     std::string("the npm package ") + package + " in " +
                         (kInteropDir / "node_modules").string());
            }
        }
        else if (name == "gltfpack")
        {
            note(!t.gltfpack.empty(), "gltfpack");
        }
        else if (name == "gltf-transform")
        {
            note(!t.gltf_transform.empty(), "gltf-transform (tests/interop/node_modules/.bin)");
        }
        else if (name == "gltf-pipeline")
        {
            note(!t.gltf_pipeline.empty(), "gltf-pipeline (tests/interop/node_modules/.bin)");
        }
        else if (name == "blender")
        {
            note(!t.blender.empty(), "blender");
        }
        else if (name == "assimp")
        {
            note(!t.assimp.empty(), "assimp (Debian assimp-utils)");
        }
        else if (name == "open3d")
        {
            note(!t.open3d_python.empty(), "Open3D (Debian python3-open3d for /usr/bin/python3)");
        }
        else if (name == "prusa-slicer-shapes")
        {
            // PrusaSlicer's sample shapes: a CAD part nothing in meshmark was tuned on.
            note(fs::exists("/usr/share/PrusaSlicer/shapes/M3x10_screw.stl"),
                 "PrusaSlicer's shapes (/usr/share/PrusaSlicer/shapes)");
        }
        else if (name == "prusa-slicer-profiles")
        {
            // The printer beds of PrusaSlicer's vendor profiles: CAD exports of flat plates.
            note(fs::exists("/usr/share/PrusaSlicer/profiles/Creality/cr10_bed.stl"),
                 "PrusaSlicer's printer profiles (/usr/share/PrusaSlicer/profiles)");
        }
        else if (name == "occt-misc")
        {
            // Debian's occt-misc: OpenCASCADE's sample CAD parts as STL.
            note(fs::exists("/usr/share/opencascade/data/stl/motor.stl"),
                 "occt-misc (/usr/share/opencascade/data)");
        }
        else if (name == "sweethome3d-furniture")
        {
            // Debian's sweethome3d-furniture: artists' models, OBJ in zip catalogues (.sh3f).
            note(fs::exists("/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f") &&
                     fs::exists("/usr/share/sweethome3d/furniture/Reallusion.sh3f"),
                 "sweethome3d-furniture (/usr/share/sweethome3d/furniture)");
        }
        else if (name == "assimp-testmodels")
        {
            // Debian's assimp-testmodels: other people's models (real_assets_*_test.cpp).
            note(fs::exists("/usr/share/assimp/models/OBJ/spider.obj"),
                 "assimp-testmodels (/usr/share/assimp/models)");
        }
        else if (name == "prusa-slicer")
        {
            note(!t.xvfb_run.empty(), "xvfb-run");
            note(!t.prusa_slicer.empty(), "prusa-slicer");
        }
    }
    return missing;
}

std::string quoted(const std::vector<std::string>& words)
{
    std::string text;
    for (const auto& word : words)
    {
        text += (text.empty() ? "" : " ") +
                (word.find(' ') == std::string::npos ? word : "'" + word + "'");
    }
    return text;
}

std::string tail(const std::string& text, std::size_t n)
{
    return text.size() <= n ? text : "..." + text.substr(text.size() - n);
}

ToolRun run(std::vector<std::string> words, const fs::path& scratch)
{
    static std::atomic<int> counter{0};
    ToolRun r;
    r.command = quoted(words);
    r.result = run_program(std::move(words), scratch, "run" + std::to_string(counter++));
    return r;
}

ToolRun meshmark(const std::vector<std::string>& arguments, const fs::path& scratch)
{
    std::vector<std::string> words{cli_path().string()};
    words.insert(words.end(), arguments.begin(), arguments.end());
    ToolRun r = run(std::move(words), scratch);
    r.command = "meshmark " + quoted(arguments);
    return r;
}

ToolRun node_helper(const std::string& script, std::vector<std::string> arguments,
                    const fs::path& scratch)
{
    std::vector<std::string> words{tools().node.string(), (kInteropDir / script).string()};
    words.insert(words.end(), arguments.begin(), arguments.end());
    return run(std::move(words), scratch);
}

// ---------------------------------------------------------------------------------------------
// The corpus cache

std::string file_stamp(const fs::path& path)
{
    std::error_code error;
    const auto size = fs::file_size(path, error);
    const auto time = fs::last_write_time(fs::canonical(path, error), error);
    return path.string() + " " + std::to_string(error ? 0 : size) + " " +
           std::to_string(time.time_since_epoch().count()) + "\n";
}

fs::path corpus_entry(const std::string& name, const std::string& stamp,
                      const std::function<std::string(const fs::path&)>& produce,
                      std::string* error)
{
    fs::create_directories(kCorpusDir);
    const FileLock lock(kCorpusDir / (name + ".lock"));
    const fs::path folder = kCorpusDir / name;
    if (fs::exists(folder / "stamp") && file_bytes(folder / "stamp") == stamp)
    {
        return folder;
    }
    const fs::path staging = kCorpusDir / (name + ".tmp-" + std::to_string(::getpid()));
    fs::remove_all(staging);
    fs::create_directories(staging);
    *error = produce(staging);
    if (!error->empty())
    {
        fs::remove_all(staging);
        return {};
    }
    std::ofstream(staging / "stamp", std::ios::binary) << stamp;
    fs::remove_all(folder);
    fs::rename(staging, folder);
    return folder;
}

// ---------------------------------------------------------------------------------------------
// Checks

Validation validate(const fs::path& file, const fs::path& scratch, std::string* error)
{
    const ToolRun r = node_helper("validate.mjs", {file.string()}, scratch);
    Validation v;
    if (!r.ok())
    {
        *error = r.describe();
        return v;
    }
    const auto json = nlohmann::json::parse(r.result.out, nullptr, false);
    if (json.is_discarded())
    {
        *error = "validate.mjs printed no JSON: " + tail(r.result.out);
        return v;
    }
    v.errors = json.value("errors", -1);
    v.warnings = json.value("warnings", -1);
    v.codes = json.value("codes", nlohmann::json::object()).dump();
    v.messages = json.value("messages", nlohmann::json::array()).dump();
    return v;
}

Positions independent_read(const fs::path& file, const fs::path& scratch, std::string* error)
{
    const fs::path bin = scratch / (file.stem().string() + ".positions.bin");
    const ToolRun r = node_helper("read_positions.mjs", {file.string(), bin.string()}, scratch);
    if (!r.ok())
    {
        *error = r.describe();
        return {};
    }
    const std::string bytes = file_bytes(bin);
    if (bytes.size() % (3 * sizeof(double)) != 0)
    {
        *error =
            bin.string() + " has " + std::to_string(bytes.size()) + " bytes, not a multiple of 24";
        return {};
    }
    Positions P(static_cast<Eigen::Index>(bytes.size() / (3 * sizeof(double))), 3);
    std::memcpy(P.data(), bytes.data(), bytes.size());
    return P;
}

Box bounds(const Positions& P)
{
    return {P.colwise().minCoeff(), P.colwise().maxCoeff()};
}

ClosestPointIndex cloud_index(const Positions& P)
{
    TriangleMesh cloud;
    cloud.V = P;
    return ClosestPointIndex(cloud);
}

}  // namespace meshmark::test::interop

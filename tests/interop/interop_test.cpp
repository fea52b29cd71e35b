// SPDX-License-Identifier: MIT
// The interop suite (issue 14, docs/interop.md): files written by the ecosystem's own tools
// (gltfpack, glTF-Transform, gltf-pipeline, PrusaSlicer), marked by `meshmark embed`, and
// checked by the ecosystem's tools (the Khronos validator, glTF-Transform as an independent
// reader, gltfpack and glTF-Transform as re-processors, PrusaSlicer --info) and by
// `meshmark detect`. One test per input file.
//
// The inputs are generated at test time into a corpus folder in the build tree (never committed),
// each once per ctest run: the folder is wiped by the `interop.corpus_reset` fixture, entries are
// made under a file lock (ctest -j runs cases in parallel processes) and reused by later cases.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <zip.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "integration/process_util.h"
#include "meshmark/geometry/closest_point_index.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"
#include "support/test_paths.h"

namespace meshmark::test {
namespace {

namespace fs = std::filesystem;

// tests/interop: the node helpers and their node_modules (scripts/setup.sh runs npm ci there).
const fs::path kInteropDir = MESHMARK_INTEROP_DIR;
// Where the corpus is generated (build tree; wiped at the start of every ctest run).
const fs::path kCorpusDir = MESHMARK_INTEROP_CORPUS_DIR;
// Any fixed seed: the "meant" positions are recomputed from the key file, not from the seed.
constexpr const char* kSeed = "1414";

// ---------------------------------------------------------------------------------------------
// Tools

bool in_ci()
{
    const char* ci = std::getenv("CI");
    return ci != nullptr && *ci != '\0' && std::string(ci) != "false" && std::string(ci) != "0";
}

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

struct Tools
{
    fs::path node = find_in_path("node");
    fs::path gltfpack = find_in_path("gltfpack");
    fs::path xvfb_run = find_in_path("xvfb-run");
    fs::path prusa_slicer = find_in_path("prusa-slicer");
    fs::path gltf_transform = node_bin("gltf-transform");
    fs::path gltf_pipeline = node_bin("gltf-pipeline");
};

const Tools& tools()
{
    static const Tools instance;
    return instance;
}

// Names of the missing tools among \p needed ("" when all are there).
std::string missing_tools(const std::vector<std::string>& needed)
{
    std::string missing;
    auto note = [&](bool present, const std::string& what) {
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
            for (const char* package : {"@gltf-transform/core", "@gltf-transform/extensions", "draco3dgltf",
                                        "meshoptimizer", "gltf-validator"})
            {
                note(fs::exists(kInteropDir / "node_modules" / package / "package.json"),
                     std::string("the npm package ") + package + " in " + (kInteropDir / "node_modules").string());
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
        else if (name == "prusa-slicer")
        {
            note(!t.xvfb_run.empty(), "xvfb-run");
            note(!t.prusa_slicer.empty(), "prusa-slicer");
        }
    }
    return missing;
}

// A missing tool skips the case on a developer's machine, but fails it when CI is set: CI has
// every tool (scripts/setup.sh), so a skip there would silently stop the suite from running.
#define INTEROP_REQUIRE_TOOLS(...)                                                                   \
    do                                                                                               \
    {                                                                                                \
        const std::string missing_ = missing_tools({__VA_ARGS__});                                   \
        if (!missing_.empty())                                                                       \
        {                                                                                            \
            if (in_ci())                                                                             \
            {                                                                                        \
                GTEST_FAIL() << "missing " << missing_ << " (CI is set: the interop suite must run; " \
                                                          "scripts/setup.sh installs the tools)";    \
            }                                                                                        \
            GTEST_SKIP() << "missing " << missing_ << " (scripts/setup.sh installs the tools)";     \
        }                                                                                            \
    } while (false)

std::string quoted(const std::vector<std::string>& words)
{
    std::string text;
    for (const auto& word : words)
    {
        text += (text.empty() ? "" : " ") + (word.find(' ') == std::string::npos ? word : "'" + word + "'");
    }
    return text;
}

std::string tail(const std::string& text, std::size_t n = 600)
{
    return text.size() <= n ? text : "..." + text.substr(text.size() - n);
}

// One run of a tool: its result and a one-line description for messages.
struct ToolRun
{
    CliResult result;
    std::string command;
    [[nodiscard]] bool ok() const { return result.exit_code == 0; }
    [[nodiscard]] std::string describe() const
    {
        return "`" + command + "` exited " + std::to_string(result.exit_code) + ": " +
               tail(result.err.empty() ? result.out : result.err);
    }
};

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

ToolRun node_helper(const std::string& script, std::vector<std::string> arguments, const fs::path& scratch)
{
    std::vector<std::string> words{tools().node.string(), (kInteropDir / script).string()};
    words.insert(words.end(), arguments.begin(), arguments.end());
    return run(std::move(words), scratch);
}

// ---------------------------------------------------------------------------------------------
// The corpus cache

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

// What a corpus entry was made from: a file's path, size and modification time.
std::string file_stamp(const fs::path& path)
{
    std::error_code error;
    const auto size = fs::file_size(path, error);
    const auto time = fs::last_write_time(fs::canonical(path, error), error);
    return path.string() + " " + std::to_string(error ? 0 : size) + " " +
           std::to_string(time.time_since_epoch().count()) + "\n";
}

/// \brief The corpus folder \p name, made by \p produce (which fills the folder it is given and
/// returns "" or an error) unless a folder with the same \p stamp is there already. The folder
/// is made beside its final place and renamed into it, under a lock, so a concurrent case
/// waits for it instead of making it again, and a failed or killed run leaves nothing behind.
fs::path corpus_entry(const std::string& name, const std::string& stamp,
                      const std::function<std::string(const fs::path&)>& produce, std::string* error)
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
// Cases

enum class Source
{
    Gltfpack,       // gltfpack -i MESH.obj -o in.glb FLAGS
    GltfTransform,  // gltf-transform COMMAND... on the `gltfpack -noq -kn` glb (chained)
    GltfPipeline,   // gltf-pipeline -i in.gltf -o in.glb FLAGS, in.gltf from `gltfpack -noq -kn`
    Scene,          // gltf-transform COMMAND... on the multi-part scene (make_scene.mjs)
    SceneGltfpack,  // gltfpack -i scene.glb -o in.glb FLAGS
};

struct Variant
{
    const char* name;
    Source source;
    std::vector<std::vector<std::string>> steps;  // gltfpack / gltf-pipeline flags: steps[0]
    /// Position bits of the grid the tool stored the positions on (0: float32). The tolerance
    /// of the position check is one step of that grid, in world units (see tolerance()).
    int position_bits;
    bool draco;  // point order may change when meshmark re-encodes (edgebreaker)
};

// Position grids (L = the largest extent of the asset's bounding box in world units, as read by
// glTF-Transform; every corpus asset has one primitive, so this is the primitive's extent):
// - gltfpack (default, -c, -cc, -kn): 14-bit positions (-vp 14), stored as unnormalized
//   integers 0..16383 over the scene's bounds, the node scale L / 16383: a step L / (2^14 - 1).
//   -c / -cc add EXT_meshopt_compression (lossless on the quantized integers).
// - gltf-transform quantize (and meshopt / optimize, which quantize first): 14 bits over the
//   mesh's bounds mapped to [-1, 1] in normalized SHORTs; the tool's grid is (L / 2) / 16383, the
//   SHORT storage (L / 2) / 32767. We allow one 14-bit step over the extent, L / (2^14 - 1):
//   twice the tool's grid, still 60x below the watermark's 1e-3 D RMS displacement.
// - gltf-transform draco: Draco's 14-bit position quantization over the primitive's largest
//   extent, step L / (2^14 - 1). quantize then draco: Draco stores the normalized SHORTs
//   losslessly, so the grid is quantize's (14 bits).
// - gltf-pipeline -d: Draco with 11-bit positions (its default), step L / (2^11 - 1).
// - float32 (-noq, weld, reorder, simplify): no grid; float32 rounding of T^-1 p, allowed as
//   1e-6 of the diagonal below (also added to every quantized tolerance for the node transform).
const std::vector<Variant>& variants()
{
    static const std::vector<Variant> list{
        {"gltfpack", Source::Gltfpack, {{}}, 14, false},
        {"gltfpack_c", Source::Gltfpack, {{"-c"}}, 14, false},
        {"gltfpack_cc", Source::Gltfpack, {{"-cc"}}, 14, false},
        {"gltfpack_noq", Source::Gltfpack, {{"-noq"}}, 0, false},
        {"gltfpack_kn", Source::Gltfpack, {{"-kn"}}, 14, false},
        {"gt_quantize", Source::GltfTransform, {{"quantize"}}, 14, false},
        {"gt_draco", Source::GltfTransform, {{"draco"}}, 14, true},
        {"gt_meshopt", Source::GltfTransform, {{"meshopt"}}, 14, false},
        {"gt_optimize", Source::GltfTransform, {{"optimize"}}, 14, false},
        {"gt_weld", Source::GltfTransform, {{"weld"}}, 0, false},
        {"gt_reorder", Source::GltfTransform, {{"reorder"}}, 0, false},
        {"gt_simplify", Source::GltfTransform, {{"simplify", "--ratio", "0.5"}}, 0, false},
        {"gt_quantize_draco", Source::GltfTransform, {{"quantize"}, {"draco"}}, 14, true},
        {"gltfpipeline_draco", Source::GltfPipeline, {{"-d"}}, 11, true},
    };
    return list;
}

const std::vector<std::string>& meshes()
{
    // spot: 2.9K vertices with UVs (a game asset); the Stanford bunny: 35K; fandisk: hard edges.
    static const std::vector<std::string> list{"spot.obj", "stanford-bunny.obj", "fandisk.obj"};
    return list;
}

struct GltfCase
{
    std::string mesh;
    Variant variant;
    [[nodiscard]] std::string name() const
    {
        std::string stem = fs::path(mesh).stem().string();
        std::replace(stem.begin(), stem.end(), '-', '_');
        return stem + "_" + variant.name;
    }
};

// gtest prints a test's parameter: the case name, not GltfCase's bytes.
void PrintTo(const GltfCase& c, std::ostream* os) { *os << c.name(); }

// The multi-part asset of make_scene.mjs (spot textured under a rotated node with fandisk as its
// scaled child, the bunny instanced by two nodes), as written and after the ecosystem's tools.
// Draco variants are left to the single meshes: their point order changes, and the position
// check would need to tell the second bunny's points from the first's.
constexpr const char* kScene = "scene";
const std::vector<std::string> kSceneMeshes{"spot.obj", "fandisk.obj", "stanford-bunny.obj"};

const std::vector<Variant>& scene_variants()
{
    static const std::vector<Variant> list{
        {"plain", Source::Scene, {}, 0, false},
        {"gltfpack", Source::SceneGltfpack, {{}}, 14, false},
        {"gltfpack_cc", Source::SceneGltfpack, {{"-cc"}}, 14, false},
        {"gt_quantize", Source::Scene, {{"quantize"}}, 14, false},
        {"gt_meshopt", Source::Scene, {{"meshopt"}}, 14, false},
        {"gt_optimize", Source::Scene, {{"optimize"}}, 14, false},
    };
    return list;
}

std::vector<GltfCase> gltf_cases()
{
    std::vector<GltfCase> cases;
    for (const auto& mesh : meshes())
    {
        for (const auto& variant : variants())
        {
            cases.push_back({mesh, variant});
        }
    }
    for (const auto& variant : scene_variants())
    {
        cases.push_back({kScene, variant});
    }
    return cases;
}


// `gltfpack -noq -kn` of a mesh as .glb or .gltf (+ .bin): the float input of the
// glTF-Transform and gltf-pipeline variants.
fs::path float_base(const fs::path& mesh, const std::string& extension, std::string* error)
{
    const std::string name = mesh.stem().string() + ".noq_kn" + extension;
    const std::vector<std::string> flags{"-noq", "-kn"};
    const std::string stamp = "gltfpack -noq -kn\n" + file_stamp(mesh) + file_stamp(tools().gltfpack);
    const fs::path folder = corpus_entry(
        name, stamp,
        [&](const fs::path& staging) {
            const ToolRun r = run({tools().gltfpack.string(), "-i", mesh.string(), "-o", (staging / ("in" + extension)).string(),
                               "-noq", "-kn"},
                              staging);
            return r.ok() ? std::string{} : r.describe();
        },
        error);
    return folder.empty() ? fs::path{} : folder / ("in" + extension);
}

// The scene of make_scene.mjs from the float bases of kSceneMeshes.
fs::path scene_base(std::string* error)
{
    std::vector<std::string> words{tools().node.string(), (kInteropDir / "make_scene.mjs").string()};
    std::string stamp = "make_scene\n" + file_stamp(kInteropDir / "make_scene.mjs");
    for (const auto& mesh : kSceneMeshes)
    {
        const fs::path base = float_base(mesh_dir() / mesh, ".glb", error);
        if (base.empty())
        {
            return {};
        }
        words.push_back(base.string());
        stamp += file_stamp(base);
    }
    const fs::path folder = corpus_entry(
        "scene_base", stamp,
        [&](const fs::path& staging) {
            std::vector<std::string> command = words;
            command.push_back((staging / "in.glb").string());
            const ToolRun r = run(command, staging);
            return r.ok() ? std::string{} : r.describe();
        },
        error);
    return folder.empty() ? fs::path{} : folder / "in.glb";
}

// The input file of a case (generated on first use).
fs::path case_input(const GltfCase& c, std::string* error)
{
    const fs::path mesh = c.mesh == kScene ? scene_base(error) : mesh_dir() / c.mesh;
    if (mesh.empty())
    {
        return {};
    }
    const Tools& t = tools();
    std::string stamp = c.name() + "\n" + file_stamp(mesh);
    for (const auto& step : c.variant.steps)
    {
        stamp += quoted(step) + "\n";
    }
    std::function<std::string(const fs::path&)> produce;
    switch (c.variant.source)
    {
    case Source::Gltfpack:
    case Source::SceneGltfpack:
        stamp += file_stamp(t.gltfpack);
        produce = [&](const fs::path& staging) {
            std::vector<std::string> words{t.gltfpack.string(), "-i", mesh.string(), "-o", (staging / "in.glb").string()};
            words.insert(words.end(), c.variant.steps[0].begin(), c.variant.steps[0].end());
            const ToolRun r = run(words, staging);
            return r.ok() ? std::string{} : r.describe();
        };
        break;
    case Source::GltfTransform:
    case Source::Scene:
    {
        const fs::path base = c.variant.source == Source::Scene ? mesh : float_base(mesh, ".glb", error);
        if (base.empty())
        {
            return {};
        }
        stamp += file_stamp(base) + file_stamp(t.gltf_transform);
        produce = [&, base](const fs::path& staging) {
            fs::path from = base;
            if (c.variant.steps.empty())
            {
                fs::copy_file(base, staging / "in.glb");
            }
            for (std::size_t i = 0; i < c.variant.steps.size(); ++i)
            {
                const fs::path to = staging / (i + 1 == c.variant.steps.size() ? "in.glb" : "step" + std::to_string(i) + ".glb");
                std::vector<std::string> words{t.gltf_transform.string(), c.variant.steps[i][0], from.string(), to.string()};
                words.insert(words.end(), c.variant.steps[i].begin() + 1, c.variant.steps[i].end());
                const ToolRun r = run(words, staging);
                if (!r.ok())
                {
                    return r.describe();
                }
                from = to;
            }
            return std::string{};
        };
        break;
    }
    case Source::GltfPipeline:
    {
        const fs::path base = float_base(mesh, ".gltf", error);
        if (base.empty())
        {
            return {};
        }
        stamp += file_stamp(base) + file_stamp(t.gltf_pipeline);
        produce = [&, base](const fs::path& staging) {
            std::vector<std::string> words{t.gltf_pipeline.string(), "-i", base.string(), "-o", (staging / "in.glb").string()};
            words.insert(words.end(), c.variant.steps[0].begin(), c.variant.steps[0].end());
            const ToolRun r = run(words, staging);
            return r.ok() ? std::string{} : r.describe();
        };
        break;
    }
    }
    const fs::path folder = corpus_entry(c.name(), stamp, produce, error);
    return folder.empty() ? fs::path{} : folder / "in.glb";
}

// ---------------------------------------------------------------------------------------------
// Checks

struct Validation
{
    int errors = 0;
    int warnings = 0;
    std::string codes;  // {"CODE": count, ...}
    std::string messages;
};

// The Khronos validator's verdict on a file; an error text when it could not run.
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

// World positions of every TRIANGLES/POINTS primitive, read by glTF-Transform (read_positions.mjs).
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
        *error = bin.string() + " has " + std::to_string(bytes.size()) + " bytes, not a multiple of 24";
        return {};
    }
    Positions P(static_cast<Eigen::Index>(bytes.size() / (3 * sizeof(double))), 3);
    std::memcpy(P.data(), bytes.data(), bytes.size());
    return P;
}

struct Box
{
    Eigen::RowVector3d lo;
    Eigen::RowVector3d hi;
    [[nodiscard]] double diagonal() const { return (hi - lo).norm(); }
    [[nodiscard]] double largest_extent() const { return (hi - lo).maxCoeff(); }
};

Box bounds(const Positions& P) { return {P.colwise().minCoeff(), P.colwise().maxCoeff()}; }

// A point cloud index (nearest vertex): meshmark's ClosestPointIndex on a mesh without faces
// (nanoflann's kd-tree underneath).
ClosestPointIndex cloud_index(const Positions& P)
{
    TriangleMesh cloud;
    cloud.V = P;
    return ClosestPointIndex(cloud);
}

// Re-process \p file with a tool into \p output: the tool's command words.
using Reprocess = std::function<std::vector<std::string>(const fs::path& in, const fs::path& out)>;

std::vector<std::string> gltfpack_cc(const fs::path& in, const fs::path& out)
{
    return {tools().gltfpack.string(), "-cc", "-i", in.string(), "-o", out.string()};
}

std::vector<std::string> gltf_transform_optimize(const fs::path& in, const fs::path& out)
{
    return {tools().gltf_transform.string(), "optimize", in.string(), out.string()};
}

// MRMS (relative to the diagonal) beyond which a re-processing tool has damaged the unmarked
// asset itself: 5 times the watermark's own RMS displacement.
constexpr double kToolDamage = 5e-3;

class GltfInterop : public ::testing::TestWithParam<GltfCase>
{
};

TEST_P(GltfInterop, EmbedValidateReadDetect)
{
    const GltfCase& c = GetParam();
    for (const auto& mesh : c.mesh == kScene ? kSceneMeshes : std::vector<std::string>{c.mesh})
    {
        if (!fs::exists(mesh_dir() / mesh))
        {
            GTEST_SKIP() << (mesh_dir() / mesh) << " is missing (shared meshes not available)";
        }
    }
    INTEROP_REQUIRE_TOOLS("meshmark", "node", "gltfpack", "gltf-transform",
                          c.variant.source == Source::GltfPipeline ? "gltf-pipeline" : "node");

    std::string error;
    const fs::path in = case_input(c, &error);
    ASSERT_FALSE(in.empty()) << c.name() << ": cannot make the input: " << error;
    const std::string in_name = c.name() + "/in.glb";
    const fs::path scratch = temp_dir("interop-" + c.name());
    const fs::path out = scratch / "out.glb";
    const fs::path key = scratch / "out.key";
    const std::string out_name = c.name() + "/out.glb";

    // (a) embed
    const ToolRun embed = meshmark({"embed", in.string(), "-o", out.string(), "--key", key.string(), "--seed", kSeed, "-q"}, scratch);
    ASSERT_TRUE(embed.ok()) << "(a) embed of " << in_name << " failed: " << embed.describe();

    // (b) the Khronos validator: no new errors or warnings.
    {
        std::string in_error;
        std::string out_error;
        const Validation vin = validate(in, scratch, &in_error);
        const Validation vout = validate(out, scratch, &out_error);
        EXPECT_TRUE(in_error.empty() && out_error.empty()) << "(b) the validator did not run: " << in_error << out_error;
        EXPECT_LE(vout.errors, vin.errors) << "(b) validator errors: " << out_name << " " << vout.errors << " " << vout.codes
                                           << " vs " << in_name << " " << vin.errors << " " << vin.codes
                                           << "; first messages of " << out_name << ": " << vout.messages;
        EXPECT_LE(vout.warnings, vin.warnings)
            << "(b) validator warnings: " << out_name << " " << vout.warnings << " " << vout.codes << " vs " << in_name
            << " " << vin.warnings << " " << vin.codes << "; first messages of " << out_name << ": " << vout.messages;
    }

    // (c) positions read by glTF-Transform: what meshmark meant to write, within one grid step.
    {
        std::string read_error;
        const Positions in_read = independent_read(in, scratch, &read_error);
        ASSERT_TRUE(read_error.empty()) << "(c) glTF-Transform cannot read " << in_name << ": " << read_error;
        ASSERT_GT(in_read.rows(), 0) << "(c) " << in_name << " has no positions";
        const Positions out_read = independent_read(out, scratch, &read_error);
        ASSERT_TRUE(read_error.empty()) << "(c) glTF-Transform cannot read " << out_name << ": " << read_error;
        EXPECT_EQ(out_read.rows(), in_read.rows())
            << "(c) vertex count: glTF-Transform reads " << out_read.rows() << " positions from " << out_name << " but "
            << in_read.rows() << " from " << in_name;
        ASSERT_GT(out_read.rows(), 0) << "(c) " << out_name << " has no positions";

        // "Meant": meshmark's library on IN (read_mesh_file, the welded world-space mesh) with
        // the key the CLI wrote: SpectralWatermark(mesh, key).displacement() is the call
        // embed_file makes (src/pipeline/embed_file.cpp), bit-identical for any thread count.
        const MeshFile in_file = read_mesh_file(in);
        const Key embed_key = read_key(key);
        const SpectralWatermark mark(in_file.mesh, embed_key, 0);
        const Positions meant = in_file.mesh.V + mark.displacement();

        const Box in_box = bounds(in_read);
        const double D = in_box.diagonal();
        const double L = in_box.largest_extent();
        const double q = c.variant.position_bits > 0 ? L / (std::pow(2.0, c.variant.position_bits) - 1.0) : 0.0;
        // The scene's instanced bunny is stored at 1/6 of its shown size (its nodes scale by 6):
        // a tool's grid over its local extent is up to 6 times coarser in world units than one
        // over the scene's extent.
        const double grid_factor = c.mesh == kScene ? 6.0 : 1.0;
        const double tolerance = grid_factor * q + 1e-6 * D;

        // Correspondence: every element of the independent read of IN is a vertex of meshmark's
        // welded mesh (distance ~0: both apply the same node transforms in double precision).
        const ClosestPointIndex welded = cloud_index(in_file.mesh.V);
        // Elements of further instances of an instanced mesh are not in the welded mesh (only
        // the first instance is watermarked; the others show its displacement, moved with
        // them): meshmark reports them as MeshFile::instances, one point per element, and the
        // elements of IN that are none of the welded vertices must be exactly those.
        Positions expected(in_read.rows(), 3);
        std::vector<char> is_instance(static_cast<std::size_t>(in_read.rows()), 0);
        Eigen::Index instance_elements = 0;
        double weld_distance = 0.0;
        for (Eigen::Index i = 0; i < in_read.rows(); ++i)
        {
            const ClosestPoint hit = welded.closest(Eigen::Vector3d(in_read.row(i).transpose()));
            if (in_file.instances.vertex_count() > 0 && hit.distance > 1e-6 * D)
            {
                is_instance[static_cast<std::size_t>(i)] = 1;
                ++instance_elements;
                expected.row(i) = in_read.row(i);  // unused in the same order (the scene cases)
                continue;
            }
            weld_distance = std::max(weld_distance, hit.distance);
            expected.row(i) = meant.row(hit.vertex);
        }
        EXPECT_LE(weld_distance, 1e-6 * D) << "(c) meshmark's read of " << in_name << " is "
                                           << weld_distance / D << " D away from glTF-Transform's";
        EXPECT_EQ(instance_elements, in_file.instances.vertex_count())
            << "(c) elements of " << in_name << " outside meshmark's welded mesh against its instance points";

        // Same order when nothing renumbers points; a Draco re-encode (edgebreaker) or a count
        // change falls back to the nearest expected position.
        const bool same_order = !c.variant.draco && out_read.rows() == in_read.rows();
        std::unique_ptr<ClosestPointIndex> expected_index;
        if (!same_order)
        {
            expected_index = std::make_unique<ClosestPointIndex>(cloud_index(expected));
        }
        double max_error = 0.0;
        Eigen::Index worst = 0;
        Eigen::Index over = 0;
        for (Eigen::Index i = 0; i < out_read.rows(); ++i)
        {
            if (same_order && is_instance[static_cast<std::size_t>(i)] != 0)
            {
                continue;  // another instance: not what meshmark analysed (see above)
            }
            const Eigen::RowVector3d target =
                same_order ? Eigen::RowVector3d(expected.row(i))
                           : Eigen::RowVector3d(expected.row(
                                 expected_index->closest(Eigen::Vector3d(out_read.row(i).transpose())).vertex));
            const double e = (out_read.row(i) - target).cwiseAbs().maxCoeff();
            over += e > tolerance ? 1 : 0;
            if (e > max_error)
            {
                max_error = e;
                worst = i;
            }
        }
        EXPECT_LE(max_error, tolerance)
            << "(c) positions of " << out_name << " differ from what meshmark meant by up to " << max_error << " ("
            << max_error / D << " D, " << (q > 0 ? max_error / q : 0.0) << " grid steps) at element " << worst << "; "
            << over << " of " << out_read.rows() << " elements beyond the tolerance " << tolerance << " ("
            << (c.variant.position_bits > 0 ? std::to_string(c.variant.position_bits) + "-bit step + 1e-6 D"
                                            : std::string("float32: 1e-6 D"))
            << "), " << (same_order ? "same order" : "nearest expected position");

        const Box out_box = bounds(out_read);
        const double bbox_change =
            std::max((out_box.lo - in_box.lo).cwiseAbs().maxCoeff(), (out_box.hi - in_box.hi).cwiseAbs().maxCoeff()) / D;
        EXPECT_LT(bbox_change, 0.01) << "(c) the bounding box of " << out_name << " moved by " << bbox_change
                                     << " of the diagonal against " << in_name;
        const double displacement = (meant - in_file.mesh.V).cwiseAbs().maxCoeff();
        EXPECT_GT(displacement, 0.0) << "(c) the expected positions equal IN's: the check would not see a missing mark";
        std::printf("[interop] %s: %lld -> %lld positions, max error %.3g D (%.3g steps, tolerance %.3g D), bbox change "
                    "%.3g D, max displacement %.3g D\n",
                    c.name().c_str(), static_cast<long long>(in_read.rows()), static_cast<long long>(out_read.rows()),
                    max_error / D, q > 0 ? max_error / q : 0.0, tolerance / D, bbox_change, displacement / D);
        RecordProperty("max_error_rel", std::to_string(max_error / D));
        RecordProperty("bbox_change_rel", std::to_string(bbox_change));
    }

    // (d) detect: the marked file, then after re-processing it.
    const ToolRun found = meshmark({"detect", out.string(), "--original", in.string(), "--key", key.string(), "-q"}, scratch);
    EXPECT_EQ(found.result.exit_code, 0) << "(d) detect " << out_name << ": " << found.describe();

    const std::vector<std::pair<std::string, Reprocess>> reprocessors{
        {"gltf-transform optimize", gltf_transform_optimize},
        {"gltfpack -cc", gltfpack_cc},
    };
    for (const auto& [what, command] : reprocessors)
    {
        const fs::path again = scratch / ("out." + std::string(what == "gltfpack -cc" ? "gltfpack_cc" : "optimize") + ".glb");
        const ToolRun redo = run(command(out, again), scratch);
        if (!redo.ok())
        {
            // Not meshmark's doing if the tool cannot process the unmarked input either.
            const ToolRun control = run(command(in, scratch / "control.glb"), scratch);
            EXPECT_FALSE(control.ok()) << "(d) " << what << " cannot process " << out_name << " but can process "
                                       << in_name << ": " << redo.describe();
            std::printf("[interop] %s: (d) %s not applicable: it cannot process the unmarked input either: %s\n",
                        c.name().c_str(), what.c_str(), control.describe().c_str());
            continue;
        }
        const ToolRun detected =
            meshmark({"detect", again.string(), "--original", in.string(), "--key", key.string(), "-q"}, scratch);
        if (detected.result.exit_code != 0)
        {
            // A tool that damages the asset itself is no faithful copy: gltfpack -cc of an asset
            // it quantized already, with instances under scaled nodes, collapses the small
            // parts onto a few grid values (measured on the scene: MRMS 1.1% of the diagonal on
            // the UNMARKED input). Such a re-processing is reported, not held against the mark.
            const fs::path control = scratch / "control.glb";
            const ToolRun redo_in = run(command(in, control), scratch);
            const ToolRun distortion = meshmark({"compare", in.string(), control.string(), "--json"}, scratch);
            const auto report = nlohmann::json::parse(distortion.result.out, nullptr, false);
            const double mrms = report.is_discarded() ? 0.0 : report.value("mrms", 0.0);
            if (redo_in.ok() && mrms > kToolDamage)
            {
                std::printf("[interop] %s: (d) %s not applicable: it distorts the unmarked input by MRMS %.3g%% of the "
                            "diagonal (the marked copy: %s)\n",
                            c.name().c_str(), what.c_str(), 100.0 * mrms, tail(detected.result.out, 160).c_str());
                continue;
            }
        }
        EXPECT_EQ(detected.result.exit_code, 0)
            << "(d) detect after " << what << " of " << out_name << ": " << detected.describe();
    }

    // (e) the unmarked input, re-processed, is not claimed. gltfpack refuses Draco input and
    // input it compressed already (-c, -cc, gltf-transform meshopt/optimize); then glTF-Transform
    // re-processes it instead, so that every case still checks an unmarked file.
    {
        const fs::path r0 = scratch / "in.reprocessed.glb";
        ToolRun redo = run(gltfpack_cc(in, r0), scratch);
        std::string how = "gltfpack -cc";
        if (!redo.ok())
        {
            std::printf("[interop] %s: (e) gltfpack -cc cannot process %s (%s); using gltf-transform optimize\n",
                        c.name().c_str(), in_name.c_str(), tail(redo.result.err, 120).c_str());
            redo = run(gltf_transform_optimize(in, r0), scratch);
            how = "gltf-transform optimize";
        }
        ASSERT_TRUE(redo.ok()) << "(e) cannot re-process the unmarked " << in_name << ": " << redo.describe();
        const ToolRun unmarked = meshmark({"detect", r0.string(), "--original", in.string(), "--key", key.string(), "-q"}, scratch);
        EXPECT_EQ(unmarked.result.exit_code, 1)
            << "(e) detect on the unmarked " << in_name << " after " << how << ": " << unmarked.describe();
    }
}

INSTANTIATE_TEST_SUITE_P(Corpus, GltfInterop, ::testing::ValuesIn(gltf_cases()),
                         [](const ::testing::TestParamInfo<GltfCase>& param) { return param.param.name(); });

// ---------------------------------------------------------------------------------------------
// 3MF from PrusaSlicer

// `prusa-slicer --info` of a 3MF: size_x/y/z and min_x/y/z.
std::map<std::string, double> prusa_info(const fs::path& file, const fs::path& scratch, std::string* error)
{
    const ToolRun r = run({tools().xvfb_run.string(), "-a", tools().prusa_slicer.string(), "--info", file.string()}, scratch);
    std::map<std::string, double> info;
    if (!r.ok())
    {
        *error = r.describe();
        return info;
    }
    const std::regex line(R"(^(size|min)_([xyz]) = (-?[0-9.eE+-]+))");
    std::stringstream lines(r.result.out);
    std::string text;
    while (std::getline(lines, text))
    {
        std::smatch match;
        if (std::regex_search(text, match, line))
        {
            info[match[1].str() + "_" + match[2].str()] = std::stod(match[3].str());
        }
    }
    if (info.size() != 6)
    {
        *error = "`prusa-slicer --info " + file.string() + "` printed " + std::to_string(info.size()) +
                 " of the 6 size_/min_ values: " + tail(r.result.out);
    }
    return info;
}

// The entries of a zip file: name -> content (libzip).
std::map<std::string, std::string> zip_entries(const fs::path& file, std::string* error)
{
    std::map<std::string, std::string> entries;
    int code = 0;
    zip_t* archive = zip_open(file.c_str(), ZIP_RDONLY, &code);
    if (archive == nullptr)
    {
        *error = file.string() + ": libzip cannot open it (error " + std::to_string(code) + ")";
        return entries;
    }
    const zip_int64_t count = zip_get_num_entries(archive, 0);
    for (zip_int64_t i = 0; i < count; ++i)
    {
        zip_stat_t stat;
        zip_stat_init(&stat);
        if (zip_stat_index(archive, static_cast<zip_uint64_t>(i), 0, &stat) != 0)
        {
            *error = file.string() + ": cannot stat zip entry " + std::to_string(i);
            break;
        }
        std::string content(static_cast<std::size_t>(stat.size), '\0');
        zip_file_t* entry = zip_fopen_index(archive, static_cast<zip_uint64_t>(i), 0);
        const zip_int64_t got = entry != nullptr ? zip_fread(entry, content.data(), stat.size) : -1;
        if (entry != nullptr)
        {
            zip_fclose(entry);
        }
        if (got != static_cast<zip_int64_t>(stat.size))
        {
            *error = file.string() + ": cannot read zip entry " + stat.name;
            break;
        }
        entries[stat.name] = std::move(content);
    }
    zip_close(archive);
    return entries;
}

TEST(ThreeMfInterop, PrusaSlicerBunny)
{
    const fs::path mesh = mesh_dir() / "bunny.stl";
    if (!fs::exists(mesh))
    {
        GTEST_SKIP() << mesh << " is missing (shared meshes not available)";
    }
    INTEROP_REQUIRE_TOOLS("meshmark", "prusa-slicer");

    std::string error;
    const std::string stamp = "prusa-slicer --export-3mf\n" + file_stamp(mesh) + file_stamp(tools().prusa_slicer);
    const fs::path folder = corpus_entry(
        "bunny.prusa_3mf", stamp,
        [&](const fs::path& staging) {
            const ToolRun r = run({tools().xvfb_run.string(), "-a", tools().prusa_slicer.string(), "--export-3mf", "-o",
                               (staging / "in.3mf").string(), mesh.string()},
                              staging);
            return r.ok() && fs::exists(staging / "in.3mf") ? std::string{} : r.describe();
        },
        &error);
    ASSERT_FALSE(folder.empty()) << "cannot make the PrusaSlicer 3MF: " << error;
    const fs::path in = folder / "in.3mf";
    const fs::path scratch = temp_dir("interop-bunny-3mf");
    const fs::path out = scratch / "out.3mf";
    const fs::path key = scratch / "out.key";

    const ToolRun embed = meshmark({"embed", in.string(), "-o", out.string(), "--key", key.string(), "--seed", kSeed, "-q"}, scratch);
    ASSERT_TRUE(embed.ok()) << "embed of the PrusaSlicer 3MF (bunny.stl) failed: " << embed.describe();

    // PrusaSlicer's own reading of both packages: the object must stay where it was.
    std::string in_error;
    std::string out_error;
    const auto in_info = prusa_info(in, scratch, &in_error);
    const auto out_info = prusa_info(out, scratch, &out_error);
    EXPECT_TRUE(in_error.empty()) << "prusa-slicer --info on the input: " << in_error;
    EXPECT_TRUE(out_error.empty()) << "prusa-slicer --info on meshmark's output: " << out_error;
    if (in_error.empty() && out_error.empty())
    {
        const double diagonal =
            std::sqrt(in_info.at("size_x") * in_info.at("size_x") + in_info.at("size_y") * in_info.at("size_y") +
                      in_info.at("size_z") * in_info.at("size_z"));
        for (const auto& [name, value] : in_info)
        {
            EXPECT_LE(std::abs(out_info.at(name) - value), 0.01 * diagonal)
                << "prusa-slicer --info: " << name << " of the marked 3MF is " << out_info.at(name) << ", of the input "
                << value << " (diagonal " << diagonal << ")";
        }
    }

    const ToolRun found = meshmark({"detect", out.string(), "--original", in.string(), "--key", key.string(), "-q"}, scratch);
    EXPECT_EQ(found.result.exit_code, 0) << "detect on the marked 3MF: " << found.describe();

    // Everything in the package but the model parts is the input's, byte for byte.
    std::string zip_error;
    const auto in_entries = zip_entries(in, &zip_error);
    const auto out_entries = zip_entries(out, &zip_error);
    ASSERT_TRUE(zip_error.empty()) << zip_error;
    const std::regex model(R"(^3D/.*\.model$)");
    std::set<std::string> names;
    for (const auto& entries : {in_entries, out_entries})
    {
        for (const auto& [name, content] : entries)
        {
            if (!std::regex_match(name, model))
            {
                names.insert(name);
            }
        }
    }
    for (const auto& name : names)
    {
        const auto a = in_entries.find(name);
        const auto b = out_entries.find(name);
        if (a == in_entries.end() || b == out_entries.end())
        {
            ADD_FAILURE() << "3MF entry " << name << " is only in " << (a == in_entries.end() ? "the marked output" : "the input");
            continue;
        }
        EXPECT_TRUE(a->second == b->second) << "3MF entry " << name << " differs: input " << a->second.size()
                                            << " bytes, marked output " << b->second.size() << " bytes";
    }
}

}  // namespace
}  // namespace meshmark::test

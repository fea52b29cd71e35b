// SPDX-License-Identifier: MIT
// Binary PLY read and write of a 1M-vertex, 2M-triangle mesh (float32 positions, the common
// layout of scanned models): read_mesh_file, the preserving write_mesh_file embed uses, and the
// generic write_mesh. Files go to a temporary directory removed at exit; the page cache is warm,
// so these are the CPU costs, not the disk's.
#include <filesystem>
#include <string>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include "bench_mesh.h"
#include "meshmark/io/mesh_io.h"

namespace
{

using namespace meshmark;
namespace fs = std::filesystem;

constexpr std::int64_t kVertices = 1'000'000;

struct PlyFixture
{
    fs::path dir;
    fs::path input;
    PlyFixture()
    {
        dir = fs::temp_directory_path() / ("meshmark_bench_perf_" + std::to_string(::getpid()));
        fs::create_directories(dir);
        input = dir / "input.ply";
        WriteOptions options;
        options.use_single_precision = true;
        write_mesh(input, cli::bumpy_torus(kVertices), options);
    }
    ~PlyFixture()
    {
        std::error_code ignored;
        fs::remove_all(dir, ignored);
    }
    PlyFixture(const PlyFixture&) = delete;
    PlyFixture& operator=(const PlyFixture&) = delete;
};

const PlyFixture& fixture()
{
    static const PlyFixture f;
    return f;
}

void set_counters(benchmark::State& state, const fs::path& file)
{
    state.counters["vertices"] = static_cast<double>(kVertices);
    state.counters["MB"] = static_cast<double>(fs::file_size(file)) / 1e6;
}

void BM_PlyRead(benchmark::State& state)
{
    const auto& f = fixture();
    for (auto _ : state)
    {
        const MeshFile file = read_mesh_file(f.input);
        benchmark::DoNotOptimize(file.mesh.V.data());
    }
    set_counters(state, f.input);
}

void BM_PlyWritePreserving(benchmark::State& state)
{
    const auto& f = fixture();
    const MeshFile file = read_mesh_file(f.input);
    const Positions moved = file.mesh.V.array() + 1e-3;
    const fs::path output = f.dir / "preserving.ply";
    for (auto _ : state)
    {
        write_mesh_file(output, file, moved);
    }
    set_counters(state, output);
}

void BM_PlyWrite(benchmark::State& state)
{
    const auto& f = fixture();
    const TriangleMesh mesh = read_mesh(f.input);
    const fs::path output = f.dir / "generic.ply";
    WriteOptions options;
    options.use_single_precision = true;
    for (auto _ : state)
    {
        write_mesh(output, mesh, options);
    }
    set_counters(state, output);
}

}  // namespace

BENCHMARK(BM_PlyRead)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PlyWritePreserving)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PlyWrite)->Unit(benchmark::kMillisecond)->UseRealTime();

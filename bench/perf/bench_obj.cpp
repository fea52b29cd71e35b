// SPDX-License-Identifier: MIT
// OBJ read of a 1M-vertex mesh of polygons, as artists' models carry them: quads (convex: each
// is checked and keeps its fan) or concave hexagons (each is triangulated inside its outline);
// and of one concave outline of 100,000 corners.
// The files go to a temporary directory removed at exit; the page cache is warm, so these are
// the CPU costs, not the disk's.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <benchmark/benchmark.h>
#include <unistd.h>

#include "meshmark/io/mesh_io.h"

namespace
{

using namespace meshmark;
namespace fs = std::filesystem;

constexpr int kSide = 1000;  // kSide x kSide vertices on a bumpy torus

/// The grid's OBJ: quads, or (concave) every two quads of a row joined into a hexagon whose
/// middle corners are moved along the rows, one of them inwards.
fs::path write_grid(const fs::path& dir, bool concave)
{
    const fs::path path = dir / (concave ? "hexagons.obj" : "quads.obj");
    std::ofstream out(path);
    out.precision(9);
    for (int i = 0; i < kSide; ++i)
    {
        for (int j = 0; j < kSide; ++j)
        {
            const double u = 2.0 * M_PI * i / kSide;
            const double v = 2.0 * M_PI * j / kSide;
            // Concave: the middle column of every pair is moved back along the rows, so each
            // hexagon (two quads) has a reflex corner.
            const double dent = concave && j % 2 == 1 ? 0.8 * 2.0 * M_PI / kSide : 0.0;
            const double r = 1.0 + 0.3 * std::cos(v) + 0.01 * std::sin(7 * u) * std::cos(5 * v);
            out << "v " << r * std::cos(u - dent) << ' ' << r * std::sin(u - dent) << ' '
                << 0.3 * std::sin(v) << '\n';
        }
    }
    const auto id = [](int i, int j) { return (i % kSide) * kSide + (j % kSide) + 1; };
    for (int i = 0; i < kSide; ++i)
    {
        for (int j = 0; j < kSide; j += concave ? 2 : 1)
        {
            if (concave)
            {
                out << "f " << id(i, j) << ' ' << id(i + 1, j) << ' ' << id(i + 1, j + 1) << ' '
                    << id(i + 1, j + 2) << ' ' << id(i, j + 2) << ' ' << id(i, j + 1) << '\n';
            }
            else
            {
                out << "f " << id(i, j) << ' ' << id(i + 1, j) << ' ' << id(i + 1, j + 1) << ' '
                    << id(i, j + 1) << '\n';
            }
        }
    }
    return path;
}

/// One face: a star of 100,000 corners along a tilted circle (a concave outline whose corners
/// are nearly cocircular, the Delaunay triangulation's hard case when inserted in order).
fs::path write_star(const fs::path& dir)
{
    constexpr int kCorners = 100'000;
    const fs::path path = dir / "star.obj";
    std::ofstream out(path);
    out.precision(12);
    for (int k = 0; k < kCorners; ++k)
    {
        const double angle = 2.0 * M_PI * k / kCorners;
        const double r = k % 2 == 0 ? 1.0 : 1.01;
        out << "v " << r * std::cos(angle) << ' ' << r * std::sin(angle) << ' '
            << 0.3 * r * std::cos(angle) << '\n';
    }
    out << 'f';
    for (int k = 1; k <= kCorners; ++k)
    {
        out << ' ' << (k % kCorners) + 1;  // from an inner corner: the fan leaves the outline
    }
    out << '\n';
    return path;
}

struct ObjFixture
{
    fs::path dir;
    fs::path quads;
    fs::path hexagons;
    fs::path star;
    ObjFixture()
    {
        dir = fs::temp_directory_path() / ("meshmark_bench_obj_" + std::to_string(::getpid()));
        fs::create_directories(dir);
        quads = write_grid(dir, false);
        hexagons = write_grid(dir, true);
        star = write_star(dir);
    }
    ~ObjFixture()
    {
        std::error_code ignored;
        fs::remove_all(dir, ignored);
    }
    ObjFixture(const ObjFixture&) = delete;
    ObjFixture& operator=(const ObjFixture&) = delete;
};

const ObjFixture& fixture()
{
    static const ObjFixture f;
    return f;
}

void BM_ObjRead(benchmark::State& state)
{
    const auto& f = fixture();
    const fs::path& input = state.range(0) == 0 ? f.quads : f.hexagons;
    for (auto _ : state)
    {
        const MeshFile file = read_mesh_file(input);
        benchmark::DoNotOptimize(file.mesh.F.data());
    }
    state.counters["vertices"] = static_cast<double>(kSide) * kSide;
    state.counters["MB"] = static_cast<double>(fs::file_size(input)) / 1e6;
}

void BM_ObjReadOutline(benchmark::State& state)
{
    const auto& f = fixture();
    for (auto _ : state)
    {
        const MeshFile file = read_mesh_file(f.star);
        benchmark::DoNotOptimize(file.mesh.F.data());
    }
}

}  // namespace

BENCHMARK(BM_ObjReadOutline)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ObjRead)
    ->ArgName("concave")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

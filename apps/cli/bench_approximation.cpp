// SPDX-License-Identifier: MIT
// `meshmark bench approximation`: how well the first k modes of each basis represent the shape,
// E_k = |P - U_k U_k^T P| / |P - centroid| (Frobenius, positions in the centroid frame), for
// several k and bases on the same meshes [Wu & Kobbelt 2005, Fig. 3 and 11].
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <sys/resource.h>

#include "bench_mesh.h"
#include "commands.h"
#include "meshmark/basis/decimated_centers.h"
#include "meshmark/basis/laplacian_basis.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/watermark/watermark.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

namespace fs = std::filesystem;

// Modes whose Gram eigenvalue is below this fraction of the largest are numerically absent
// (the same cut as RbfBasis::position_coefficients).
constexpr double kPresentModeTolerance = 1e-14;

struct ApproximationArgs
{
    std::string mesh_dir;
    std::vector<std::string> meshes;
    std::vector<int> sizes{10, 25, 50, 100, 200};
    std::vector<std::string> bases{"rbf", "rbf-decimate", "laplacian"};
    int keys = 3;
    std::string factorization = "cholmod";
    std::uint64_t seed = 1;
    bool json = false;
};

struct Clock
{
    std::chrono::steady_clock::time_point wall = std::chrono::steady_clock::now();
    double cpu = cpu_now();
    static double cpu_now()
    {
        rusage usage{};
        ::getrusage(RUSAGE_SELF, &usage);
        const auto seconds = [](const timeval& t)
        { return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec); };
        return seconds(usage.ru_utime) + seconds(usage.ru_stime);
    }
    [[nodiscard]] double wall_seconds() const
    {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall).count();
    }
    [[nodiscard]] double cpu_seconds() const { return cpu_now() - cpu; }
};

// |P~ - U c| / |P~| over the active rows, P~ = P - o, for the synthesized field U c.
double relative_error(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                      const Eigen::Vector3d& origin, const Positions& field)
{
    double residual = 0.0;
    double total = 0.0;
    for (const auto i : rows)
    {
        const Eigen::RowVector3d p = mesh.V.row(i) - origin.transpose();
        residual += (p - field.row(i)).squaredNorm();
        total += p.squaredNorm();
    }
    return std::sqrt(residual / total);
}

struct Row
{
    std::string mesh;
    std::string basis;
    int k = 0;
    int modes = 0;  // modes numerically present (RBF), else k
    double error = 0.0;
    double wall = 0.0;  // basis construction, mean over keys
    double cpu = 0.0;
};

std::vector<Row> rbf_rows(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                          const CanonicalFrame& frame, const std::string& name,
                          const std::string& basis, const ApproximationArgs& args, int threads)
{
    const bool is_decimated = basis == "rbf-decimate";
    const int keys = is_decimated ? 1 : args.keys;  // decimated centers do not depend on the key
    std::vector<Row> out;
    for (const int k : args.sizes)
    {
        Row row{name, basis, k, k, 0.0, 0.0, 0.0};
        for (int key = 0; key < keys; ++key)
        {
            const Clock clock;
            const auto centers =
                is_decimated
                    ? decimated_centers(mesh, rows, k)
                    : random_centers(
                          mesh.V, rows, k,
                          derive_seed(derive_seed(args.seed, std::to_string(key)), "centers"));
            const RbfBasis rbf(position_rows(mesh.V, rows), centers, frame.diagonal / 2.0,
                               frame.origin, threads);
            const int present = rbf.well_conditioned_modes(kPresentModeTolerance);
            const Positions field = rbf.synthesize(rbf.position_coefficients().topRows(present));
            row.wall += clock.wall_seconds() / keys;
            row.cpu += clock.cpu_seconds() / keys;
            row.error += relative_error(mesh, rows, frame.origin, field) / keys;
            row.modes = std::min(row.modes, present);
        }
        out.push_back(row);
    }
    return out;
}

std::vector<Row> laplacian_rows(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                                const CanonicalFrame& frame, const std::string& name,
                                const ApproximationArgs& args)
{
    // One basis of the largest k: the first k eigenvectors are those of every smaller k.
    const int largest = *std::max_element(args.sizes.begin(), args.sizes.end());
    const Clock clock;
    const LaplacianBasis basis(
        mesh, rows, frame.origin,
        {.modes = largest,
         .factorization = args.factorization == "ldlt" ? LaplacianFactorization::SimplicialLdlt
                                                       : LaplacianFactorization::Cholmod});
    const double wall = clock.wall_seconds();
    const double cpu = clock.cpu_seconds();
    const Eigen::MatrixX3d alpha = basis.position_coefficients();
    std::vector<Row> out;
    for (const int k : args.sizes)
    {
        const Positions field = basis.synthesize(alpha.topRows(k));
        out.push_back(
            {name, "laplacian", k, k, relative_error(mesh, rows, frame.origin, field), wall, cpu});
    }
    return out;
}

int run_bench_approximation(const ApproximationArgs& args, const GlobalArgs& global)
{
    std::vector<fs::path> paths(args.meshes.begin(), args.meshes.end());
    if (paths.empty())
    {
        paths = mesh_files_in(args.mesh_dir.empty() ? default_mesh_dir() : fs::path(args.mesh_dir));
    }
    if (paths.empty())
    {
        throw InvalidOption("no meshes to measure: give --mesh or a --mesh-dir with meshes.");
    }
    std::vector<Row> table;
    for (const auto& path : paths)
    {
        const TriangleMesh mesh = read_mesh(path);
        const std::string name = path.filename().string();
        const auto rows = referenced_vertices(mesh);
        const CanonicalFrame frame = canonical_frame(mesh.V, rows);
        for (const auto& basis : args.bases)
        {
            if (!global.quiet)
            {
                std::fprintf(stderr, "meshmark bench approximation: %s, %s\n", name.c_str(),
                             basis.c_str());
            }
            const auto part = basis == "laplacian"
                                  ? laplacian_rows(mesh, rows, frame, name, args)
                                  : rbf_rows(mesh, rows, frame, name, basis, args, global.threads);
            table.insert(table.end(), part.begin(), part.end());
        }
    }
    if (args.json)
    {
        nlohmann::json all = nlohmann::json::array();
        for (const auto& r : table)
        {
            all.push_back({{"mesh", r.mesh},
                           {"basis", r.basis},
                           {"k", r.k},
                           {"modes", r.modes},
                           {"relative_error", r.error},
                           {"basis_seconds", r.wall},
                           {"basis_cpu_seconds", r.cpu}});
        }
        print_json({{"rows", all}, {"keys", args.keys}});
        return 0;
    }
    std::printf(
        "| mesh | basis | k | E_k | modes | basis s (wall) | basis s (cpu) "
        "|\n|---|---|---:|---:|---:|---:|---:|\n");
    for (const auto& r : table)
    {
        std::printf("| %s | %s | %d | %s | %d | %s | %s |\n", r.mesh.c_str(), r.basis.c_str(), r.k,
                    format_number(r.error, 4).c_str(), r.modes, format_number(r.wall, 3).c_str(),
                    format_number(r.cpu, 3).c_str());
    }
    std::printf(
        "E_k = |P - U_k U_k^T P| / |P - centroid|; rbf: mean over %d random-center keys; "
        "laplacian: one basis of the largest k (its time is that of the whole basis); "
        "modes: RBF modes numerically present (< k when the Gram matrix is singular).\n",
        args.keys);
    return 0;
}

}  // namespace

void register_bench_approximation(CLI::App& bench, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<ApproximationArgs>();
    auto* command = bench.add_subcommand(
        "approximation",
        "Approximation error E_k of the shape by the first k modes of each basis (Wu & Kobbelt's "
        "Fig. 3/11)");
    command->add_option(
        "--mesh-dir", args->mesh_dir,
        "Meshes (.ply .obj .off .stl); default $MESHMARK_MESH_DIR, else ../shared/data/meshes");
    command->add_option("--mesh", args->meshes, "Mesh files instead of a directory (repeatable)");
    command->add_option("--sizes", args->sizes, "Values of k, comma-separated")
        ->delimiter(',')
        ->check(CLI::Range(1, 5000))
        ->capture_default_str();
    command
        ->add_option("--basis", args->bases, "Bases, comma-separated: rbf, rbf-decimate, laplacian")
        ->delimiter(',')
        ->check(CLI::IsMember({"rbf", "rbf-decimate", "laplacian"}))
        ->capture_default_str();
    command->add_option("--keys", args->keys, "Random-center keys averaged for rbf")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    command->add_option("--seed", args->seed, "Seed of the random-center keys")
        ->capture_default_str();
    command
        ->add_option("--factorization", args->factorization,
                     "Factorization of the shifted Laplacian: cholmod (CHOLMOD supernodal) or ldlt "
                     "(Eigen SimplicialLDLT)")
        ->check(CLI::IsMember({"cholmod", "ldlt"}))
        ->capture_default_str();
    command->add_flag("--json", args->json, "Print one JSON object instead of the table");
    add_global_flags(*command, global);
    command->callback(
        [args, &global, &runner]()
        { runner = [args, &global]() { return run_bench_approximation(*args, global); }; });
}

}  // namespace meshmark::cli

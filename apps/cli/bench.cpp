// SPDX-License-Identifier: MIT
// `meshmark bench speed`: end-to-end embed and detect timings and peak memory per mesh.
//
// Every embed and detect runs in its own child process (posix_spawn of this very program with
// `embed ... --json` / `detect ... --json`), so each peak RSS (wait4's ru_maxrss) is that run's
// own and the phase times are the ones embed_file/detect_file report. The parent never loads a
// mesh: generated meshes are written by a forked child, because Linux folds the RSS peak of the
// process image an exec replaces into the child's ru_maxrss, and a large parent would hide the
// child's own figure.
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <sys/resource.h>
#include <unistd.h>

#include "bench_child.h"
#include "bench_mesh.h"
#include "commands.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"
#include "report.h"

namespace meshmark::cli
{
namespace
{

namespace fs = std::filesystem;

struct BenchSpeedArgs
{
    std::string mesh_dir;
    std::vector<std::string> meshes;
    std::vector<std::string> bases{"rbf"};
    std::vector<std::int64_t> sizes{10'000, 100'000, 1'000'000};
    std::string work_dir;
    int repeat = 1;
    bool no_shared = false;
    bool no_generated = false;
    bool no_detect = false;
    bool keep = false;
    bool json = false;
    std::string attack;  ///< detect an attacked copy (spec) instead of the marked one
    std::int64_t max_detect_vertices = 5'000'000;  ///< no detect above this
    int out_of_core_mib = 0;       ///< > 0: also embed generated meshes streamed with this budget
    bool compare_threads = false;  ///< also embed with 1 thread (speedup, identity)
};

struct Case
{
    std::string name;
    fs::path input;
    bool is_generated = false;
};

// True when both files hold the same bytes (compared in 1 MiB pieces: the files may be GBs).
bool same_bytes(const fs::path& a, const fs::path& b)
{
    std::error_code error;
    if (fs::file_size(a, error) != fs::file_size(b, error) || error)
    {
        return false;
    }
    std::ifstream fa(a, std::ios::binary);
    std::ifstream fb(b, std::ios::binary);
    std::vector<char> ba(std::size_t{1} << 20U);
    std::vector<char> bb(ba.size());
    while (fa && fb)
    {
        fa.read(ba.data(), static_cast<std::streamsize>(ba.size()));
        fb.read(bb.data(), static_cast<std::streamsize>(bb.size()));
        if (fa.gcount() != fb.gcount() ||
            !std::equal(ba.begin(), ba.begin() + fa.gcount(), bb.begin()))
        {
            return false;
        }
    }
    return fa.eof() && fb.eof();
}

// A second embed of \p c with \p extra arguments, compared byte for byte with the first one's
// marked file and key: its phases, peak and CPU time under \p prefix in \p row.
void bench_variant(const fs::path& program, const Case& c, const fs::path& work,
                   const fs::path& output, const fs::path& key, const std::string& threads,
                   const std::vector<std::string>& extra, const std::string& prefix,
                   nlohmann::json& row)
{
    const fs::path other = work / (prefix + "-" + c.input.filename().string());
    const fs::path other_key = work / (prefix + "-key-" + c.input.stem().string() + ".json");
    std::vector<std::string> command{"embed",   c.input.string(),   "-o",     other.string(),
                                     "--key",   other_key.string(), "--seed", "20261122",
                                     "--force", "--json",           "-q",     "--threads",
                                     threads};
    command.insert(command.end(), extra.begin(), extra.end());
    const ChildRun run = run_child(program, command);
    row[prefix + "_exit_code"] = run.exit_code;
    if (run.exit_code == 0)
    {
        row[prefix + "_seconds"] = run.report["seconds"];
        row[prefix + "_peak_mib"] = run.peak_mib;
        row[prefix + "_cpu_seconds"] = run.cpu_seconds;
        row[prefix + "_identical"] = same_bytes(output, other) && same_bytes(key, other_key);
    }
    std::error_code ignored;
    fs::remove(other, ignored);
    fs::remove(other_key, ignored);
}

std::vector<Case> shared_cases(const fs::path& dir)
{
    std::vector<Case> cases;
    for (const auto& path : mesh_files_in(dir))
    {
        cases.push_back({path.filename().string(), path});
    }
    return cases;
}

double phase(const nlohmann::json& report, const char* name)
{
    if (report.contains("seconds") && report["seconds"].contains(name))
    {
        return report["seconds"][name].get<double>();
    }
    return 0.0;
}

nlohmann::json bench_case(const fs::path& program, const Case& c, const std::string& basis,
                          const fs::path& work, const BenchSpeedArgs& args,
                          const GlobalArgs& global)
{
    const fs::path output =
        work / ("marked-" + basis + "-" + c.input.stem().string() + c.input.extension().string());
    const fs::path key = work / ("key-" + basis + "-" + c.input.stem().string() + ".json");
    const std::string threads = std::to_string(global.threads);
    std::optional<ChildRun> best;
    for (int r = 0; r < args.repeat; ++r)
    {
        ChildRun run = run_child(program, {"embed", c.input.string(), "-o", output.string(),
                                           "--key", key.string(), "--seed", "20261122", "--force",
                                           "--json", "-q", "--threads", threads, "--basis", basis});
        if (run.exit_code != 0)
        {
            best = std::move(run);
            break;
        }
        if (!best || phase(run.report, "total") < phase(best->report, "total"))
        {
            best = std::move(run);
        }
    }
    nlohmann::json row = {{"mesh", c.name},
                          {"input", c.input.string()},
                          {"basis", basis},
                          {"threads", global.threads}};
    row["embed_exit_code"] = best->exit_code;
    if (best->exit_code != 0)
    {
        return row;
    }
    const auto vertices = best->report.value("vertices", std::int64_t{0});
    const double total = phase(best->report, "total");
    row["vertices"] = vertices;
    row["faces"] = best->report.value("faces", std::int64_t{0});
    row["embed_seconds"] = best->report["seconds"];
    row["embed_process_seconds"] = best->wall_seconds;
    // CPU time is the figure to trust on a shared machine, where wall time includes waiting.
    row["embed_cpu_seconds"] = best->cpu_seconds;
    row["embed_us_per_vertex"] = vertices > 0 ? 1e6 * total / static_cast<double>(vertices) : 0.0;
    row["embed_peak_mib"] = best->peak_mib;
    if (args.out_of_core_mib > 0 && c.is_generated && basis == "rbf")
    {
        // Out of core the strength is a vertex measure (the surface one needs the faces in
        // memory): the streamed copy is compared with the in-memory one of that measure.
        const fs::path reference = work / ("vertex-" + c.input.filename().string());
        const fs::path reference_key = work / ("vertex-key-" + c.input.stem().string() + ".json");
        const ChildRun in_memory =
            run_child(program, {"embed", c.input.string(), "-o", reference.string(), "--key",
                                reference_key.string(), "--seed", "20261122", "--force", "--json",
                                "-q", "--threads", threads, "--strength-measure", "vertex"});
        if (in_memory.exit_code != 0)
        {
            throw IoError(
                c.input.string() +
                ": the in-memory embed with --strength-measure vertex failed (exit code " +
                std::to_string(in_memory.exit_code) + ").");
        }
        bench_variant(program, c, work, reference, reference_key, threads,
                      {"--stream", "--memory-budget", std::to_string(args.out_of_core_mib),
                       "--strength-measure", "vertex"},
                      "stream", row);
        std::error_code ignored;
        fs::remove(reference, ignored);
        fs::remove(reference_key, ignored);
    }
    if (args.compare_threads && basis == "rbf")
    {
        bench_variant(program, c, work, output, key, "1", {}, "one_thread", row);
    }
    if (!args.no_detect && vertices <= args.max_detect_vertices)
    {
        fs::path suspect = output;
        if (!args.attack.empty())
        {
            suspect = work / ("suspect-" + basis + "-" + c.input.stem().string() + ".ply");
            const ChildRun attack =
                run_child(program, {"attack", output.string(), "-o", suspect.string(), "--seed",
                                    "2", "-q", "--threads", threads, args.attack});
            if (attack.exit_code != 0)
            {
                throw IoError(output.string() +
                              ": `meshmark attack` failed on the marked copy (exit code " +
                              std::to_string(attack.exit_code) + ").");
            }
            row["detect_attack"] = args.attack;
        }
        const ChildRun detect =
            run_child(program, {"detect", suspect.string(), "--original", c.input.string(), "--key",
                                key.string(), "--json", "-q", "--threads", threads});
        if (suspect != output)
        {
            std::error_code ignored;
            fs::remove(suspect, ignored);
        }
        row["detect_exit_code"] = detect.exit_code;
        row["detected"] = detect.exit_code == 0;
        if (detect.exit_code == 0 || detect.exit_code == 1)
        {
            row["detect_seconds"] = detect.report["seconds"];
            row["detect_peak_mib"] = detect.peak_mib;
            row["detect_cpu_seconds"] = detect.cpu_seconds;
            row["correlation"] = detect.report.value("correlation", 0.0);
        }
    }
    if (!args.keep)
    {
        std::error_code ignored;
        fs::remove(output, ignored);
        fs::remove(key, ignored);
    }
    return row;
}

// Per mesh timed with several bases: each basis against the first one of --basis.
void print_ratios(const std::vector<nlohmann::json>& rows)
{
    bool has_header = false;
    for (const auto& base : rows)
    {
        if (base.value("embed_exit_code", -1) != 0)
        {
            continue;
        }
        for (const auto& other : rows)
        {
            if (&other == &base || other["mesh"] != base["mesh"] ||
                other.value("embed_exit_code", -1) != 0 || base["basis"] != rows.front()["basis"] ||
                other["basis"] == base["basis"])
            {
                continue;
            }
            if (!has_header)
            {
                std::printf("\n%-24s %-21s %9s %9s %9s %9s %9s\n", "mesh", "ratio", "basis s",
                            "total s", "cpu s", "peak MB", "detect s");
                has_header = true;
            }
            const auto ratio = [&](double a, double b) { return b > 0.0 ? a / b : 0.0; };
            const auto get = [](const nlohmann::json& o, const char* k) { return o.value(k, 0.0); };
            const auto detect = [&](const nlohmann::json& r)
            { return r.contains("detect_seconds") ? get(r["detect_seconds"], "total") : 0.0; };
            const std::string name =
                other["basis"].get<std::string>() + " / " + base["basis"].get<std::string>();
            std::printf(
                "%-24s %-21s %9.1f %9.1f %9.1f %9.2f %9.1f\n",
                base["mesh"].get<std::string>().c_str(), name.c_str(),
                ratio(get(other["embed_seconds"], "basis"), get(base["embed_seconds"], "basis")),
                ratio(get(other["embed_seconds"], "total"), get(base["embed_seconds"], "total")),
                ratio(get(other, "embed_cpu_seconds"), get(base, "embed_cpu_seconds")),
                ratio(get(other, "embed_peak_mib"), get(base, "embed_peak_mib")),
                ratio(detect(other), detect(base)));
        }
    }
}

void print_table(const std::vector<nlohmann::json>& rows)
{
    std::printf("%-24s %-9s %9s %7s %7s %7s %7s %7s %7s %8s %8s %8s %8s %s\n", "mesh", "basis",
                "vertices", "read", "basis", "embed", "write", "total", "cpu", "us/vert", "peak MB",
                "detect", "det. MB", "found");
    for (const auto& row : rows)
    {
        if (row.value("embed_exit_code", -1) != 0)
        {
            std::printf("%-24s %-9s embed failed (exit code %d)\n",
                        row["mesh"].get<std::string>().c_str(),
                        row["basis"].get<std::string>().c_str(), row.value("embed_exit_code", -1));
            continue;
        }
        const auto& s = row["embed_seconds"];
        const auto get = [](const nlohmann::json& o, const char* k) { return o.value(k, 0.0); };
        std::printf("%-24s %-9s %9lld %7.3f %7.3f %7.3f %7.3f %7.3f %7.3f %8.3f %8.1f",
                    row["mesh"].get<std::string>().c_str(), row["basis"].get<std::string>().c_str(),
                    static_cast<long long>(row["vertices"].get<std::int64_t>()), get(s, "read"),
                    get(s, "basis"), get(s, "embed"), get(s, "write"), get(s, "total"),
                    row.value("embed_cpu_seconds", 0.0), row["embed_us_per_vertex"].get<double>(),
                    row["embed_peak_mib"].get<double>());
        if (row.contains("detect_seconds"))
        {
            std::printf(" %8.3f %8.1f %s\n", get(row["detect_seconds"], "total"),
                        row["detect_peak_mib"].get<double>(),
                        row["detected"].get<bool>() ? "yes" : "NO");
        }
        else if (row.contains("detect_exit_code"))
        {
            std::printf(" detect failed (exit code %d)\n", row["detect_exit_code"].get<int>());
        }
        else
        {
            std::printf("\n");
        }
    }
    std::printf(
        "Times in seconds (embed_file's phases, best of --repeat by total); cpu = the embed "
        "process's user + system time; peak MB = the run's own peak RSS in MiB; detect = "
        "detect_file on the marked copy%s.\n",
        rows.empty() || !rows.front().contains("detect_attack")
            ? ""
            : (" after `attack " + rows.front()["detect_attack"].get<std::string>() + "`").c_str());
    const auto get = [](const nlohmann::json& o, const char* k) { return o.value(k, 0.0); };
    bool has_header = false;
    for (const auto& row : rows)
    {
        if (!row.contains("stream_exit_code"))
        {
            continue;
        }
        if (!has_header)
        {
            std::printf(
                "\nOut of core (--stream --memory-budget), against the in-memory embed above:\n"
                "%-24s %9s %7s %7s %7s %7s %8s %8s %10s %s\n",
                "mesh", "vertices", "scan", "basis", "write", "total", "cpu", "peak MB", "Mvert/s",
                "identical");
            has_header = true;
        }
        if (row["stream_exit_code"].get<int>() != 0)
        {
            std::printf("%-24s streamed embed failed (exit code %d)\n",
                        row["mesh"].get<std::string>().c_str(), row["stream_exit_code"].get<int>());
            continue;
        }
        const auto& t = row["stream_seconds"];
        const double total = get(t, "total");
        const auto vertices = static_cast<double>(row["vertices"].get<std::int64_t>());
        std::printf("%-24s %9lld %7.3f %7.3f %7.3f %7.3f %8.3f %8.1f %10.2f %s\n",
                    row["mesh"].get<std::string>().c_str(),
                    static_cast<long long>(row["vertices"].get<std::int64_t>()),
                    get(t, "scan") + get(t, "frame"), get(t, "basis"), get(t, "write"), total,
                    get(row, "stream_cpu_seconds"), get(row, "stream_peak_mib"),
                    total > 0.0 ? vertices / total / 1e6 : 0.0,
                    row["stream_identical"].get<bool>() ? "yes" : "NO");
    }
    has_header = false;
    for (const auto& row : rows)
    {
        if (!row.contains("one_thread_exit_code") || row["one_thread_exit_code"].get<int>() != 0)
        {
            continue;
        }
        if (!has_header)
        {
            std::printf(
                "\nOne thread against --threads of the table above (embed totals):\n"
                "%-24s %-9s %9s %9s %9s %9s %s\n",
                "mesh", "basis", "vertices", "1 thread", "threads", "speedup", "identical");
            has_header = true;
        }
        const double one = get(row["one_thread_seconds"], "total");
        const double many = get(row["embed_seconds"], "total");
        std::printf("%-24s %-9s %9lld %9.3f %9.3f %9.2f %s\n",
                    row["mesh"].get<std::string>().c_str(), row["basis"].get<std::string>().c_str(),
                    static_cast<long long>(row["vertices"].get<std::int64_t>()), one, many,
                    many > 0.0 ? one / many : 0.0,
                    row["one_thread_identical"].get<bool>() ? "yes" : "NO");
    }
    print_ratios(rows);
}

int run_bench_speed(const BenchSpeedArgs& args, const GlobalArgs& global)
{
    const fs::path program = fs::read_symlink("/proc/self/exe");
    const fs::path work =
        args.work_dir.empty()
            ? fs::temp_directory_path() / ("meshmark-bench-" + std::to_string(::getpid()))
            : fs::path(args.work_dir);

    std::vector<Case> cases;
    if (!args.no_shared)
    {
        const fs::path dir = args.mesh_dir.empty() ? default_mesh_dir() : fs::path(args.mesh_dir);
        std::error_code error;
        if (!args.mesh_dir.empty() && !fs::is_directory(dir, error))
        {
            throw IoError(dir.string() + ": --mesh-dir is not a directory.");
        }
        cases = shared_cases(dir);
        if (!args.meshes.empty())
        {
            cases.clear();
            for (const auto& m : args.meshes)
            {
                if (!fs::is_regular_file(m, error))
                {
                    throw IoError(m + ": --mesh is not a readable file.");
                }
                cases.push_back({fs::path(m).filename().string(), fs::path(m)});
            }
        }
        if (cases.empty() && !global.quiet)
        {
            std::fprintf(stderr,
                         "meshmark bench: no meshes in %s (set --mesh-dir or MESHMARK_MESH_DIR)\n",
                         dir.string().c_str());
        }
    }
    if (cases.empty() && (args.no_generated || args.sizes.empty()))
    {
        throw InvalidOption(
            "nothing to time: no meshes in the mesh directory and no generated sizes.");
    }
    fs::create_directories(work);
    // A temporary work directory goes away however the run ends (unless --keep).
    struct RemoveOnExit
    {
        fs::path path;
        ~RemoveOnExit()
        {
            if (!path.empty())
            {
                std::error_code ignored;
                fs::remove_all(path, ignored);
            }
        }
    } const cleanup{args.work_dir.empty() && !args.keep ? work : fs::path()};
    std::vector<fs::path> generated;
    for (const auto n : args.no_generated ? std::vector<std::int64_t>{} : args.sizes)
    {
        const fs::path path = work / ("generated-" + std::to_string(n) + ".ply");
        if (!global.quiet)
        {
            std::fprintf(stderr, "meshmark bench: generating %lld vertices\n",
                         static_cast<long long>(n));
        }
        write_generated(path, n);
        generated.push_back(path);
        cases.push_back({"generated-" + std::to_string(n), path, true});
    }

    std::vector<nlohmann::json> rows;
    for (const auto& c : cases)
    {
        for (const auto& basis : args.bases)
        {
            if (!global.quiet)
            {
                std::fprintf(stderr, "meshmark bench: %s, %s basis\n", c.name.c_str(),
                             basis.c_str());
            }
            rows.push_back(bench_case(program, c, basis, work, args, global));
        }
    }
    if (!args.keep)
    {
        std::error_code ignored;
        for (const auto& path : generated)
        {
            fs::remove(path, ignored);
        }
    }
    rusage self{};
    ::getrusage(RUSAGE_SELF, &self);
    if (args.json)
    {
        print_json({{"runs", rows},
                    {"threads", global.threads},
                    {"repeat", args.repeat},
                    {"harness_peak_mib", static_cast<double>(self.ru_maxrss) / 1024.0}});
    }
    else
    {
        print_table(rows);
    }
    // A failed run, a copy not found, or a streamed or 1-thread embed that differs is a failure.
    const bool all_ok = std::all_of(
        rows.begin(), rows.end(),
        [](const nlohmann::json& r)
        {
            return r.value("embed_exit_code", -1) == 0 && r.value("detect_exit_code", 0) == 0 &&
                   r.value("stream_exit_code", 0) == 0 && r.value("stream_identical", true) &&
                   r.value("one_thread_exit_code", 0) == 0 && r.value("one_thread_identical", true);
        });
    return all_ok ? 0 : static_cast<int>(ExitCode::Internal);
}

}  // namespace

void register_bench(CLI::App& app, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<BenchSpeedArgs>();
    auto* bench = app.add_subcommand("bench", "Measure meshmark itself");
    bench->require_subcommand(1);
    auto* speed = bench->add_subcommand("speed",
                                        "Embed and detect times and peak RSS, a process per run, "
                                        "on the shared and generated meshes");
    speed->add_option("--mesh-dir", args->mesh_dir,
                      "Meshes to time (.ply .obj .off .stl); default $MESHMARK_MESH_DIR, else "
                      "../shared/data/meshes");
    speed->add_option("--mesh", args->meshes,
                      "Mesh files to time instead of the whole --mesh-dir (repeatable)");
    speed
        ->add_option("--basis", args->bases,
                     "Bases to time on every mesh, comma-separated (rbf, laplacian)")
        ->delimiter(',')
        ->check(CLI::IsMember({"rbf", "laplacian"}))
        ->capture_default_str();
    speed->add_flag("--no-shared", args->no_shared, "Only the generated meshes");
    speed->add_flag("--no-generated", args->no_generated, "Only the meshes of --mesh-dir");
    speed
        ->add_option("--sizes", args->sizes,
                     "Vertex counts of generated meshes (binary float32 PLY)")
        ->delimiter(',')
        ->check(CLI::Range(std::int64_t{9}, std::int64_t{100'000'000}))
        ->capture_default_str();
    speed
        ->add_option("--repeat", args->repeat, "Embed runs per mesh; the fastest total is reported")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    speed->add_option("--work-dir", args->work_dir,
                      "Where generated meshes, marked copies and keys go (default: a temporary "
                      "directory)");
    speed->add_flag("--keep", args->keep, "Keep the generated meshes, marked copies and keys");
    speed->add_flag("--no-detect", args->no_detect, "Time embed only");
    speed->add_option(
        "--attack", args->attack,
        "Detect a copy attacked with this spec (seed 2) instead of the marked copy itself");
    speed
        ->add_option("--max-detect-vertices", args->max_detect_vertices,
                     "Skip detection on larger meshes")
        ->check(CLI::Range(std::int64_t{0}, std::int64_t{1'000'000'000}))
        ->capture_default_str();
    speed
        ->add_option("--out-of-core", args->out_of_core_mib,
                     "MiB: also embed generated meshes out of core and compare with the in-memory "
                     "embed (0 = no)")
        ->check(CLI::Range(0, 1 << 20))
        ->capture_default_str();
    speed->add_flag("--compare-threads", args->compare_threads,
                    "Also embed with one thread: speedup of --threads over 1, and whether the "
                    "outputs are identical");
    speed->add_flag("--json", args->json, "Print one JSON object with every run on stdout");
    add_global_flags(*speed, global);
    speed->callback([args, &global, &runner]()
                    { runner = [args, &global]() { return run_bench_speed(*args, global); }; });
    register_bench_robustness(*bench, global, runner);
    register_bench_approximation(*bench, global, runner);
}

}  // namespace meshmark::cli

// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/embed_file.h"

#include <cmath>
#include <fstream>
#include <iterator>
#include <optional>
#include <random>
#include <thread>

#include <unistd.h>

#include "embed_streamed.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/file_lock.h"
#include "meshmark/meshmark.h"
#include "timer.h"

namespace meshmark
{
namespace
{

std::uint64_t fresh_seed()
{
    std::random_device device;
    return (static_cast<std::uint64_t>(device()) << 32U) ^ static_cast<std::uint64_t>(device());
}

void check_paths(const std::filesystem::path& input, const std::filesystem::path& output,
                 const std::filesystem::path& key_path, bool force)
{
    if (is_same_file(input, key_path) || output == key_path)
    {
        throw InvalidOption(key_path.string() +
                            ": the key file must differ from the input and output.");
    }
    if (!force && std::filesystem::exists(key_path))
    {
        throw InvalidOption(key_path.string() + ": " + detail::kKeyExists +
                            " Choose another --key or pass --force.");
    }
}

}  // namespace

void check_basis_input(const TriangleMesh& mesh, const EmbedOptions& options,
                       const std::filesystem::path& path)
{
    if (!mesh.is_point_cloud())
    {
        return;
    }
    if (options.basis == BasisType::Laplacian)
    {
        throw InvalidMesh(path.string() +
                          ": the Laplacian basis needs triangles, but this file is a "
                          "point cloud (no faces); use --basis rbf.");
    }
    if (options.centers == CenterSelection::Decimate)
    {
        throw InvalidMesh(path.string() +
                          ": decimated centers need triangles, but this file is a "
                          "point cloud (no faces); use --centers random.");
    }
}

SpectralWatermark watermark_of(const TriangleMesh& mesh, const Key& key,
                               const std::filesystem::path& path, int threads)
{
    try
    {
        return SpectralWatermark(mesh, key, threads);
    }
    catch (const InvalidMesh& e)
    {
        throw InvalidMesh(path.string() + ": " + e.what());
    }
    catch (const NumericalError& e)
    {
        throw NumericalError(path.string() + ": " + e.what());
    }
}

void EmbedMeshOptions::validate() const
{
    embed.validate();
    if (message && bits_hex)
    {
        throw InvalidOption("give either --message or --bits, not both.");
    }
    if (threads < 0)
    {
        throw InvalidOption("--threads must be >= 0 (0 = all cores).");
    }
    if (!(std::isfinite(max_displacement) && max_displacement >= 0.0))
    {
        throw InvalidOption(
            "the largest displacement's cap must be a positive length (0 = no cap).");
    }
}

void EmbedFileOptions::validate() const
{
    EmbedMeshOptions::validate();
    if (memory_budget_mib < 0)
    {
        throw InvalidOption("--memory-budget must be >= 0 MiB (0 = no budget).");
    }
    if (max_displacement_length && max_displacement > 0.0)
    {
        throw InvalidOption(
            "give the largest displacement's cap once: as a length or in the mesh's units.");
    }
    if (max_displacement_length && force_stream)
    {
        throw InvalidOption(
            "--max-displacement embeds in memory (it reads the written copy back); drop --stream.");
    }
}

namespace detail
{

double write_mesh_and_key(const std::filesystem::path& key_path, const Key& key,
                          const EmbedFileOptions& options, const std::function<void()>& write_mesh)
{
    // Recorded before released (docs/reliability.md): the key is durable at its path before the
    // copy it traces is written, so a crash at any moment leaves no marked copy without its key.
    // The lock makes the check for an existing key and its replacement one step: two calls
    // creating the same key cannot both succeed, one's copy traced by the other's key.
    FileLock lock = lock_key(key_path, options.lock_timeout, options.progress);
    std::optional<std::string> previous;  // the key this call replaces (force), restored on failure
    if (std::filesystem::exists(key_path))
    {
        if (!options.force)
        {
            throw InvalidOption(key_path.string() + ": " + kKeyExists +
                                " Choose another --key or pass --force.");
        }
        std::ifstream in(key_path, std::ios::binary);
        previous.emplace(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        if (in.bad())
        {
            throw IoError(key_path.string() + ": cannot read the key file it would replace.");
        }
    }
    write_key(key_path, key);
    try
    {
        write_mesh();
    }
    catch (...)
    {
        // Neither file: the key as it was (under the same lock, so no other call saw the new one
        // trace a copy).
        try
        {
            if (previous)
            {
                write_file_atomically(key_path, [&](std::ostream& out) { out << *previous; },
                                      {.permissions = 0600});
            }
            else
            {
                std::filesystem::remove(key_path);
            }
        }
        catch (...)  // NOLINT(bugprone-empty-catch): the write's error is the one to report
        {
        }
        throw;
    }
    return lock.waited_seconds();
}

FileLock lock_key(const std::filesystem::path& key_path, std::chrono::milliseconds timeout,
                  const ProgressCallback& progress)
{
    create_parent_directories(key_path);
    return lock_file(key_path, {.timeout = timeout,
                                .on_wait = [&]
                                {
                                    if (progress)
                                    {
                                        progress("wait for the key", 0.0);
                                    }
                                }});
}

}  // namespace detail

Key detail::new_key(const EmbedMeshOptions& options)
{
    return make_key(options.embed, options.seed ? *options.seed : fresh_seed(), options.message,
                    options.bits_hex);
}

namespace
{

// The in-memory embed of \p mesh (named \p name in errors) into \p result: phases "basis" and
// "embed" on \p timer.
void embed_into(EmbedResult& result, detail::PhaseTimer& timer, const TriangleMesh& mesh,
                const std::filesystem::path& name, const EmbedMeshOptions& options,
                std::optional<LengthUnit> unit = std::nullopt)
{
    timer.begin("basis");
    Key key = detail::new_key(options);
    check_basis_input(mesh, key.options, name);

    // Basis (pass 1 + eigen-decomposition) -> synthesis of the displacement (pass 2). The
    // fingerprint (a serial hash of the positions, 15 ms at 1M vertices) is independent of the
    // basis: it runs on one more thread while the basis starts with its serial canonical frame
    // (30 ms), and is joined before the key is used. The jthread joins on every path.
    MeshFingerprint original_fingerprint;
    std::jthread fingerprinter;
    if (options.threads != 1)
    {
        fingerprinter = std::jthread([&] { original_fingerprint = fingerprint(mesh); });
    }
    else
    {
        original_fingerprint = fingerprint(mesh);
    }
    SpectralWatermark mark = watermark_of(mesh, key, name, options.threads);
    if (fingerprinter.joinable())
    {
        fingerprinter.join();
    }
    key.original = original_fingerprint;
    timer.lap("basis");
    timer.begin("embed");
    // The field becomes the marked positions in place: one #V x 3 array, not two.
    result.positions = mark.displacement(&result.stats);
    mark.calibrate_strength(mesh, result.positions, &result.stats);
    if (options.max_displacement > 0.0)
    {
        result.cap = cap_displacement(mark, mesh, result.positions, &result.stats,
                                      options.max_displacement, name, unit);
    }
    result.diagonal = bounding_box(mesh.V, mark.mesh_rows()->active()).diagonal();
    key.options =
        mark.key().options;  // the calibrated (and capped) strength and the automatic repetitions
    result.positions += mesh.V;
    timer.lap("embed");
    result.key = std::move(key);
}

}  // namespace

EmbedResult embed(const TriangleMesh& mesh, const EmbedMeshOptions& options)
{
    options.validate();
    EmbedResult result;
    detail::PhaseTimer timer(result.seconds, options.progress);
    embed_into(result, timer, mesh, "mesh", options);
    return result;
}

namespace
{

// The cap as the user wrote it, in the coordinates of \p input, whose unit is \p unit.
double cap_in_mesh_units(const Length& cap, std::optional<LengthUnit> unit,
                         const std::filesystem::path& input)
{
    std::string written = std::to_string(cap.value);
    written.erase(written.find_last_not_of('0') + 1);
    if (!written.empty() && written.back() == '.')
    {
        written.pop_back();
    }
    written += cap.unit ? to_string(*cap.unit) : "";
    return length_in_mesh_units(cap, unit, input.string() + ": --max-displacement " + written);
}

// The largest displacement of the file just written at \p output from \p source, as read
// back (the file's rounding included), checked against \p cap: a file that exceeds it (a
// quantized glTF whose grid is coarser than the cap) is removed and refused.
double check_written_cap(const MeshFile& source, const std::filesystem::path& output, double cap,
                         std::optional<LengthUnit> unit)
{
    // Row for row: the preserving writer (same format), or the plain writers that keep the
    // rows in order. Others (STL, glTF, 3MF from another format) may regroup the vertices; the
    // margin's bound stands for them.
    const MeshFormat format = format_from_extension(output);
    if (format != source.format && format != MeshFormat::Ply && format != MeshFormat::Obj &&
        format != MeshFormat::Off)
    {
        return -1.0;
    }
    const TriangleMesh written = read_mesh(output);
    if (written.V.rows() != source.mesh.V.rows())
    {
        return -1.0;
    }
    const double largest = largest_row_distance(written.V, source.mesh.V);
    if (largest > cap)
    {
        std::error_code ignored;
        std::filesystem::remove(output, ignored);
        const auto text = [&](double v)
        { return unit ? format_length(v, *unit) : std::to_string(v); };
        throw NumericalError(
            output.string() + ": the written file moves a vertex by " + text(largest) +
            ", beyond --max-displacement " + text(cap) +
            ": its coordinates are stored more coarsely than the cap (quantized); nothing was "
            "written.");
    }
    return largest;
}

EmbedReport embed_to_new_file(const std::filesystem::path& input,
                              const std::filesystem::path& output,
                              const std::filesystem::path& key_path,
                              const EmbedFileOptions& options)
{
    options.validate();
    check_paths(input, output, key_path, options.force);
    (void)format_from_extension(output);  // fail on a bad extension before any work

    std::string note;
    // A cap reads the written copy back: in memory only (EmbedFileOptions::validate).
    if (const auto streamed = options.max_displacement_length
                                  ? std::nullopt
                                  : detail::stream_plan(input, output, options, &note))
    {
        return detail::embed_file_streamed(*streamed, output, key_path, detail::new_key(options),
                                           options);
    }

    EmbedReport report;
    report.stream_note = note;
    detail::PhaseTimer timer(report.seconds, options.progress);
    timer.begin("read");
    const MeshFile file = read_mesh_file(input);
    report.input_format = file.format;
    report.output_format = format_from_extension(output);
    report.vertex_count = file.mesh.vertex_count();
    report.face_count = file.mesh.face_count();
    report.unit = options.unit ? options.unit : file.unit;
    report.is_unit_from_file = !options.unit && file.unit.has_value();
    EmbedMeshOptions mesh_options = options;
    if (options.max_displacement_length)
    {
        mesh_options.max_displacement =
            cap_in_mesh_units(*options.max_displacement_length, report.unit, input);
    }
    timer.lap("read");
    EmbedResult marked;
    embed_into(marked, timer, file.mesh, input, mesh_options, report.unit);
    timer.begin("write");
    // (A binary PLY goes out in slices of the original bytes: no second copy of the file.)
    const double waited = detail::write_mesh_and_key(
        key_path, marked.key, options,
        [&]()
        {
            write_mesh_file(output, file, marked.positions);
            if (mesh_options.max_displacement > 0.0)
            {
                report.written_max_displacement =
                    check_written_cap(file, output, mesh_options.max_displacement, report.unit);
            }
        });
    timer.lap("write");
    report.seconds.phases.emplace_back("lock", waited);  // the part of "write" spent waiting
    report.key = std::move(marked.key);
    report.stats = marked.stats;
    report.diagonal = marked.diagonal;
    report.cap = marked.cap;
    return report;
}

// In place (see EmbedFileOptions::replace_input): embed into a hidden staging file next to the
// input, give it the input's permissions, then rename it over the input.
EmbedReport embed_in_place(const std::filesystem::path& input, const std::filesystem::path& output,
                           const std::filesystem::path& key_path, const EmbedFileOptions& options)
{
    const std::filesystem::path target = std::filesystem::canonical(input);
    // (Built by appending: GCC 12 reports a false -Wrestrict on `"." + std::string`.)
    std::string staged_name(1, '.');
    staged_name += target.stem().string();
    staged_name += ".meshmark-embed-";
    staged_name += std::to_string(::getpid());
    staged_name += target.extension().string();
    const std::filesystem::path staged = target.parent_path() / staged_name;
    // The input's permissions before the embed: the marked copy that replaces it keeps them
    // (a fresh file would get the default mode of an atomic write instead).
    const std::filesystem::perms mode = std::filesystem::status(target).permissions();
    EmbedReport report = embed_to_new_file(input, staged, key_path, options);
    std::error_code error;
    std::filesystem::permissions(staged, mode, error);
    if (!error)
    {
        std::filesystem::rename(staged, target, error);
    }
    if (error)
    {
        std::error_code ignored;
        std::filesystem::remove(staged, ignored);
        throw IoError(output.string() + ": cannot replace the input with the marked copy (" +
                      error.message() + "); the input is unchanged.");
    }
    return report;
}

}  // namespace

EmbedReport embed_file(const std::filesystem::path& input, const std::filesystem::path& output,
                       const std::filesystem::path& key_path, const EmbedFileOptions& options)
{
    if (!is_same_file(input, output))
    {
        return embed_to_new_file(input, output, key_path, options);
    }
    if (!options.replace_input)
    {
        throw InvalidOption(output.string() +
                            ": -o names the input file, which an embed never "
                            "replaces unless asked; choose another -o or pass --force.");
    }
    return embed_in_place(input, output, key_path, options);
}

}  // namespace meshmark

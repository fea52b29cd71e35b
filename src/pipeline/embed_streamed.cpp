// SPDX-License-Identifier: MIT
// Out-of-core embedding of a binary PLY: the schedule of the passes. The file format (layout,
// face scan, vertex readers, the patched copy) is the io module's PlyStream.
//
// Passes (each one sequential over the file, reading windows with pread):
//   1. elements after the vertex element: faces triangulated exactly as the reader does, to
//      mark the referenced vertices (1 byte per vertex) and count the triangles;
//   2. vertex section x 3: canonical frame (CanonicalFrameBuilder, the code canonical_frame
//      runs), with the fingerprint hash, finiteness check and bounding box in the first;
//   3. keyed centers (random_centers over the active rows, positions read one record each);
//   4. RbfBasis pass 1 through a RowPositionSource (one cursor per chunk);
//   5. synthesis, chunk by chunk in row order, patched into the vertex records on their way
//      to the output, between the header and the rest of the file copied through.
#include "embed_streamed.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <memory>
#include <numeric>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "meshmark/basis/row_source.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/hash.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/threads.h"
#include "timer.h"

namespace meshmark::detail
{
namespace
{

// The active rows of the file for the basis passes: one sequential reader per cursor.
class FileRowCursor final : public RowPositionCursor
{
public:
    FileRowCursor(const PlyStream& file, const ReferencedVertices& referenced, std::size_t begin,
                  std::size_t window)
        : referenced_(referenced), reader_(file, referenced.select(begin), window), next_(begin)
    {
    }
    void read(std::size_t count, double* xyz, std::int32_t* rows) override
    {
        reader_.read_active(referenced_, count, xyz, rows);
        next_ += count;
    }
    void read_at(std::span<const std::size_t> indices, double* xyz, std::int32_t* rows) override
    {
        for (std::size_t i = 0; i < indices.size(); ++i)
        {
            reader_.skip_active(referenced_, indices[i] - next_);  // the active rows before it
            reader_.read_active(referenced_, 1, xyz + 3 * i, rows + i);
            next_ = indices[i] + 1;
        }
    }

private:
    const ReferencedVertices& referenced_;
    PlyVertexReader reader_;
    std::size_t next_;  // active-row index of the next active record
};

class FileRowSource final : public RowPositionSource
{
public:
    FileRowSource(const PlyStream& file, const ReferencedVertices& referenced, std::size_t window)
        : file_(file), referenced_(referenced), window_(window)
    {
    }
    [[nodiscard]] std::size_t size() const override
    {
        return static_cast<std::size_t>(referenced_.active);
    }
    [[nodiscard]] std::size_t vertex_count() const override
    {
        return static_cast<std::size_t>(file_.vertex_count());
    }
    [[nodiscard]] std::int32_t row(std::size_t i) const override
    {
        return static_cast<std::int32_t>(referenced_.select(i));
    }
    [[nodiscard]] std::array<double, 3> position(std::int32_t row) const override
    {
        return file_.position(static_cast<std::uint64_t>(row));
    }
    [[nodiscard]] std::unique_ptr<RowPositionCursor> cursor(std::size_t begin) const override
    {
        return std::make_unique<FileRowCursor>(file_, referenced_, begin, window_);
    }

private:
    const PlyStream& file_;
    const ReferencedVertices& referenced_;
    std::size_t window_;
};

// Fingerprint hash, bounding box and canonical frame of the active rows.
struct FrameResult
{
    std::uint64_t hash = 0;
    BoundingBox box;
    CanonicalFrameBuilder frame;
};

// The three frame passes over the vertices, in blocks; the first also hashes every vertex
// (the key's position hash), checks that it is finite and bounds the active ones.
// \p on_pass(pass) after each pass, if given.
FrameResult frame_passes(const PlyStream& file, const ReferencedVertices& referenced,
                         std::size_t window, const std::function<void(int)>& on_pass)
{
    const std::uint64_t n = file.vertex_count();
    FrameResult result;
    Hasher hasher(n * 3 * sizeof(double));
    bool has_box = false;
    constexpr std::size_t kBlock = 4096;
    Positions block(static_cast<Eigen::Index>(kBlock), 3);
    std::vector<std::int32_t> every_row(kBlock);
    std::iota(every_row.begin(), every_row.end(), 0);
    std::vector<std::int32_t> active_rows;
    active_rows.reserve(kBlock);
    int pass = 0;
    while (result.frame.pass() != CanonicalFrameBuilder::Pass::Done)
    {
        const bool is_first = result.frame.pass() == CanonicalFrameBuilder::Pass::Centroid;
        PlyVertexReader reader(file, 0, window);
        for (std::uint64_t first = 0; first < n; first += kBlock)
        {
            const auto count = static_cast<std::size_t>(std::min<std::uint64_t>(kBlock, n - first));
            if (is_first)
            {
                // Row by row, each row hashed as soon as it is read: the hash is one long chain
                // of dependent multiplies, and this lets the processor parse the next record
                // while the chain runs (hashing the block after reading it was 5% slower
                // on 20M vertices).
                double* values = block.data();
                for (std::size_t i = 0; i < count; ++i)
                {
                    reader.read(1, values + 3 * i);
                    hasher.update(values + 3 * i, 3 * sizeof(double));
                }
            }
            else
            {
                reader.read(count, block.data());
            }
            std::span<const std::int32_t> rows(every_row.data(), count);
            if (!referenced.flags.empty())
            {
                active_rows.clear();
                for (std::size_t i = 0; i < count; ++i)
                {
                    if (referenced.flags[first + i] != 0)
                    {
                        active_rows.push_back(static_cast<std::int32_t>(i));
                    }
                }
                rows = active_rows;
            }
            if (is_first)
            {
                const double* values = block.data();
                for (std::size_t k = 0; k < 3 * count; ++k)
                {
                    if (!std::isfinite(values[k]))
                    {
                        throw InvalidMesh(file.path().string() + ": vertex " +
                                          std::to_string(first + k / 3) +
                                          " has a non-finite coordinate (NaN or infinity).");
                    }
                }
                for (const std::int32_t i : rows)
                {
                    const Eigen::Vector3d p = block.row(i).transpose();
                    if (!has_box)
                    {
                        result.box.min = p;
                        result.box.max = p;
                        has_box = true;
                    }
                    result.box.min = result.box.min.cwiseMin(p);
                    result.box.max = result.box.max.cwiseMax(p);
                }
            }
            result.frame.add_rows(block, rows);
        }
        result.frame.next_pass();
        if (on_pass)
        {
            on_pass(++pass);
        }
    }
    result.hash = hasher.value();
    return result;
}

// The face scan and, with two threads or more, the frame passes beside it on the guess that
// every vertex is referenced (the usual case: then they are exactly the passes the flags
// would give). Errors keep their order: the scan's is thrown here, the guess's is kept in
// guess_error for after the basis size check.
struct ScanResult
{
    ReferencedVertices referenced;
    std::optional<FrameResult> guess;
    std::exception_ptr guess_error;
};

ScanResult scan(const PlyStream& file, std::size_t window, bool overlap)
{
    ScanResult result;
    if (!overlap)
    {
        result.referenced = file.scan_faces(window);
        return result;
    }
    std::exception_ptr scan_error;
    std::thread scanner(
        [&]()
        {
            try
            {
                result.referenced = file.scan_faces(window);
            }
            catch (...)
            {
                scan_error = std::current_exception();
            }
        });
    ReferencedVertices everything;  // no flags: every vertex
    everything.active = file.vertex_count();
    try
    {
        result.guess = frame_passes(file, everything, window, {});
    }
    catch (...)
    {
        result.guess_error = std::current_exception();
    }
    scanner.join();
    if (scan_error)
    {
        std::rethrow_exception(scan_error);
    }
    return result;
}

// Chunks of the synthesis computed at once: at most a quarter of the memory budget (256 MiB
// without one) for two rounds (one computed, one written), at most one per thread.
std::size_t chunks_in_flight(const EmbedFileOptions& options, std::size_t chunk_bytes)
{
    const int threads = resolve_threads(options.threads);
    const std::size_t budget = options.memory_budget_mib > 0
                                   ? static_cast<std::size_t>(options.memory_budget_mib) << 20U
                                   : std::size_t{256} << 20U;
    return std::clamp<std::size_t>(budget / 8 / std::max<std::size_t>(chunk_bytes, 1), 1,
                                   static_cast<std::size_t>(threads));
}

// Why the options cannot be embedded out of core ("" if they can): the streamed passes build
// the RBF basis with random centers only (the Laplacian basis and the decimation need the whole
// mesh in memory).
std::string options_refusal(const EmbedFileOptions& options)
{
    if (options.embed.basis != BasisType::Rbf)
    {
        return "the Laplacian basis needs the whole mesh in memory";
    }
    if (options.embed.centers != CenterSelection::Random)
    {
        return "decimated centers need the whole mesh in memory";
    }
    return {};
}

// Why \p input cannot be embedded out of core into \p output ("" if it can); opens it into
// \p opened unless it was.
std::string stream_refusal(const std::filesystem::path& input, const std::filesystem::path& output,
                           const EmbedFileOptions& options, std::optional<PlyStream>& opened)
{
    std::string refusal = options_refusal(options);
    if (!refusal.empty())
    {
        return refusal;
    }
    if (format_from_extension(input) != MeshFormat::Ply)
    {
        return "it is not a PLY file";
    }
    if (format_from_extension(output) != MeshFormat::Ply)
    {
        return "the output is not a PLY file (a format conversion needs the mesh in memory)";
    }
    if (!opened)
    {
        opened.emplace(input);
    }
    return opened->refusal();
}

}  // namespace

std::optional<PlyStream> stream_plan(const std::filesystem::path& input,
                                     const std::filesystem::path& output,
                                     const EmbedFileOptions& options, std::string* note)
{
    std::optional<PlyStream> opened;
    if (options.force_stream)
    {
        const std::string refusal = stream_refusal(input, output, options, opened);
        if (!refusal.empty())
        {
            throw InvalidOption(input.string() +
                                ": cannot be embedded out of core (--stream): " + refusal + ".");
        }
        return opened;
    }
    if (options.memory_budget_mib <= 0 || format_from_extension(input) != MeshFormat::Ply)
    {
        return std::nullopt;
    }
    opened.emplace(input);
    const auto budget = static_cast<std::uint64_t>(options.memory_budget_mib) << 20U;
    if (in_memory_embed_bytes(*opened) <= budget)
    {
        return std::nullopt;
    }
    const std::string refusal = stream_refusal(input, output, options, opened);
    if (!refusal.empty())
    {
        *note =
            "the in-memory embed exceeds the memory budget, but the input cannot be streamed: " +
            refusal;
        return std::nullopt;
    }
    return opened;
}

std::uint64_t in_memory_embed_bytes(const PlyStream& input)
{
    // What reading takes (the file's bytes, 24 B of positions per vertex, 12 B per triangle),
    // the marked copy (24 B), active rows and flags (5 B) per vertex, and the process's base.
    constexpr std::uint64_t kBase = std::uint64_t{32} << 20U;
    return input.read_memory_bytes() + 29 * input.vertex_count() + kBase;
}

EmbedReport embed_file_streamed(const PlyStream& file, const std::filesystem::path& output,
                                const std::filesystem::path& key_path, Key key,
                                const EmbedFileOptions& options, const StreamTuning& tuning)
{
    EmbedReport report;
    report.streamed = true;
    PhaseTimer timer(report.seconds, options.progress);
    // Fractions within a phase; 1 (the end of a phase) is for the timer's lap alone.
    const auto progress = [&](const char* phase, double fraction)
    {
        if (options.progress && fraction < 1.0)
        {
            options.progress(phase, fraction);
        }
    };
    const std::size_t window = std::max<std::size_t>(tuning.window_bytes, 64);

    // Header and faces (the frame passes beside them, see scan()).
    timer.begin("scan");
    const std::string refusal = file.refusal();
    if (!refusal.empty())
    {
        throw InvalidOption(file.path().string() + ": cannot be embedded out of core: " + refusal +
                            ".");
    }
    const bool overlap = resolve_threads(options.threads) > 1;
    ScanResult scanned = scan(file, window, overlap);
    const ReferencedVertices& referenced = scanned.referenced;
    report.input_format = MeshFormat::Ply;
    report.output_format = MeshFormat::Ply;
    report.vertex_count = static_cast<std::int64_t>(file.vertex_count());
    report.face_count = static_cast<std::int64_t>(referenced.triangles);
    timer.lap("scan");

    // Fingerprint, finiteness, bounding box and canonical frame; again over the referenced
    // vertices when the scan found unreferenced ones.
    timer.begin("frame");
    if (key.options.needs_calibration())
    {
        // The surface measure needs the faces and the whole field in memory: out of core the
        // strength is applied as its vertex equivalent on a uniformly sampled surface, and the
        // key says so (docs/algorithms/embedding.md, "Strength").
        key.options.measure = StrengthMeasure::Vertex;
        key.options.strength *= std::sqrt(3.0);
        report.strength_note =
            "out of core, the strength is applied as an RMS vertex displacement of " +
            std::to_string(key.options.strength) +
            " of the diagonal (the surface measure needs the mesh in memory)";
    }
    key.options.validate();
    check_analysed_rows(key.options, static_cast<std::size_t>(referenced.active),
                        file.path().string());
    if (scanned.guess_error)
    {
        std::rethrow_exception(scanned.guess_error);
    }
    if (!scanned.guess || referenced.active != file.vertex_count())
    {
        scanned.guess = frame_passes(file, referenced, window,
                                     [&](int pass) { progress("frame", pass / 3.0); });
    }
    const BoundingBox box = scanned.guess->box;
    const CanonicalFrameBuilder& frame = scanned.guess->frame;
    key.original.vertex_count = static_cast<std::int64_t>(file.vertex_count());
    key.original.face_count = static_cast<std::int64_t>(referenced.triangles);
    key.original.position_hash = scanned.guess->hash;
    timer.lap("frame");

    // Centers and basis (pass 1 over the file): the watermark reads the active rows' positions
    // through the file's row source.
    timer.begin("basis");
    const auto source = std::make_shared<const FileRowSource>(file, referenced, window);
    const SpectralWatermark mark = [&]
    {
        try
        {
            return SpectralWatermark(key, source, frame.frame(), options.threads);
        }
        catch (const NumericalError& e)
        {
            throw NumericalError(file.path().string() + ": " + e.what());
        }
    }();
    key.options = mark.key().options;  // the automatic repetitions, as the watermark resolved them
    const std::size_t chunk_bytes = mark.basis().max_chunk_rows() * 3 * sizeof(double);
    timer.lap("basis");

    // Synthesis streamed into the output: header, patched vertex records, the rest as is.
    timer.begin("write");
    const std::size_t in_flight = chunks_in_flight(options, chunk_bytes);
    const Eigen::MatrixX3d change = mark.coefficient_change();
    const auto active = static_cast<double>(referenced.active);
    const double waited = write_mesh_and_key(
        key_path, key, options,
        [&]()
        {
            write_file_atomically(
                output,
                [&](std::ostream& out)
                {
                    PlyDisplacedCopy writer(file, referenced, output, out, window);
                    DisplacementSummary summary;
                    double orthogonality = 0.0;
                    mark.basis().synthesize_streamed(
                        change, in_flight,
                        [&](std::size_t begin, std::size_t rows, const double* field)
                        {
                            for (std::size_t i = 0; i < rows; ++i)
                            {
                                summary.add(field + 3 * i);
                            }
                            writer.add(rows, field);
                            progress("write", static_cast<double>(begin + rows) / active);
                        },
                        &orthogonality);
                    writer.finish();
                    mark.describe(summary, box.diagonal(), orthogonality, &report.stats);
                });
        });
    timer.lap("write");
    report.seconds.phases.emplace_back("lock", waited);  // the part of "write" spent waiting
    report.key = std::move(key);
    return report;
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/core/file_lock.h"
#include "meshmark/core/length_unit.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/displacement_cap.h"
#include "meshmark/pipeline/progress.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// \brief Options of the in-memory embed (meshmark.h): the watermark's parameters plus where
/// its seed and payload come from (see make_key).
struct EmbedMeshOptions
{
    EmbedOptions embed;                   ///< k, m, rule, strength, sigma factor.
    std::optional<std::string> message;   ///< Payload from a text (hashed to 3m bits).
    std::optional<std::string> bits_hex;  ///< Payload given directly as hex digits.
    std::optional<std::uint64_t> seed;    ///< Secret seed; drawn from the OS when absent.
    int threads = 0;                      ///< 0 = all cores (resolve_threads).
    /// \brief Cap on the largest vertex displacement, in the mesh's coordinates; 0: none. When
    /// the strength would move a vertex further, it is lowered to fit with room for float32
    /// rounding, and an undetectable mark is refused (cap_displacement, displacement_cap.h).
    /// Not for recipient copies (one family strength for copies of different largest moves).
    double max_displacement = 0.0;
    ProgressCallback progress;  ///< Optional.
    /// \throws InvalidOption on conflicting or out-of-range options.
    void validate() const;
};

/// Options of embed_file: those of the in-memory embed plus the files' handling.
struct EmbedFileOptions : EmbedMeshOptions
{
    bool force = false;  ///< Allow replacing an existing key file.
    /// Longest wait for the key while another call changes it (file_lock.h); then IoError.
    std::chrono::milliseconds lock_timeout = kDefaultLockTimeout;
    /// \brief Allow the output to be the input itself (in-place embedding). The marked copy is
    /// written to a hidden staging file next to the input, ".<stem>.meshmark-embed-<pid><ext>",
    /// given the input's permissions and renamed over it once the mesh and the key are complete:
    /// the input is replaced by a whole marked file or not at all, and never opened for writing.
    /// A kill between the two leaves the staging file (hidden, never an output name) and the
    /// input untouched. Without it an output naming the input is refused (InvalidOption).
    bool replace_input = false;
    /// \brief Memory budget in MiB, 0 = none. When the in-memory embed of a binary PLY would
    /// need more, the file is embedded out of core (streamed in chunks, same output bytes);
    /// an input that cannot be streamed is then embedded in memory anyway.
    std::int64_t memory_budget_mib = 0;
    /// Always embed out of core; an input that cannot be streamed is an error (InvalidOption).
    bool force_stream = false;
    /// The unit of the input's coordinates as the user states it (`--unit`); overrides the
    /// unit the file declares (MeshFile::unit). Empty: the file's, if it has one.
    std::optional<LengthUnit> unit;
    /// \brief The cap on the largest displacement as the user wrote it (`--max-displacement
    /// 0.05mm`; a bare number is in the coordinates' unit, refused when there is none); turned
    /// into EmbedMeshOptions::max_displacement once the file is read. Embeds in memory. The
    /// written file is read back and its largest displacement checked against the cap.
    std::optional<Length> max_displacement_length;
    /// \throws InvalidOption on conflicting or out-of-range options.
    void validate() const;
};

/// What embed_file did.
struct EmbedReport
{
    Key key;
    EmbedStats stats;
    MeshFormat input_format = MeshFormat::Ply;
    MeshFormat output_format = MeshFormat::Ply;
    std::int64_t vertex_count = 0;
    std::int64_t face_count = 0;
    PhaseTimings seconds;
    bool streamed = false;    ///< Embedded out of core.
    std::string stream_note;  ///< Why a budget-exceeding input was embedded in memory anyway.
    /// Out of core: how the surface strength was applied (as its vertex equivalent).
    std::string strength_note;
    /// The unit of the coordinates: `--unit`, else the file's (MeshFile::unit); empty: unitless.
    std::optional<LengthUnit> unit;
    bool is_unit_from_file = false;  ///< The unit is the file's declaration (not `--unit`).
    /// Axis-aligned bbox diagonal of the analysed vertices in the coordinates' unit: the
    /// length EmbedStats' `_rel` fractions are of.
    double diagonal = 0.0;
    DisplacementCap cap;  ///< What the cap did (cap.cap == 0: none asked for).
    /// With a cap: the largest displacement between the input's and the written file's vertices
    /// as read back (the file's own rounding included), coordinates' unit; -1: not measured.
    double written_max_displacement = -1.0;
};

/// \brief Refuse, with one sentence naming \p path, a key that \p mesh cannot use: the
/// Laplacian basis or decimated centers on a point cloud (they need faces).
/// \throws InvalidMesh in those cases.
void check_basis_input(const TriangleMesh& mesh, const EmbedOptions& options,
                       const std::filesystem::path& path);

/// \brief The watermark of \p key on \p mesh (SpectralWatermark), its InvalidMesh and
/// NumericalError errors (a mesh with fewer usable vertices than the basis has functions, or
/// whose vertices span fewer modes than the mark needs, say) naming \p path.
[[nodiscard]] SpectralWatermark watermark_of(const TriangleMesh& mesh, const Key& key,
                                             const std::filesystem::path& path, int threads);

/// \brief Watermark a mesh file end to end: read -> the in-memory embed (meshmark.h) -> write
/// mesh and key; or, for large binary PLY files under a memory budget, the same bytes out of core.
/// \details The output is written in the format of its extension; when that is the input's
/// format everything but the positions is preserved (see write_mesh_file). The input is never
/// opened for writing (in place, with replace_input, it is replaced by a rename). Both files are
/// written atomically, missing folders created, under the key's lock (another call creating or
/// replacing the same key waits up to lock_timeout): the key first, made durable, then the
/// mesh, so a marked copy is never visible without the key that traces it; a failure writing
/// the mesh puts the key back as it was (removed, or the replaced one restored).
/// \throws InvalidOption (output naming the input without replace_input, key path equal to the
/// input or output, existing key without force, bad options), IoError, InvalidMesh,
/// NumericalError.
EmbedReport embed_file(const std::filesystem::path& input, const std::filesystem::path& output,
                       const std::filesystem::path& key_path, const EmbedFileOptions& options);

}  // namespace meshmark

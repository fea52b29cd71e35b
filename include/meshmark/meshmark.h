// SPDX-License-Identifier: MIT
#pragma once

/// \file
/// \brief meshmark as a library: the one header to include (docs/library.md).
/// \details Watermark a TriangleMesh in memory with embed() and look for the mark in a suspect
/// with detect(); embed_file() and detect_file() do the same from and to files (read -> the
/// in-memory step -> write), including in-place embedding (EmbedFileOptions::replace_input)
/// and the out-of-core embed of large binary PLY files. A Key (make_key, read_key, write_key)
/// and the original mesh regenerate the watermark; keep both. Errors are typed exceptions
/// (meshmark/core/error.h); "not found" is a result, not an error. Every call is deterministic:
/// the same inputs, seed and options give the same bits for any thread count.

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/attack_file.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/pipeline/progress.h"
#include "meshmark/pipeline/report_json.h"
#include "meshmark/pipeline/verdict.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// What the in-memory embed made.
struct EmbedResult
{
    /// Seed, parameters, payload and the original's fingerprint: save it with write_key.
    Key key;
    /// The marked vertex positions, row for row those of the input (its faces are unchanged).
    Positions positions;
    EmbedStats stats;
    PhaseTimings seconds;  ///< Phases "basis" and "embed".
    /// Axis-aligned bbox diagonal of the analysed vertices (mesh units): what stats' `_rel`
    /// fractions are of.
    double diagonal = 0.0;
    DisplacementCap cap;  ///< What EmbedMeshOptions::max_displacement did.
};

/// \brief Watermark \p mesh in memory (docs/algorithms/embedding.md).
/// \details The key is made by make_key from the options (the seed drawn from the OS when
/// absent) and gets \p mesh's fingerprint. For the same mesh, seed and options the positions
/// are exactly those embed_file writes, and the key the one it writes.
/// \throws InvalidOption for bad options, InvalidMesh for a mesh the basis cannot use (a
/// point cloud with the Laplacian basis or decimated centers, too few vertices),
/// NumericalError.
[[nodiscard]] EmbedResult embed(const TriangleMesh& mesh, const EmbedMeshOptions& options);

/// \brief Look for the watermark of \p key in \p suspect, in memory (docs/algorithms/detection.md).
/// \details detect_file without the files: \p original must be the mesh the key was made from
/// (checked against its fingerprint); the suspect is taken vertex for vertex or registered and
/// resampled as in detect_file, and the report is the one detect_file gives for the same meshes.
/// \throws IoError when \p original is not the key's original, InvalidMesh when the key's
/// basis cannot use it, InvalidOption for bad options or, with registration off, a suspect
/// that does not correspond to the original; NumericalError.
[[nodiscard]] DetectReport detect(const TriangleMesh& suspect, const TriangleMesh& original,
                                  const Key& key, const DetectFileOptions& options = {});

}  // namespace meshmark

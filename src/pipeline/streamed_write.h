// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>

#include "meshmark/io/mesh_io.h"

namespace meshmark::detail {

/// \brief The preserving write of a binary PLY, streamed: the original bytes go out in
/// slices of at most 1 MiB with the changed coordinates patched in, instead of as one patched
/// copy of the whole file (write_mesh_file), so the output never occupies memory twice.
/// \details Produces exactly write_mesh_file's bytes (same atomic write, same float
/// conversion and range checks, unchanged coordinates keep their bytes).
/// \return false, having written nothing, unless \p path has the source's format and the
/// source is a binary PLY with its layout; the caller then uses write_mesh_file.
/// \throws IoError (not writable, or a coordinate does not fit the file's type),
/// InvalidMesh (non-finite coordinate).
bool write_binary_ply_streamed(const std::filesystem::path& path, const MeshFile& source,
                               const Positions& positions);

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// Private interface between the attacks library and its OpenVDB plugin, libmeshmark_voxel.so
// (voxel_openvdb_plugin.cpp). OpenVDB, TBB and their dependencies take ~70 ms and ~27 MB to load
// and relocate, so only the plugin links them and the library opens it (dlopen) the first time
// a voxel remeshing runs: every other meshmark process never loads them.
#pragma once

#include <cstddef>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

/// File name of the plugin (a CMake MODULE library built with the attacks library).
inline constexpr const char* kVoxelPluginFile = "libmeshmark_voxel.so";

/// Name of the plugin's entry point. The suffix is the interface version: raise it whenever
/// the signature below or the layout of TriangleMesh changes, so that a stale plugin is refused
/// by dlsym instead of being called with the wrong arguments.
inline constexpr const char* kVoxelPluginSymbol = "meshmark_voxel_remesh_v1";

/// Return codes of the entry point.
enum VoxelPluginStatus : int
{
    kVoxelPluginOk = 0,
    kVoxelPluginOutOfMemory = 1,  ///< std::bad_alloc was caught.
    kVoxelPluginFailed = 2,       ///< Any other exception; its what() is in the message buffer.
};

/// \brief The entry point: the OpenVDB half of voxel_remesh (voxel_remeshing.cpp validates,
/// picks the voxel edge and the shift, and checks that a surface is left).
/// \details The vertices of \p mesh minus \p shift, in single precision, become a narrow-band
/// level set of voxel edge \p voxel, whose zero level set is extracted, triangulated, oriented
/// outwards and moved back by \p shift into \p result (no faces when no surface is left). Runs
/// in a TBB arena of \p threads workers (capped at the cores TBB sees). Never throws: an
/// exception is caught and reported by the status, with its message in \p message (NUL-
/// terminated, cut to \p message_size bytes).
/// \param shift  3 doubles.
using VoxelRemeshFunction = int (*)(const TriangleMesh* mesh, double voxel, const double* shift,
                                    int threads, TriangleMesh* result, char* message,
                                    std::size_t message_size) noexcept;

/// \brief The plugin's entry point, loaded on the first call (once per process, thread-safe).
/// \details Searched for, in order: only in $MESHMARK_PLUGIN_DIR when that is set (so a test or
/// a user can point it elsewhere); otherwise in the directory of the object holding this code
/// (the program, or a shared library or Python extension that links meshmark), then in
/// `lib/meshmark/` (and `<libdir>/meshmark/`) in that directory and up to four of its parents,
/// then in the configured install prefix's plugin directory (`<libdir>/meshmark/`).
/// \throws Error (exit code 5) with one sentence naming what was searched, when the plugin is
/// missing, cannot be loaded (e.g. OpenVDB is not installed) or lacks the entry point.
[[nodiscard]] VoxelRemeshFunction voxel_plugin();

}  // namespace meshmark::detail

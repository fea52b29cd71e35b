// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/file_lock.h"
#include "meshmark/io/ply_stream.h"
#include "meshmark/pipeline/embed_file.h"

namespace meshmark::detail
{

/// The key of a new embed: make_key with the options' seed, or one drawn from the OS.
[[nodiscard]] Key new_key(const EmbedMeshOptions& options);

/// The refusal to replace a key, after "KEY: ".
inline constexpr const char* kKeyExists =
    "a key file already exists there; it may be the only proof for copies marked earlier.";

/// \brief Under the key's lock (lock_key): refuse an existing key unless options.force, write
/// \p key durably at \p key_path, then run \p write_mesh (which writes the mesh atomically).
/// If \p write_mesh fails the key is put back as it was (removed, or the replaced one
/// restored): both files or neither, and never the copy without its key (see embed_file).
/// \return The seconds spent waiting for the lock.
/// \throws InvalidOption (an existing key without force), IoError (the lock's wait expired, a
/// write failed) and whatever \p write_mesh throws.
double write_mesh_and_key(const std::filesystem::path& key_path, const Key& key,
                          const EmbedFileOptions& options, const std::function<void()>& write_mesh);

/// \brief The lock that makes every change of the key at \p key_path one step (FileLock), its
/// missing folders created first; while it waits, \p progress hears "wait for the key".
/// \throws IoError when \p timeout expires or the folder cannot be made.
[[nodiscard]] FileLock lock_key(const std::filesystem::path& key_path,
                                std::chrono::milliseconds timeout,
                                const ProgressCallback& progress);

/// \brief The input, opened and analysed once, when \p options ask for an out-of-core embed:
/// with --stream (force_stream), or when the in-memory embed would exceed the memory budget
/// (in_memory_embed_bytes) and the input can be streamed. Otherwise nullopt, with a note in
/// \p note when the budget asked for streaming but the input or options cannot be streamed.
/// \details Streamed: a binary PLY (PlyStream::refusal() empty) written to a .ply, with the
/// RBF basis and random centers.
/// \throws InvalidOption when --stream is given but the input cannot be streamed; IoError when
/// the input cannot be read or its header is malformed.
[[nodiscard]] std::optional<PlyStream> stream_plan(const std::filesystem::path& input,
                                                   const std::filesystem::path& output,
                                                   const EmbedFileOptions& options,
                                                   std::string* note);

/// \brief Memory the in-memory embed of \p input would need, in bytes (estimate from the file
/// size and the header's counts: the file, positions and field, triangles, row lists).
[[nodiscard]] std::uint64_t in_memory_embed_bytes(const PlyStream& input);

/// Tuning of the out-of-core embed (tests shrink the window to force many reads).
struct StreamTuning
{
    std::size_t window_bytes = std::size_t{1} << 20U;  ///< Bytes per read of a vertex pass.
};

/// \brief Out-of-core embed_file: the same output and key files, byte for byte, as the
/// in-memory path for the same input, seed and options, with memory O(#V bytes + k^2) plus
/// a few chunks of the passes (see docs/performance.md, "Out of core").
/// \details Paths are checked and the key is staged by the caller's rules (embed_file);
/// \p key.seed, options and payload are given, the fingerprint is computed here.
/// \throws InvalidOption unless input.refusal() is empty.
EmbedReport embed_file_streamed(const PlyStream& input, const std::filesystem::path& output,
                                const std::filesystem::path& key_path, Key key,
                                const EmbedFileOptions& options, const StreamTuning& tuning = {});

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

// Detection's first stage: what it reads, read once and up front (read_inputs), and the
// meshes every later stage works on (DetectInputs).

#include <filesystem>
#include <optional>
#include <vector>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/pipeline/detect_file.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// The animations of an animated original, where detection may read a copy through their poses.
struct AnimatedOriginal
{
    /// The original's file as read (ReadInputs::original), posed at other times
    /// (for_each_animation_pose) without reading it again.
    const MeshFile* file = nullptr;
    std::vector<AnimationSpan>
        animations;  ///< Those that may bend the mesh, the file's first first.
};

/// The meshes of one detection (views: the caller or read_inputs owns them).
struct DetectInputs
{
    const TriangleMesh& original;
    /// Geometry of the original that is shown but not watermarked (other instances of
    /// instanced glTF meshes); registration matches the suspect against it too.
    const TriangleMesh& instances;
    const TriangleMesh& suspect;
    std::filesystem::path suspect_path;  ///< For messages.
    const AnimatedOriginal* animated = nullptr;
};

/// Where a detection's inputs come from: each one read from its file unless the caller holds it.
struct DetectSources
{
    const TriangleMesh* suspect = nullptr;  ///< Null: read from suspect_path.
    std::filesystem::path suspect_path = "suspect";
    const TriangleMesh* original =
        nullptr;  ///< Null: read from original_path (with its instances and animations).
    std::filesystem::path original_path = "original";
    const Key* key = nullptr;  ///< Null (and no mark): read from key_path.
    std::filesystem::path key_path;
    const SpectralWatermark* mark =
        nullptr;  ///< Built already from the original (detect_mesh): no key, no checks.
};

/// What read_inputs read (and holds for the detection's length).
struct ReadInputs
{
    std::optional<Key> key;
    /// The original's file: its mesh, other instances and animations; what posing it needs
    /// (MeshFile::layout) only when it has animations that may bend the mesh.
    MeshFile original;
    TriangleMesh suspect;
    AnimatedOriginal animated;
};

/// \brief The read stage: the key, the original and the suspect from their files (the meshes
/// side by side, phase "read"), the original checked against the key's fingerprint and the
/// basis' needs. Meshes the caller holds are not copied: \p read keeps what was read, and the
/// returned views point into it or at the caller's meshes. Errors in the order of a serial run:
/// the key, the original, its checks, then the suspect.
[[nodiscard]] DetectInputs read_inputs(const DetectSources& sources,
                                       const DetectFileOptions& options, PhaseTimer& timer,
                                       ReadInputs& read);

/// The key the detection uses: the caller's or the one read (null with a watermark given).
[[nodiscard]] const Key* key_of(const DetectSources& sources, const ReadInputs& read);

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "meshmark/pipeline/progress.h"

namespace meshmark
{

/// Options of attack_file.
struct AttackFileOptions
{
    std::uint64_t seed = 0;     ///< Seed of every random choice of the chain.
    int threads = 0;            ///< 0 = all cores (resolve_threads).
    bool force = false;         ///< Allow the output to replace the input file.
    ProgressCallback progress;  ///< Optional; phases "read", "attack", "write".
};

/// What attack_file did.
struct AttackFileReport
{
    std::string spec;  ///< The chain in canonical form (parse_attack_spec(spec) gives it back).
    std::uint64_t seed = 0;
    std::int64_t vertices_before = 0;
    std::int64_t faces_before = 0;
    std::int64_t vertices_after = 0;
    std::int64_t faces_after = 0;
    /// Every output vertex is an input vertex (see AttackResult::source_vertex).
    bool has_correspondence = false;
    /// The similarity applied (input -> output), when a step was one.
    std::optional<Eigen::Matrix4d> similarity;
    PhaseTimings seconds;  ///< Phases "read", "attack", "write".
};

/// \brief Apply the attack chain \p spec (the grammar of `meshmark attack --help`) to the mesh
/// file \p input and write the result to \p output (format from its extension, atomically).
/// \details The spec and the output's extension are checked before anything is read.
/// \throws InvalidOption for a bad spec or output name, or an output naming the input without
/// force; IoError; InvalidMesh (naming \p input) when an attack cannot work on the mesh.
AttackFileReport attack_file(const std::filesystem::path& input,
                             const std::filesystem::path& output, const std::string& spec,
                             const AttackFileOptions& options = {});

}  // namespace meshmark

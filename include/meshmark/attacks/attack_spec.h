// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "meshmark/attacks/attack_result.h"
#include "meshmark/attacks/cropping.h"
#include "meshmark/attacks/noise.h"
#include "meshmark/attacks/quantization.h"
#include "meshmark/attacks/remeshing.h"
#include "meshmark/attacks/reordering.h"
#include "meshmark/attacks/similarity.h"
#include "meshmark/attacks/simplification.h"
#include "meshmark/attacks/smoothing.h"
#include "meshmark/attacks/subdivision.h"
#include "meshmark/attacks/voxel_remeshing.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief One attack with its parameters: one alternative per attack of the suite.
/// \details Adding an attack means one header, one source, one alternative here and one test
/// file; parse_attack_spec(), to_string() and apply_attack() dispatch on the alternative.
using AttackSpec =
    std::variant<SimilarityOptions, NoiseOptions, LaplacianSmoothingOptions, TaubinSmoothingOptions,
                 QuantizationOptions, SimplificationOptions, RemeshingOptions, SubdivisionOptions,
                 CropOptions, ReorderOptions, VoxelRemeshingOptions>;

/// \brief Parse a chain of attacks written in the attack grammar.
/// \details
/// ```
/// SPEC := STEP[,STEP]...                     applied left to right
/// STEP := NAME[=LEVEL][:KEY=VALUE]...
/// ```
/// | NAME | LEVEL | KEYS |
/// |---|---|---|
/// | similarity | none (random) | explicit: axis=x\|y\|z or ax=,ay=,az= ; angle=DEG; scale=S;
/// tx=,ty=,tz= ; random: smax=S (scale in [1/S, S]), tmax=R (bbox radii) | | noise | amplitude,
/// fraction of the reference length | dist=uniform\|gaussian; dir=iso\|normal; ref=diag\|centroid |
/// | smooth | iterations | lambda=0.1 |
/// | taubin | iterations | lambda=0.5; mu=-0.53 |
/// | quantize | bits | |
/// | simplify | fraction of the vertices kept | policy=gh\|lt |
/// | remesh | target fraction of the vertices | iter=N (iterations per pass) |
/// | subdivide | loop\|midpoint\|sqrt3 | steps=N |
/// | crop | fraction of the vertices kept | axis=x\|y\|z or ax=,ay=,az= (normal of the cut, towards
/// the removed side) | | reorder | none | | | voxel | voxels along the bounding-box diagonal | |
///
/// A missing level takes the default of the options struct. Any explicit similarity key
/// selects the explicit transform (identity in what is not given); smax and tmax cannot be
/// mixed with explicit keys. Numbers are read with std::from_chars (locale-independent).
/// Example: `similarity,simplify=0.1:policy=lt,noise=0.001:dir=normal`.
/// \return The steps, in order; never empty.
/// \throws InvalidOption with a message naming the step and the problem: empty spec or step,
/// unknown attack, missing or malformed level or value, unknown or repeated key, value out of
/// range (from the options' validate()).
[[nodiscard]] std::vector<AttackSpec> parse_attack_spec(std::string_view text);

/// \brief Canonical text of one step: the name, the level, then the keys whose values differ
/// from the defaults. parse_attack_spec(to_string(spec)) gives back \p spec exactly (numbers
/// are written with the shortest digits that read back to the same double).
[[nodiscard]] std::string to_string(const AttackSpec& spec);

/// \brief Canonical text of a chain: the steps' to_string joined by commas.
[[nodiscard]] std::string to_string(const std::vector<AttackSpec>& specs);

/// \brief Name of the attack of a step ("noise", "simplify", ...), as in the grammar.
[[nodiscard]] std::string_view attack_name(const AttackSpec& spec);

/// \brief Apply one attack.
/// \details Validates the options, then calls the attack's function (apply_similarity,
/// add_noise, smooth_laplacian, smooth_taubin, quantize, simplify, remesh, subdivide, crop,
/// reorder or voxel_remesh) and fills the result's transform and correspondence as described in
/// AttackResult. \param rng      Random stream of this step; attacks without randomness do not draw
/// from it. \param threads  Worker threads for the parallel attacks (0 = all cores); the result
/// does
///                 not depend on it.
/// \throws InvalidOption for options out of range; InvalidMesh when the attack cannot work on
/// this mesh (e.g. smoothing or simplifying a point cloud).
[[nodiscard]] AttackResult apply_attack(const TriangleMesh& mesh, const AttackSpec& spec, Rng& rng,
                                        int threads = 0);

/// \brief Apply a chain of attacks, left to right.
/// \details Step k draws from its own stream, `Rng(derive_seed(seed, "attack/<k>/<name>"))`, so
/// a step's randomness does not depend on how much the steps before it drew. The result's
/// similarity is the composition of the similarity steps (empty if there is none) and its
/// correspondence is the composition of the steps' correspondences (empty if any step has
/// none).
/// \throws As apply_attack(), for the first step that fails.
[[nodiscard]] AttackResult apply_attacks(const TriangleMesh& mesh,
                                         const std::vector<AttackSpec>& specs, std::uint64_t seed,
                                         int threads = 0);

}  // namespace meshmark

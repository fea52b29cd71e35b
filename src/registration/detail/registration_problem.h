// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/registration.h"
#include "registration/detail/icp.h"
#include "registration/detail/surface_matcher.h"

/// What the stages of register_to_reference share: the suspect's samples, the reference's two
/// closest-point structures, the candidates and how they are scored. Mirrored candidates keep a
/// proper rotation and use mirrored samples (x -> -x) instead.
namespace meshmark::detail
{

// The coarse ICP may not leave [0.25, 2] times the initial scale (collapse guard), and neither
// may the fine stage's choice.
constexpr double kMinScaleFactor = 0.25;
constexpr double kMaxScaleFactor = 2.0;
// Distances below this fraction of a bounding-box diagonal count as an exact fit (rounding, not
// misfit): the floor of the overlap threshold and of the scores, so that exact copies tie.
constexpr double kExactFit = 1e-9;
// Two candidates whose poses lie within this fraction of the reference's diagonal of each other
// (RMS over the first sample tier) are one pose to a round's choice of survivors
// (distinct_poses_first). The repeats of the turned vehicle's pose (kTurnedCoarse) lay within
// 0.05% of each other; 2% merged, after the first round's 8 iterations, starts that would still
// have settled apart, and a half vehicle then lost its right pose to its mirror image
// (RegistrationTest.registers_a_half_cut_through_the_bounding_box_centre_along_an_axis).
constexpr double kSamePose = 0.005;

/// The suspect's point samples of every stage, by tier: the coarse rounds' three sizes,
/// then the fine and the final stage.
using SampleSets = std::array<Positions, 5>;
constexpr std::size_t kFineTier = 3;
constexpr std::size_t kFinalTier = 4;

/// One coarse hypothesis and how well it did so far.
struct Candidate
{
    Similarity transform;
    bool mirrored = false;
    double score = 0.0;     // score_of: the residual, raised where the overlap falls short
    double residual = 0.0;  // trimmed RMS divided by the scale: the residual in suspect units
    IcpOutcome outcome;
    bool kept_in_place = false;  // the identity of a suspect that stands in place: never dropped
};

/// Everything the stages share.
struct Problem
{
    const RegistrationOptions& options;
    std::array<SampleSets, 2> samples;  // [mirrored]
    std::unique_ptr<SurfaceMatcher> coarse_target;
    std::unique_ptr<SurfaceMatcher> fine_target;
    double reference_diagonal = 1.0;
    double initial_scale = 1.0;
    double score_floor = 0.0;  // scores below this (suspect units) count as exact fits
    // Half turns about the reference's principal axes through its centroid (kTurnedCoarse);
    // empty where the starts are given (point pairs, a start to refine).
    std::vector<Similarity> reference_turns;
};

/// The reflection used for mirrored candidates: x -> -x.
[[nodiscard]] Eigen::Matrix3d mirror_matrix();

/// \p T as a 4x4 map of the suspect's frame, the samples' mirror (x -> -x) applied first when
/// \p mirrored.
[[nodiscard]] Eigen::Matrix4d as_matrix(const Similarity& T, bool mirrored);

/// The residual of a run in suspect units: its trimmed RMS over its scale.
[[nodiscard]] double residual_of(const IcpOutcome& outcome);

/// A candidate's score: its residual (at least \p floor), raised where its overlap falls short.
[[nodiscard]] double score_of(const IcpOutcome& outcome, double floor);

/// RMS distance between where two similarities put the points \p X.
[[nodiscard]] double pose_distance(const Positions& X, const Similarity& a, const Similarity& b);

/// Keep the best \p count candidates; ties broken by the original order (deterministic).
void keep_best(std::vector<Candidate>& candidates, std::size_t count);

/// For each candidate, the first earlier one with the same start (the same handedness and
/// transform, bit for bit), or itself: a run of ICP is a function of its start (and its
/// samples, which the handedness picks), so a repeated start's outcome is copied instead of
/// computed again.
[[nodiscard]] std::vector<std::size_t> first_same_start(const std::vector<Candidate>& candidates);

/// The outcome of \p from's run given to \p to (same start): everything but its own flags.
void copy_run(const Candidate& from, Candidate& to);

/// The settings of a coarse (point-to-point, scale-clamped around \p scale_hint) ICP run.
[[nodiscard]] IcpSettings coarse_settings(const Problem& p, int iterations, double scale_hint,
                                          int threads);

/// The settings of a fine ICP run.
[[nodiscard]] IcpSettings fine_settings(const Problem& p, int iterations);

/// The rows of \p mesh used by its faces (all of them for a point cloud), validated.
/// \throws InvalidMesh as register_to_reference documents, naming \p what.
[[nodiscard]] std::vector<std::int32_t> usable_vertices(const TriangleMesh& mesh, const char* what);

/// The samples of both sides and the reference's closest-point structures. The fine stage's
/// target is left out when \p build_fine_target is false (the caller builds it).
[[nodiscard]] Problem make_problem(const TriangleMesh& suspect, const TriangleMesh& reference,
                                   const std::vector<std::int32_t>& suspect_rows,
                                   const std::vector<std::int32_t>& reference_rows,
                                   const RegistrationOptions& options,
                                   bool build_fine_target = true);

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/registration/point_pairs.h"  // PointPair: register_to_reference's pairs
#include "meshmark/registration/surface_matcher.h"

namespace meshmark
{

/// Parameters of register_to_reference. The defaults are the measured choices of
/// docs/algorithms/registration.md; the CLI and the pipeline take them from here.
struct RegistrationOptions
{
    bool allow_reflection = true;  ///< Also try mirrored candidates (det = -1).
    /// Fraction of ICP pairs kept at each iteration: the closest ones (trimmed ICP).
    double trim_keep = 0.9;
    int coarse_samples = 64;       ///< Suspect points per candidate in the first coarse round
                                   ///< (twice as many in the second).
    int refine_samples = 1024;     ///< Suspect points in the last coarse round.
    int fine_samples = 4096;       ///< Suspect points of the fine (point-to-plane) stage.
    int final_samples = 32768;     ///< Suspect points of the last few fine iterations.
    int reference_samples = 4096;  ///< Reference points of the coarse stage's kd-tree.
    int max_iterations = 40;       ///< Fine-stage iteration limit.
    /// Fine-stage stopping tolerance on the relative size of one update (rotation angle in
    /// radians, relative scale change, translation over the sample radius).
    double tolerance = 1e-10;
    /// Smallest overlap_fraction for which a result counts as converged.
    double min_overlap = 0.5;
    /// Largest rms_error (relative to the reference bbox diagonal) of a converged result.
    double max_rms_rel = 0.05;
    std::uint64_t seed = 0x5245474953544552ULL;  ///< Seed of the deterministic subsampling.
    int threads = 0;                             ///< 0 = all cores.
    /// Return the fine stage's closest-point structure over the reference
    /// (RegistrationResult::reference_surface) instead of dropping it, for a caller that queries
    /// the reference's surface next (detection's symmetry search). It holds a copy of the
    /// reference, its face normals, its vertex-to-face rings and a kd-tree: about 150 MB of arrays
    /// for a 1M-vertex reference.
    bool keep_reference_surface = false;

    /// \throws InvalidOption naming the field, its value and the allowed range.
    void validate() const;
};

/// Outcome of a registration. Not converging is a value, not an exception.
struct RegistrationResult
{
    /// Suspect -> reference frame: `x_ref = transform * [x_suspect; 1]`; the upper 3×3 block is
    /// `scale * R` with R orthogonal (det(R) = -1 for a mirrored copy).
    Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
    double scale = 1.0;          ///< Uniform scale factor inside `transform`.
    bool is_reflection = false;  ///< The suspect is a mirrored copy (det of the 3×3 block < 0).
    /// RMS distance of the kept (trimmed) suspect samples to the reference surface, relative
    /// to the reference's bounding-box diagonal.
    double rms_error = 0.0;
    int iterations = 0;      ///< ICP iterations of every stage, summed.
    bool converged = false;  ///< Final stage met its tolerance and the result is plausible.
    /// Fraction of the final suspect samples lying on the reference (closer than three times
    /// the trimmed RMS distance): near 1 for cropped copies too, low for a wrong alignment.
    double overlap_fraction = 0.0;
    int candidates = 0;  ///< Coarse starting transforms that were tried.
    /// The best fit of the other handedness (unmirrored when `transform` is mirrored, and the
    /// reverse), given when it fitted nearly as well as the chosen one (within 1.5 times its
    /// score): a nearly mirror-symmetric reference fits a copy about as well both ways, and the
    /// choice between them is then no evidence of which is right. Empty otherwise.
    std::optional<Eigen::Matrix4d> other_handedness;
    /// The fine stage's closest points on the reference's surface, when
    /// RegistrationOptions::keep_reference_surface asked for it; null otherwise.
    std::shared_ptr<const SurfaceMatcher> reference_surface;
};

/// \brief Bring a suspect copy into the reference's frame with a similarity transform.
/// \details Fully automatic [Wu & Kobbelt 2005 asked the user for point pairs instead]:
/// (1) coarse alignment: principal axes of the area-weighted surfaces (vertex moments when
/// either side is a point cloud) matched by every signed permutation of the axes (24
/// rotations, and 24 reflections when allowed), plus the axes of the parts of the reference
/// that a plane crop could have left (crop hypotheses), pruned by a tournament of short
/// trimmed point-to-point ICP runs with uniform scale [Umeyama 1991] on growing subsamples;
/// (2) trimmed point-to-plane ICP with scale against the reference surface for the best
/// candidates (each sample projected onto the triangles around its nearest reference vertex),
/// last iterations on many points. Samples flow suspect -> reference, so a
/// cropped suspect still lies entirely on the reference. Subsampling is seeded and
/// reductions run in a fixed order: the result is bit-identical for any thread count.
/// See docs/algorithms/registration.md for the measured choices and the failure modes
/// (mirror-symmetric shapes register as unmirrored; rotational symmetry needs point pairs).
/// \param suspect    Mesh, triangle soup or point cloud (no faces).
/// \param reference  The mesh the suspect is a copy of: for detection, the original (the
///                   unwatermarked mesh the key was made from, with its other instances when
///                   the file has some), never the watermarked mesh.
/// \throws InvalidMesh if either has non-finite coordinates or out-of-range indices, fewer
/// than 4 vertices used by its faces (4 vertices for a point cloud), or all its points at one
/// place; InvalidOption from options.validate().
[[nodiscard]] RegistrationResult register_to_reference(const TriangleMesh& suspect,
                                                       const TriangleMesh& reference,
                                                       const RegistrationOptions& options = {});

/// \brief Same, started from user point pairs instead of the automatic coarse stage.
/// \details The pairs give a similarity (Umeyama); when reflections are allowed the mirrored
/// fit is tried as well (three pairs cannot tell a copy from its mirror image) and ICP decides.
/// \throws InvalidMesh as above (except the zero-extent case, which the pairs make moot);
/// InvalidOption from options.validate(), or if fewer than 3 pairs are given or their suspect
/// points are (nearly) collinear or coincident.
[[nodiscard]] RegistrationResult register_to_reference(const TriangleMesh& suspect,
                                                       const TriangleMesh& reference,
                                                       std::span<const PointPair> pairs,
                                                       const RegistrationOptions& options = {});

/// \brief Same, started from a known transform instead of the coarse stage.
/// \details For a suspect whose pose is known roughly: the reference is one of several
/// near-alike ones (the frames of an animation) and the suspect was registered onto another.
/// The last coarse round and the fine stage run from \p start (suspect -> reference; a mirrored
/// one stays mirrored), which costs a small part of a full registration.
/// \throws InvalidMesh as above; InvalidOption from options.validate() or when the linear
/// part of \p start is not a similarity.
[[nodiscard]] RegistrationResult register_from(const TriangleMesh& suspect,
                                               const TriangleMesh& reference,
                                               const Eigen::Matrix4d& start,
                                               const RegistrationOptions& options = {});

/// \brief The shape's spread along its principal axes: the eigenvalues of the area-weighted
/// second moments of its surface (vertex moments for a point cloud), smallest first, as shares
/// of their sum.
/// \details Unchanged by any similarity and by the triangulation, changed by a pose that moves
/// parts against each other: detection compares a copy with the frames of an animation by it
/// before registering onto the closest ones.
/// \throws InvalidMesh when the mesh has no area (or, as a point cloud, no extent).
[[nodiscard]] Eigen::Vector3d principal_spread(const TriangleMesh& mesh);

/// \brief Apply a 4×4 affine transform to every row of \p V.
[[nodiscard]] Positions transform_points(const Eigen::Matrix4d& transform, const Positions& V);

}  // namespace meshmark

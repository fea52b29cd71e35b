// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <string>

#include <Eigen/Core>

#include "meshmark/pipeline/correspondence.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/registration/point_pairs.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// Options of detect_file.
struct DetectFileOptions
{
    DetectOptions decision;  ///< Verdict rule and its parameters.
    int threads = 0;         ///< 0 = all cores (resolve_threads).
    /// Register and resample suspects whose vertices do not correspond to the original's
    /// (docs/algorithms/detection.md, "General suspects"). False: such suspects are refused.
    bool allow_registration = true;
    std::vector<PointPair> pairs;  ///< Optional user point pairs (suspect, original) to start from.
    ProgressCallback progress;     ///< Optional.
    /// Family keys: score every recipient and accuse (docs/fingerprinting.md). False: the
    /// owner's mark alone decides, as with a single-owner key.
    bool trace = true;
    /// Resampled suspects: measure each row against the original's surface laid under the
    /// suspect's own triangles (match_reference_surface), which removes a coarse copy's chord
    /// error. False: against the original's vertex, as before 2026-11-26 (an ablation).
    bool match_surface = true;
    /// Registered suspects whose vertices are the original's again (reordered, split at seams,
    /// welded, or with vertices added between them) are read vertex for vertex, every
    /// component of the change (vertices_in_place, registration/vertex_matching.h). False:
    /// resampled like any other registered suspect, as before 2026-11-26 (an ablation).
    bool match_vertices = true;
    /// Resampled suspects whose edges look voxel-remeshed: the original is voxel-remeshed at the
    /// suspect's voxel size and its change is fitted beside the mark (predict_voxel_change,
    /// docs/algorithms/detection.md, "Voxel-remeshed suspects"). False: read as before
    /// 2026-12-01 (an ablation).
    bool predict_voxel = true;
};

/// What detect_file found.
struct DetectReport
{
    Decision decision;
    Extraction extraction;  ///< What was read (per coefficient and per bit), for diagnosis.
    double cropped_fraction = 0.0;
    /// Fraction of the original's rows left out of the reading because the suspect is far from
    /// them (beyond 3 x the median distance and 10 x the strength), crops aside: a resampled
    /// suspect's surface, or a vertex-for-vertex suspect's own vertices.
    double outlier_fraction = 0.0;
    /// How the suspect was put in correspondence with the original (of the reading kept); its
    /// words for people and files: registration_method().
    Correspondence correspondence = Correspondence::None;
    /// Correspondence::AnimationFrame: the frame of the original's animations read through
    /// ("animation 'Run' at 10/24 s"); empty otherwise.
    std::string pose;
    /// A resampled suspect read beside the original voxel-remeshed (DetectFileOptions::
    /// predict_voxel): the voxels along the original's diagonal of that remesh; 0 otherwise.
    double voxel_resolution = 0.0;
    Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  ///< Suspect -> original frame.
    double registration_rms = 0.0;  ///< RMS distance to the original / its bbox diagonal.
    /// The mark's RMS amplitude / the original's bbox diagonal: the key's additive strength (the
    /// default mark's for the paper's rule). registration_rms over it says how many times further
    /// than the mark a registered suspect lies from the original
    /// (bench/results/2026-11-26-what-an-attack-leaves.md).
    double mark_strength = 0.0;
    /// A registered suspect this many times further from the original (registration_rms) than
    /// the mark's strength is past what marked copies mostly survive: of 195 marked copies at 3x
    /// or more in four robustness runs, 35 were claimed (subdivisions, which shrink the surface
    /// but keep the mark; some 1/150 voxel remeshes and Lindstrom-Turk simplifications); of the
    /// 218 copies not claimed, 160 were that far
    /// (bench/results/2026-11-26-what-an-attack-leaves.md).
    static constexpr double kFarCopyStrengths = 3.0;
    std::int64_t suspect_vertices = 0;
    std::int64_t original_vertices = 0;
    PhaseTimings seconds;
    /// Family keys traced: the recipients scored (all of the key's), else 0.
    std::size_t recipients_traced = 0;
    /// The accused recipients (RecipientScore::is_accused), strongest first: the smallest
    /// false-positive probability first, then the larger score.
    std::vector<RecipientScore> accused;
    /// Every recipient traced, in the key's order (for diagnosis and null studies).
    std::vector<RecipientScore> traced;
    /// Whether the owner's claim holds. Single-owner key: decision.is_present. Family key
    /// traced: the owner's mark alone or read jointly with some recipient's code
    /// (RecipientScore::joint_score), the two sharing the level half and half
    /// (docs/fingerprinting.md); it can hold when nobody is accused.
    bool owner_detected = false;
    /// Its bound: decision.false_positive_probability for a single-owner key; with a family
    /// key traced, min(1, 2 decision.false_positive_probability, 2 min_j
    /// joint_false_positive_probability_j).
    double owner_false_positive_probability = 1.0;
    /// The verdict (verdict.h): whether the copy is claimed. With recipients traced, when
    /// ownership is shown (owner_detected) or anyone is accused; otherwise whether the mark is
    /// present (decision.is_present, which for a family key is the owner's mark).
    [[nodiscard]] bool detected() const noexcept
    {
        return recipients_traced > 0 ? !accused.empty() || owner_detected : decision.is_present;
    }
    /// The suspect was registered onto the original (is_registered(correspondence)): its
    /// vertices are not the original's in its order.
    [[nodiscard]] bool registered() const noexcept { return is_registered(correspondence); }
    /// `detect --json`'s registration.method: correspondence_method(correspondence, pose).
    [[nodiscard]] std::string registration_method() const
    {
        return correspondence_method(correspondence, pose);
    }
    /// Whether the suspect was registered and lies kFarCopyStrengths times the mark's strength
    /// or more from the original: why a "not found" there says little (meshmark detect's note).
    [[nodiscard]] bool is_far_copy() const noexcept
    {
        return registered() && mark_strength > 0.0 &&
               registration_rms >= kFarCopyStrengths * mark_strength;
    }
};

/// \brief Look for the watermark of \p key in \p suspect (docs/algorithms/detection.md).
/// \details Reads the key and the original, checks the original against the key's
/// fingerprint, regenerates the watermark, puts the suspect in vertex correspondence with it,
/// extracts the bits and decides. A suspect with the original's vertex count is taken vertex
/// for vertex (after a closed-form similarity); unless allow_registration is off, anything else is
/// registered onto the original and resampled at its vertices, with cropped
/// vertices left out (least squares).
/// "Not found" is a result, not an error. detect (meshmark.h) is the same without the files.
/// \throws IoError for an unreadable key or mesh and when the original is not the one the key
/// was made for (its vertex and face counts or its position hash differ from the key's
/// fingerprint); InvalidMesh for a malformed mesh or an original the key's basis cannot use;
/// InvalidOption for bad options or, with allow_registration off, a suspect that does not
/// correspond to the original; NumericalError.
DetectReport detect_file(const std::filesystem::path& suspect,
                         const std::filesystem::path& original,
                         const std::filesystem::path& key_path, const DetectFileOptions& options);

/// \brief detect_file with the suspect in memory (the mesh an editor holds): the original and
/// the key are read from their files, so the original's other instances and animation are used
/// as detect_file uses them (the Blender add-on's Detect). Same steps, results and errors.
DetectReport detect_against_file(const TriangleMesh& suspect, const std::filesystem::path& original,
                                 const std::filesystem::path& key_path,
                                 const DetectFileOptions& options);

/// \brief detect_against_file with the key in memory too (a catalogue's record): same steps,
/// results and errors.
DetectReport detect_against_original(const TriangleMesh& suspect,
                                     const std::filesystem::path& original, const Key& key,
                                     const DetectFileOptions& options);

/// \brief detect_file for meshes in memory and a watermark already built from \p original
/// (which must be the mesh \p mark was made from): many suspects against one key pay for the
/// basis once (the robustness benchmark). Same steps, results and errors as detect_file.
DetectReport detect_mesh(const SpectralWatermark& mark, const TriangleMesh& original,
                         const TriangleMesh& suspect, const DetectFileOptions& options);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// `meshmark bench robustness`, shared by its two files: the run (bench_robustness.cpp) and its
// reports (bench_robustness_report.cpp: the trials as JSON, the Markdown tables, --from-json).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "meshmark/watermark/watermark.h"

namespace meshmark::cli::robustness
{

// The attack suite at the levels of issue 4's targets (and a few more), in the grammar of
// `meshmark attack`.
inline const std::vector<std::string> kDefaultAttacks = {
    "similarity",
    "reorder",
    "noise=0.001",
    "noise=0.005",
    "noise=0.01",
    "quantize=10",
    "quantize=8",
    "smooth=5",
    "smooth=10",
    "smooth=30",
    "smooth=50",
    "taubin=20",
    "simplify=0.1",
    "simplify=0.02",
    "remesh=0.25",
    "remesh=0.05",
    "subdivide=loop",
    "subdivide=sqrt3",
    "crop=0.7",
    "crop=0.5",
    "similarity,simplify=0.1,noise=0.001",
    // Surface refitting (issue 16): voxel remeshing at 1/300 and 1/150 of the diagonal.
    "voxel=300",
    "voxel=150",
};

/// The options of `bench robustness`.
struct RobustnessArgs
{
    std::string mesh_dir;
    std::vector<std::string> meshes;
    int keys = 10;
    int wrong_keys = 5;
    int unmarked_keys = 3;
    std::int64_t max_vertices = 200'000;
    std::vector<std::string> attacks = kDefaultAttacks;
    std::uint64_t seed = 1;
    double strength = -1.0;
    std::string strength_measure = "surface";
    int coefficients = EmbedOptions{}.coefficients;
    int repetitions = EmbedOptions{}.repetitions;
    int first_mode = EmbedOptions{}.first_mode;
    int basis_size = EmbedOptions{}.basis_size;
    std::string rule = "additive";
    std::string basis = "rbf";
    std::string centers = "random";
    std::int64_t gram_rows = EmbedOptions::kDefaultGramRows;
    std::string markdown;
    std::string json_path;
    std::vector<std::string> from_json;
    bool plain_resampling = false;     // ablation: DetectFileOptions::match_surface off
    bool no_voxel_prediction = false;  // ablation: DetectFileOptions::predict_voxel off
    bool json = false;
    int recipients = 0;  // > 0: family keys with this many recipients (docs/fingerprinting.md)
    int colluders =
        1;  // family keys: the marked copy averages the copies of recipients 0 .. colluders-1
};

/// One suspect detected with one key.
struct Trial
{
    std::string mesh;
    int key = 0;
    std::string attack;
    std::string kind;  // "marked", "unmarked" or "wrong-key"
    Decision decision;
    double cropped_fraction = 0.0;
    double outlier_fraction = 0.0;  // rows left out for being far from the suspect
    double registration_rms = 0.0;  // fraction of the original's diagonal
    std::string alignment;          // how the suspect was put in correspondence
    double seconds = 0.0;
    std::string error;
    // Family keys (--recipients): the suspect traced against the key's recipients; the marked
    // copies are recipient 0's.
    std::size_t recipients_traced = 0;
    bool recipient_accused = false;  // a colluder (recipient 0 .. colluders-1) accused
    int others_accused = 0;          // innocent recipients accused (never, for a sound bound)
    double recipient_score = 0.0;    // the best colluder's z
    bool owner_detected = false;     // the owner's claim: its mark alone or jointly with a code
};

/// The distortion of one mesh's marked copies, averaged over its keys.
struct MeshEmbedding
{
    std::string mesh;
    std::int64_t vertices = 0;
    int keys = 0;
    double mrms = 0.0;       // mean over keys, fraction of the diagonal
    double hausdorff = 0.0;  // mean over keys
    double rms_displacement = 0.0;
    double embed_seconds = 0.0;
    int repetitions = 0;  // r of the mesh's keys (resolved when the run asked for auto)
};

/// One trial as a JSON object of the trials file.
[[nodiscard]] nlohmann::json to_json(const Trial& t);

/// The Markdown tables of docs/robustness.md: per attack, the marked, wrong-key and unmarked
/// trials.
[[nodiscard]] std::string markdown_report(const std::vector<MeshEmbedding>& embeddings,
                                          const std::vector<Trial>& trials,
                                          const std::vector<std::string>& attacks,
                                          const RobustnessArgs& args,
                                          const DetectOptions& decision);

/// Writes the trials so far (and the finished meshes' distortion) to --json-file.
void write_trials_json(const RobustnessArgs& args, const std::vector<MeshEmbedding>& embeddings,
                       const std::vector<Trial>& trials);

/// --from-json: tables from the trials of earlier runs (one per mesh, say), which must share
/// their settings; nothing is embedded or detected. Returns the exit code.
int report_from_json(const RobustnessArgs& args);

}  // namespace meshmark::cli::robustness

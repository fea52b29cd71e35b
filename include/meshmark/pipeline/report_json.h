// SPDX-License-Identifier: MIT
#pragma once

/// \file
/// \brief The JSON reports of the `meshmark` commands (`--json`), built in one place so that the
/// program and the Python package (python/) print and return the same fields.

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/attack_file.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/pipeline/progress.h"

namespace meshmark
{

/// Phase timings as a JSON object {"read": 0.1, ..., "total": 0.5}.
[[nodiscard]] nlohmann::json to_json(const PhaseTimings& timings);

/// A 4x4 matrix as four rows of four numbers.
[[nodiscard]] nlohmann::json matrix_json(const Eigen::Matrix4d& matrix);

/// \brief What an embed made, without the files: the key's parameters, the payload bits and the
/// distortion (`analysed_vertices`, `rule`, `strength`, `basis`, ..., `weak_bits`).
[[nodiscard]] nlohmann::json embed_stats_json(const Key& key, const EmbedStats& stats);

/// \brief `meshmark embed --recipient ... --json`: the family's parameters, then one entry
/// per copy written (name, index, output, new, rms_displacement, max_displacement).
[[nodiscard]] nlohmann::json embed_recipients_report_json(const EmbedRecipientsReport& report,
                                                          const std::string& input,
                                                          const std::string& key);

/// \brief `meshmark embed --json`: embed_stats_json plus the file names as given, the counts,
/// `streamed` and `seconds`; where the coordinates' unit is known (the file's or `--unit`),
/// `in_unit`: {`unit` ("mm", ...), `source` ("file" or "option"), `bbox_diagonal`,
/// `max_displacement`, `rms_displacement`, `surface_rms_displacement`} in that unit; with a cap,
/// `max_displacement_cap`: {`cap`, `unit` (when known), `rounding_margin`,
/// `uncapped_max_displacement`, `strength_factor`, `written_max_displacement` (read back; null
/// when not measured), `intact_score` (z of the undamaged float32 copy; null when the cap did
/// not bind)}, lengths in the coordinates' unit.
[[nodiscard]] nlohmann::json embed_report_json(const EmbedReport& report, const std::string& input,
                                               const std::string& output, const std::string& key);

/// \brief `meshmark detect --json`: the decision, registration and counts of \p report under
/// \p options (its threshold and bound are echoed). \p diagnostics adds what was read per
/// coefficient and bit (`normalized_change`, `coefficient_weights`, `bit_values`; `--verbose`).
[[nodiscard]] nlohmann::json detect_report_json(const DetectReport& report,
                                                const DetectOptions& options,
                                                bool diagnostics = false);

/// `meshmark attack --json`.
[[nodiscard]] nlohmann::json attack_report_json(const AttackFileReport& report,
                                                const std::string& input,
                                                const std::string& output);

/// \brief `meshmark compare --json`'s `in_unit` object: the distances of \p r in \p unit, A's
/// coordinates' unit (`unit`, `source` "file" or "option", `bbox_diagonal`, `hausdorff`,
/// `hausdorff_ab`, `hausdorff_ba`, `rms_ab`, `rms_ba`, `mrms`, `mean_ab`, `mean_ba`, and with the
/// same connectivity `max_displacement`, `rms_displacement`).
[[nodiscard]] nlohmann::json compare_in_unit_json(const DistortionReport& r, LengthUnit unit,
                                                  bool is_from_file);

/// \brief `meshmark compare --json` without `seconds` and `heatmap`: the distances of \p report
/// (A = \p a read from \p a_path, B likewise), the counts and the sampling \p seed.
[[nodiscard]] nlohmann::json compare_report_json(const std::string& a_path,
                                                 const std::string& b_path, const TriangleMesh& a,
                                                 const TriangleMesh& b,
                                                 const DistortionReport& report,
                                                 std::uint64_t seed);

/// The seconds of a `compare` run besides those of its report (reading, the heatmap, in all).
struct CompareRunSeconds
{
    double read = 0.0;
    double heatmap = 0.0;
    double total = 0.0;
};

/// \brief Completes compare_report_json as `meshmark compare --json` prints it (the CLI's and the
/// Python package's `compare`): `in_unit` when \p unit is known (\p unit_from_file: read from A's
/// file), `heatmap` when \p heatmap names the picture written (\p heatmap_max its largest
/// distance), and `seconds`.
void complete_compare_json(nlohmann::json& out, const DistortionReport& report,
                           const std::optional<LengthUnit>& unit, bool unit_from_file,
                           const std::string& heatmap, double heatmap_max,
                           const CompareRunSeconds& seconds);

/// \brief An argument as the shell reads it back: quoted unless made of safe characters only
/// (the command an evidence report gives to repeat a check).
[[nodiscard]] std::string shell_word(const std::string& word);

/// The shortest text that reads back as \p value ("1e-06", "0.5").
[[nodiscard]] std::string shortest(double value);

/// \brief The `meshmark detect ... --json` command that repeats a check of \p suspect against
/// \p original with the key file \p key under \p options (the options that differ from their
/// defaults; \p pairs: the point-pair file, empty when none): what `detect --report` states.
[[nodiscard]] std::string detect_command(const std::string& suspect, const std::string& original,
                                         const std::string& key, const std::string& pairs,
                                         const DetectFileOptions& options);

}  // namespace meshmark

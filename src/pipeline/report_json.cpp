// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/report_json.h"

#include <array>
#include <charconv>

#include "meshmark/pipeline/verdict.h"

namespace meshmark
{
namespace
{

nlohmann::json mesh_json(const std::string& path, const TriangleMesh& mesh,
                         const OneSidedDistance& side)
{
    return {{"file", path},
            {"vertices", mesh.vertex_count()},
            {"faces", mesh.face_count()},
            {"vertex_samples", side.vertex_samples},
            {"area_samples", side.area_samples}};
}

}  // namespace

nlohmann::json to_json(const PhaseTimings& timings)
{
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [name, seconds] : timings.phases)
    {
        // A phase that ran more than once (a symmetric original's poses each register, match
        // and read) reports its whole time.
        object[name] = object.value(name, 0.0) + seconds;
    }
    object["total"] = timings.total;
    return object;
}

nlohmann::json matrix_json(const Eigen::Matrix4d& matrix)
{
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < 4; ++r)
    {
        rows.push_back({matrix(r, 0), matrix(r, 1), matrix(r, 2), matrix(r, 3)});
    }
    return rows;
}

nlohmann::json embed_stats_json(const Key& key, const EmbedStats& stats)
{
    nlohmann::json out = {{"analysed_vertices", stats.analysed_vertices},
                          {"rule", to_string(key.options.rule)},
                          {"strength", key.options.strength},
                          {"strength_measure", to_string(key.options.measure)},
                          {"basis", to_string(key.options.basis)},
                          {"centers", to_string(key.options.centers)},
                          {"basis_size", key.options.basis_size},
                          {"coefficients", key.options.coefficients},
                          {"repetitions", key.options.repetitions},
                          {"first_mode", key.options.first_mode},
                          {"bits", to_bit_string(key.payload)},
                          {"max_displacement", stats.max_displacement_rel},
                          {"rms_displacement", stats.rms_displacement_rel},
                          {"surface_rms_displacement", stats.surface_rms_rel},
                          {"orthogonality_error", stats.orthogonality_error},
                          {"weak_bits", stats.weak_bits},
                          {"basis_span", stats.basis_span},
                          {"shortened_to_span", stats.shortened_to_span}};
    if (key.options.rule != EmbeddingRule::Additive)
    {
        out.erase("strength_measure");  // rho is not a distance
    }
    return out;
}

nlohmann::json embed_recipients_report_json(const EmbedRecipientsReport& report,
                                            const std::string& input, const std::string& key)
{
    nlohmann::json copies = nlohmann::json::array();
    for (const IssuedCopy& copy : report.copies)
    {
        copies.push_back({{"name", copy.name},
                          {"index", copy.index},
                          {"output", copy.path.string()},
                          {"new", copy.is_new},
                          {"rms_displacement", copy.stats.rms_displacement_rel},
                          {"surface_rms_displacement", copy.stats.surface_rms_rel},
                          {"max_displacement", copy.stats.max_displacement_rel}});
    }
    nlohmann::json out = embed_stats_json(report.key, report.copies.front().stats);
    out.erase("max_displacement");
    out.erase("rms_displacement");
    out.erase("surface_rms_displacement");
    out["input"] = input;
    out["key"] = key;
    out["key_created"] = report.key_created;
    out["recipient_modes"] = report.key.recipients->modes;
    out["recipient_share"] = report.key.recipients->energy_share;
    out["recipients_in_key"] = report.key.recipients->recipients.size();
    out["copies"] = std::move(copies);
    out["vertices"] = report.vertex_count;
    out["faces"] = report.face_count;
    out["seconds"] = to_json(report.seconds);
    return out;
}

nlohmann::json embed_report_json(const EmbedReport& report, const std::string& input,
                                 const std::string& output, const std::string& key)
{
    nlohmann::json out = embed_stats_json(report.key, report.stats);
    out["input"] = input;
    out["output"] = output;
    out["key"] = key;
    out["vertices"] = report.vertex_count;
    out["faces"] = report.face_count;
    out["streamed"] = report.streamed;
    out["seconds"] = to_json(report.seconds);
    if (report.unit)
    {
        // The distortion again in the coordinates' unit (the fields above stay fractions of the
        // diagonal).
        const double d = report.diagonal;
        out["in_unit"] = {{"unit", to_string(*report.unit)},
                          {"source", report.is_unit_from_file ? "file" : "option"},
                          {"bbox_diagonal", d},
                          {"max_displacement", report.stats.max_displacement_rel * d},
                          {"rms_displacement", report.stats.rms_displacement_rel * d},
                          {"surface_rms_displacement", report.stats.surface_rms_rel * d}};
    }
    if (report.cap.cap > 0.0)
    {
        nlohmann::json cap = {{"cap", report.cap.cap},
                              {"rounding_margin", report.cap.rounding_margin},
                              {"uncapped_max_displacement", report.cap.uncapped_max},
                              {"strength_factor", report.cap.factor},
                              {"written_max_displacement", nullptr},
                              {"intact_score", nullptr}};
        if (report.unit)
        {
            cap["unit"] = to_string(*report.unit);
        }
        if (report.written_max_displacement >= 0.0)
        {
            cap["written_max_displacement"] = report.written_max_displacement;
        }
        if (report.cap.factor < 1.0)
        {
            cap["intact_score"] = report.cap.intact_score;
        }
        out["max_displacement_cap"] = std::move(cap);
    }
    return out;
}

nlohmann::json detect_report_json(const DetectReport& report, const DetectOptions& options,
                                  bool diagnostics)
{
    const Decision& d = report.decision;
    const Verdict verdict = verdict_of(report, options.max_false_positive);
    // The verdict first (detected, headline, false_positive_probability, recipients); the
    // owner's mark read alone as details (owner_mark; also the top-level correlation, bits and
    // score, as before).
    nlohmann::json out = {{"detected", verdict.claimed},
                          {"headline", headline(verdict)},
                          {"owner_mark",
                           {{"detected", d.is_present},
                            {"score", d.score},
                            {"false_positive_probability", d.false_positive_probability},
                            {"correlation", d.correlation},
                            {"matches", d.matches},
                            {"bit_count", d.bit_count}}},
                          {"correlation", d.correlation},
                          {"matches", d.matches},
                          {"bit_count", d.bit_count},
                          {"threshold", options.threshold},
                          {"verdict", to_string(d.verdict)},
                          {"score", d.score},
                          {"coefficient_count", d.coefficient_count},
                          {"max_false_positive_probability", options.max_false_positive},
                          {"bits_expected", d.bits_expected},
                          {"bits_found", d.bits_found},
                          {"false_positive_probability", verdict.false_positive_probability},
                          {"score_false_positive_probability", d.score_false_positive_probability},
                          {"bits_false_positive_probability", d.bits_false_positive_probability},
                          {"cropped_fraction", report.cropped_fraction},
                          {"outlier_fraction", report.outlier_fraction},
                          {"registration",
                           {{"method", report.registration_method()},
                            {"rms_error", report.registration_rms},
                            {"transform", matrix_json(report.transform)}}},
                          {"voxel_resolution", report.voxel_resolution},
                          {"mark_strength", report.mark_strength},
                          {"suspect_vertices", report.suspect_vertices},
                          {"original_vertices", report.original_vertices},
                          {"seconds", to_json(report.seconds)}};
    if (report.recipients_traced > 0)
    {
        nlohmann::json accused = nlohmann::json::array();
        for (const RecipientScore& r : report.accused)
        {
            accused.push_back({{"name", r.name},
                               {"score", r.score},
                               {"false_positive_probability", r.false_positive_probability}});
        }
        out["recipients"] = std::move(accused);
        out["recipients_traced"] = report.recipients_traced;
        out["owner_detected"] = report.owner_detected;
        out["owner_false_positive_probability"] = report.owner_false_positive_probability;
    }
    if (diagnostics)
    {
        out["normalized_change"] = report.extraction.normalized_change;
        out["coefficient_weights"] = report.extraction.weights;
        out["bit_values"] = report.extraction.bit_values;
        if (report.recipients_traced > 0)
        {
            // Every recipient's score, in the key's order: what a null study needs.
            nlohmann::json scores = nlohmann::json::array();
            for (const RecipientScore& r : report.traced)
            {
                scores.push_back(
                    {{"name", r.name}, {"score", r.score}, {"region_score", r.region_score}});
            }
            out["recipient_scores"] = std::move(scores);
        }
    }
    return out;
}

nlohmann::json attack_report_json(const AttackFileReport& report, const std::string& input,
                                  const std::string& output)
{
    return {{"input", input},
            {"output", output},
            {"spec", report.spec},
            {"seed", report.seed},
            {"vertices_before", report.vertices_before},
            {"faces_before", report.faces_before},
            {"vertices_after", report.vertices_after},
            {"faces_after", report.faces_after},
            {"has_correspondence", report.has_correspondence},
            {"transform",
             report.similarity ? matrix_json(*report.similarity) : nlohmann::json(nullptr)},
            {"seconds", to_json(report.seconds)}};
}

void complete_compare_json(nlohmann::json& out, const DistortionReport& report,
                           const std::optional<LengthUnit>& unit, bool unit_from_file,
                           const std::string& heatmap, double heatmap_max,
                           const CompareRunSeconds& seconds)
{
    if (unit)
    {
        out["in_unit"] = compare_in_unit_json(report, *unit, unit_from_file);
    }
    if (!heatmap.empty())
    {
        out["heatmap"] = {{"file", heatmap}, {"max_distance", heatmap_max / report.diagonal}};
    }
    out["seconds"] = {{"read", seconds.read},
                      {"index", report.seconds.index},
                      {"a_to_b", report.seconds.a_to_b},
                      {"b_to_a", report.seconds.b_to_a},
                      {"heatmap", seconds.heatmap},
                      {"total", seconds.total}};
}

nlohmann::json compare_in_unit_json(const DistortionReport& r, LengthUnit unit, bool is_from_file)
{
    const double d = r.diagonal;
    nlohmann::json out = {{"unit", to_string(unit)},
                          {"source", is_from_file ? "file" : "option"},
                          {"bbox_diagonal", d},
                          {"hausdorff", r.hausdorff_rel * d},
                          {"hausdorff_ab", r.hausdorff_ab_rel * d},
                          {"hausdorff_ba", r.hausdorff_ba_rel * d},
                          {"rms_ab", r.rms_ab_rel * d},
                          {"rms_ba", r.rms_ba_rel * d},
                          {"mrms", r.mrms_rel * d},
                          {"mean_ab", r.a_to_b.mean},
                          {"mean_ba", r.b_to_a.mean}};
    if (r.displacement)
    {
        out["max_displacement"] = r.max_displacement_rel * d;
        out["rms_displacement"] = r.rms_displacement_rel * d;
    }
    return out;
}

nlohmann::json compare_report_json(const std::string& a_path, const std::string& b_path,
                                   const TriangleMesh& a, const TriangleMesh& b,
                                   const DistortionReport& r, std::uint64_t seed)
{
    nlohmann::json out = {{"hausdorff", r.hausdorff_rel},
                          {"hausdorff_ab", r.hausdorff_ab_rel},
                          {"hausdorff_ba", r.hausdorff_ba_rel},
                          {"rms_ab", r.rms_ab_rel},
                          {"rms_ba", r.rms_ba_rel},
                          {"mrms", r.mrms_rel},
                          {"mean_ab", r.a_to_b.mean / r.diagonal},
                          {"mean_ba", r.b_to_a.mean / r.diagonal},
                          {"same_connectivity", r.displacement.has_value()},
                          {"unit", "bounding-box diagonal of A"},
                          {"bbox_diagonal", r.diagonal},
                          {"a", mesh_json(a_path, a, r.a_to_b)},
                          {"b", mesh_json(b_path, b, r.b_to_a)},
                          {"samples", r.a_to_b.vertex_samples + r.a_to_b.area_samples +
                                          r.b_to_a.vertex_samples + r.b_to_a.area_samples},
                          {"seed", seed}};
    if (r.displacement)
    {
        out["max_displacement"] = r.max_displacement_rel;
        out["rms_displacement"] = r.rms_displacement_rel;
    }
    return out;
}

std::string shell_word(const std::string& word)
{
    const bool is_safe = !word.empty() && word.find_first_not_of(
                                              "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789_-+=.,/:@%") == std::string::npos;
    if (is_safe)
    {
        return word;
    }
    std::string out = "'";
    for (const char c : word)
    {
        out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    }
    return out + "'";
}

std::string shortest(double value)
{
    std::array<char, 32> text{};
    const auto end = std::to_chars(text.data(), text.data() + text.size(), value).ptr;
    return {text.data(), end};
}

std::string detect_command(const std::string& suspect, const std::string& original,
                           const std::string& key, const std::string& pairs,
                           const DetectFileOptions& options)
{
    const DetectOptions defaults;
    const DetectOptions& decision = options.decision;
    std::string command = "meshmark detect " + shell_word(suspect) + " --original " +
                          shell_word(original) + " --key " + shell_word(key);
    if (decision.verdict != defaults.verdict)
    {
        command += std::string(" --verdict ") + to_string(decision.verdict);
    }
    if (decision.max_false_positive != defaults.max_false_positive)
    {
        command += " --max-fpp " + shortest(decision.max_false_positive);
    }
    if (decision.threshold != defaults.threshold)
    {
        command += " --threshold " + shortest(decision.threshold);
    }
    if (decision.epsilon != defaults.epsilon)
    {
        command += " --epsilon " + shortest(decision.epsilon);
    }
    if (!pairs.empty())
    {
        command += " --pairs " + shell_word(pairs);
    }
    command += options.trace ? "" : " --no-trace";
    command += options.allow_registration ? "" : " --no-register";
    return command + " --json";
}

}  // namespace meshmark

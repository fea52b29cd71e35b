// SPDX-License-Identifier: MIT
// `meshmark bench robustness`: its reports (the trials as JSON, the Markdown tables of
// docs/robustness.md, and the tables of earlier runs with --from-json).
#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_robustness.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "report.h"

namespace meshmark::cli::robustness
{

nlohmann::json to_json(const Trial& t)
{
    return {{"mesh", t.mesh},
            {"key", t.key},
            {"attack", t.attack},
            {"kind", t.kind},
            {"detected", t.decision.is_present},
            {"score", t.decision.score},
            {"correlation", t.decision.correlation},
            {"false_positive_probability", t.decision.false_positive_probability},
            {"score_false_positive_probability", t.decision.score_false_positive_probability},
            {"bits_false_positive_probability", t.decision.bits_false_positive_probability},
            {"cropped_fraction", t.cropped_fraction},
            {"outlier_fraction", t.outlier_fraction},
            {"registration_rms", t.registration_rms},
            {"alignment", t.alignment},
            {"seconds", t.seconds},
            {"error", t.error},
            {"recipients_traced", t.recipients_traced},
            {"recipient_accused", t.recipient_accused},
            {"others_accused", t.others_accused},
            {"recipient_score", t.recipient_score},
            {"owner_detected", t.owner_detected}};
}

namespace
{

Trial trial_from_json(const nlohmann::json& j)
{
    Trial t;
    t.mesh = j.at("mesh").get<std::string>();
    t.key = j.at("key").get<int>();
    t.attack = j.at("attack").get<std::string>();
    t.kind = j.at("kind").get<std::string>();
    t.decision.is_present = j.at("detected").get<bool>();
    t.decision.score = j.at("score").get<double>();
    t.decision.correlation = j.at("correlation").get<double>();
    t.decision.false_positive_probability = j.at("false_positive_probability").get<double>();
    // Files written before the combined verdict hold the correlation rule's probability only.
    t.decision.score_false_positive_probability =
        j.value("score_false_positive_probability", t.decision.false_positive_probability);
    t.decision.bits_false_positive_probability =
        j.at("bits_false_positive_probability").get<double>();
    t.cropped_fraction = j.at("cropped_fraction").get<double>();
    t.outlier_fraction = j.value("outlier_fraction", 0.0);  // files written before 2026-11-25: none
    t.registration_rms = j.value("registration_rms", 0.0);
    t.alignment = j.value("alignment", std::string());
    t.seconds = j.at("seconds").get<double>();
    t.recipients_traced = j.value("recipients_traced", std::size_t{0});
    t.recipient_accused = j.value("recipient_accused", false);
    t.others_accused = j.value("others_accused", 0);
    t.recipient_score = j.value("recipient_score", 0.0);
    // Files written before the joint ownership reading: the owner's mark alone.
    t.owner_detected = j.value("owner_detected", t.decision.is_present);
    t.error = j.at("error").get<std::string>();
    return t;
}

nlohmann::json to_json(const MeshEmbedding& e)
{
    return {{"mesh", e.mesh},
            {"vertices", e.vertices},
            {"keys", e.keys},
            {"mrms", e.mrms},
            {"hausdorff", e.hausdorff},
            {"rms_displacement", e.rms_displacement},
            {"embed_seconds", e.embed_seconds},
            {"repetitions", e.repetitions}};
}

MeshEmbedding embedding_from_json(const nlohmann::json& j)
{
    MeshEmbedding e;
    e.mesh = j.at("mesh").get<std::string>();
    e.vertices = j.at("vertices").get<std::int64_t>();
    e.keys = j.at("keys").get<int>();
    e.mrms = j.at("mrms").get<double>();
    e.hausdorff = j.at("hausdorff").get<double>();
    e.rms_displacement = j.at("rms_displacement").get<double>();
    e.embed_seconds = j.at("embed_seconds").get<double>();
    e.repetitions = j.value("repetitions", 0);  // absent from files before the automatic choice
    return e;
}

// The settings that make trials comparable: files merged with --from-json must agree on them.
nlohmann::json settings_json(const RobustnessArgs& args)
{
    nlohmann::json settings = {{"rule", args.rule},
                               {"strength", args.strength},
                               {"strength_measure", args.strength_measure},
                               {"coefficients", args.coefficients},
                               {"repetitions", args.repetitions},
                               {"first_mode", args.first_mode},
                               {"basis_size", args.basis_size},
                               {"seed", args.seed},
                               {"wrong_keys", args.wrong_keys},
                               {"unmarked_keys", args.unmarked_keys}};
    if (args.recipients > 0)
    {
        settings["recipients"] = args.recipients;  // absent for single-owner keys (older files)
        settings["colluders"] = args.colluders;
    }
    return settings;
}

// Per-attack summary of the marked trials.
struct Summary
{
    int trials = 0;
    int errors = 0;
    int detected = 0;       // the verdict (default: combined)
    int detected_bits = 0;  // paper's rule, R >= threshold
    double sum_score = 0.0;
    double min_score = 1e300;
    double sum_r = 0.0;
    double max_score = -1e300;
    double max_r = 0.0;
    double min_fpp = 1.0;
    std::vector<double> fpp;
};

void add(Summary& s, const Trial& t, double threshold)
{
    ++s.trials;
    if (!t.error.empty())
    {
        ++s.errors;
        return;
    }
    s.detected += t.decision.is_present ? 1 : 0;
    s.detected_bits += t.decision.correlation >= threshold ? 1 : 0;
    s.sum_score += t.decision.score;
    s.sum_r += t.decision.correlation;
    s.min_score = std::min(s.min_score, t.decision.score);
    s.max_score = std::max(s.max_score, t.decision.score);
    s.max_r = std::max(s.max_r, t.decision.correlation);
    s.min_fpp = std::min(s.min_fpp, t.decision.false_positive_probability);
    s.fpp.push_back(t.decision.false_positive_probability);
}

double median(std::vector<double> v)
{
    if (v.empty())
    {
        return 1.0;
    }
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

std::string percent(double fraction)
{
    return format_number(100.0 * fraction, 3) + "%";
}

}  // namespace

namespace
{

// Family keys: per attack, how often the marked copy's recipient was accused, the owner's mark
// claimed, either of them; innocents accused over every trial (marked, unmarked, wrong keys).
std::string recipients_section(const std::vector<Trial>& trials,
                               const std::vector<std::string>& attacks, int recipients,
                               int colluders)
{
    std::ostringstream md;
    md << "\n### Recipient copies (family keys of " << recipients
       << " recipients; the marked copy is "
       << (colluders == 1 ? std::string("recipient 0's")
                          : "the average of " + std::to_string(colluders) + " recipients' copies")
       << ")\n\n"
       << "| attack | marked trials | " << (colluders == 1 ? "its recipient" : "a colluder")
       << " accused | owner's mark alone | ownership (alone or joint) | accused or ownership | "
          "median z of "
       << (colluders == 1 ? "its recipient" : "the best colluder")
       << " |\n|---|---:|---:|---:|---:|---:|---:|\n";
    int innocents = 0;
    int traced = 0;
    int false_ownership = 0;  // ownership shown on an unmarked copy or with a wrong key
    int unmarked_traced = 0;
    for (const Trial& t : trials)
    {
        innocents += t.others_accused + (t.kind != "marked" && t.recipient_accused ? 1 : 0);
        traced += t.recipients_traced > 0 ? 1 : 0;
        if (t.kind != "marked" && t.recipients_traced > 0 && t.error.empty())
        {
            ++unmarked_traced;
            false_ownership += t.owner_detected ? 1 : 0;
        }
    }
    for (const auto& a : attacks)
    {
        int n = 0;
        int accused = 0;
        int owner = 0;
        int ownership = 0;
        int either = 0;
        std::vector<double> scores;
        for (const Trial& t : trials)
        {
            if (t.attack != a || t.kind != "marked" || !t.error.empty())
            {
                continue;
            }
            ++n;
            accused += t.recipient_accused ? 1 : 0;
            owner += t.decision.is_present ? 1 : 0;
            ownership += t.owner_detected ? 1 : 0;
            either += (t.recipient_accused || t.owner_detected) ? 1 : 0;
            scores.push_back(t.recipient_score);
        }
        std::sort(scores.begin(), scores.end());
        const double median = scores.empty() ? 0.0 : scores[scores.size() / 2];
        md << "| `" << a << "` | " << n << " | " << accused << " | " << owner << " | " << ownership
           << " | " << either << " | " << format_number(median) << " |\n";
    }
    md << "\nInnocent recipients accused, over all " << traced
       << " traced trials (marked, unmarked and wrong keys): " << innocents
       << ". Ownership shown on an "
       << "unmarked copy or with a wrong key: " << false_ownership << " of " << unmarked_traced
       << ".\n";
    return md.str();
}

}  // namespace

std::string markdown_report(const std::vector<MeshEmbedding>& embeddings,
                            const std::vector<Trial>& trials,
                            const std::vector<std::string>& attacks, const RobustnessArgs& args,
                            const DetectOptions& decision)
{
    std::ostringstream md;
    int fewest_keys = 0;
    int most_keys = 0;
    for (const auto& e : embeddings)
    {
        fewest_keys = fewest_keys == 0 ? e.keys : std::min(fewest_keys, e.keys);
        most_keys = std::max(most_keys, e.keys);
    }
    md << "<!-- Generated by `meshmark bench robustness`; do not edit by hand. -->\n\n";
    md << "Keys per mesh: "
       << (fewest_keys == most_keys ? std::to_string(most_keys)
                                    : std::to_string(fewest_keys) + "-" + std::to_string(most_keys))
       << " (wrong keys per marked copy: " << args.wrong_keys
       << ", keys on unmarked attacked copies: " << args.unmarked_keys << "); rule " << args.rule
       << ", strength "
       << (args.strength < 0 ? std::string("default") : format_number(args.strength)) << " ("
       << args.strength_measure << ")"
       << ", coefficients " << args.coefficients << ", repetitions "
       << (args.repetitions == EmbedOptions::kAutoRepetitions ? std::string("auto")
                                                              : std::to_string(args.repetitions))
       << ", first mode " << args.first_mode << ", basis size " << args.basis_size << ", basis "
       << args.basis
       << (args.basis == "rbf" ? " (" + args.centers + " centers" +
                                     (args.gram_rows == EmbedOptions::kDefaultGramRows
                                          ? std::string()
                                          : ", Gram rows " + std::to_string(args.gram_rows)) +
                                     ")"
                               : std::string())
       << "; verdict: " << to_string(decision.verdict)
       << ", bound <= " << format_number(decision.max_false_positive)
       << " (bits rule: R >= " << format_number(decision.threshold) << ").\n\n";

    md << "### Embedding distortion (mean over keys, fraction of the bounding-box diagonal)\n\n";
    md << "| mesh | vertices | keys | r | MRMS | Hausdorff | RMS displacement | embed s |\n"
          "|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& e : embeddings)
    {
        md << "| " << e.mesh << " | " << e.vertices << " | " << e.keys << " | "
           << (e.repetitions > 0 ? std::to_string(e.repetitions) : std::string("-")) << " | "
           << percent(e.mrms) << " | " << percent(e.hausdorff) << " | "
           << percent(e.rms_displacement) << " | " << format_number(e.embed_seconds) << " |\n";
    }

    std::map<std::string, Summary> marked;
    std::map<std::string, Summary> unmarked;
    Summary wrong;
    Summary all_unmarked;
    std::map<std::string, std::vector<std::string>> misses;
    for (const auto& t : trials)
    {
        if (t.kind == "marked")
        {
            add(marked[t.attack], t, decision.threshold);
            if (t.error.empty() && !t.decision.is_present)
            {
                misses[t.attack].push_back(t.mesh);
            }
        }
        else if (t.kind == "unmarked")
        {
            add(unmarked[t.attack], t, decision.threshold);
            add(all_unmarked, t, decision.threshold);
        }
        else
        {
            add(wrong, t, decision.threshold);
        }
    }
    md << "\n### Marked copies\n\n"
       << "| attack | trials | detected | mean z | min z | median FPP | mean R | R >= "
       << format_number(decision.threshold)
       << " | missed on |\n|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (const auto& a : attacks)
    {
        const Summary& s = marked[a];
        const int ok = s.trials - s.errors;
        std::vector<std::string> names = misses[a];
        std::sort(names.begin(), names.end());
        names.erase(std::unique(names.begin(), names.end()), names.end());
        std::string missed;
        for (const auto& n : names)
        {
            missed += (missed.empty() ? "" : ", ") + n;
        }
        md << "| `" << a << "` | " << s.trials
           << (s.errors > 0 ? " (" + std::to_string(s.errors) + " errors)" : "") << " | "
           << s.detected << "/" << ok << " | " << format_number(ok > 0 ? s.sum_score / ok : 0.0)
           << " | " << format_number(ok > 0 ? s.min_score : 0.0) << " | "
           << format_number(median(s.fpp)) << " | " << format_number(ok > 0 ? s.sum_r / ok : 0.0, 3)
           << " | " << s.detected_bits << "/" << ok << " | " << missed << " |\n";
    }
    md << "\n### Marked copies per mesh (every attack)\n\n"
       << "| mesh | trials | detected | mean R | min z | missed (attack: copies) "
          "|\n|---|---:|---:|---:|---:|---|\n";
    for (const auto& e : embeddings)
    {
        Summary s;
        std::map<std::string, int> missed_attacks;
        for (const auto& t : trials)
        {
            if (t.kind == "marked" && t.mesh == e.mesh)
            {
                add(s, t, decision.threshold);
                if (t.error.empty() && !t.decision.is_present)
                {
                    ++missed_attacks[t.attack];
                }
            }
        }
        const int ok = s.trials - s.errors;
        std::string missed;
        for (const auto& a : attacks)
        {
            if (const auto it = missed_attacks.find(a); it != missed_attacks.end())
            {
                missed += (missed.empty() ? "`" : ", `") + a + "`: " + std::to_string(it->second);
            }
        }
        md << "| " << e.mesh << " | " << s.trials
           << (s.errors > 0 ? " (" + std::to_string(s.errors) + " errors)" : "") << " | "
           << s.detected << "/" << ok << " | " << format_number(ok > 0 ? s.sum_r / ok : 0.0, 3)
           << " | " << format_number(ok > 0 ? s.min_score : 0.0) << " | " << missed << " |\n";
    }
    md << "\n### Unmarked copies and wrong keys (nothing may be claimed)\n\n"
       << "| suspect | trials | claimed | claimed by R >= " << format_number(decision.threshold)
       << " | largest z | largest R | smallest FPP |\n|---|---:|---:|---:|---:|---:|---:|\n";
    auto row = [&](const std::string& name, const Summary& s)
    {
        md << "| " << name << " | " << s.trials - s.errors << " | " << s.detected << " | "
           << s.detected_bits << " | " << format_number(s.trials > s.errors ? s.max_score : 0.0)
           << " | " << format_number(s.max_r, 3) << " | " << format_number(s.min_fpp) << " |\n";
    };
    row("wrong key on a marked copy", wrong);
    row("unmarked copies, all attacks", all_unmarked);
    for (const auto& a : attacks)
    {
        row("unmarked, `" + a + "`", unmarked[a]);
    }
    if (args.recipients > 0)
    {
        md << recipients_section(trials, attacks, args.recipients, args.colluders);
    }
    // Trials that could not run count in the tables as errors only: say why, once per reason.
    std::map<std::string, std::pair<int, std::vector<std::string>>>
        reasons;  // error -> count, attacks
    for (const Trial& t : trials)
    {
        if (!t.error.empty())
        {
            auto& [count, where] = reasons[t.error];
            ++count;
            if (std::find(where.begin(), where.end(), t.attack) == where.end())
            {
                where.push_back(t.attack);
            }
        }
    }
    if (!reasons.empty())
    {
        md << "\n### Trials that could not run\n\n";
        for (const auto& [error, entry] : reasons)
        {
            md << "- " << entry.first << (entry.first == 1 ? " trial (" : " trials (");
            for (std::size_t i = 0; i < entry.second.size(); ++i)
            {
                md << (i > 0 ? ", `" : "`") << entry.second[i] << "`";
            }
            md << "): " << error << "\n";
        }
    }
    return md.str();
}

void write_trials_json(const RobustnessArgs& args, const std::vector<MeshEmbedding>& embeddings,
                       const std::vector<Trial>& trials)
{
    nlohmann::json all_trials = nlohmann::json::array();
    for (const auto& t : trials)
    {
        all_trials.push_back(to_json(t));
    }
    nlohmann::json all_embeddings = nlohmann::json::array();
    for (const auto& e : embeddings)
    {
        all_embeddings.push_back(to_json(e));
    }
    const nlohmann::json doc{
        {"settings", settings_json(args)}, {"embeddings", all_embeddings}, {"trials", all_trials}};
    write_file_atomically(args.json_path, [&](std::ostream& out) { out << doc.dump(1) << "\n"; });
}

int report_from_json(const RobustnessArgs& args)
{
    RobustnessArgs merged = args;
    std::optional<nlohmann::json> settings;
    std::vector<MeshEmbedding> embeddings;
    std::vector<Trial> trials;
    std::vector<std::string> attack_names = {"none"};
    for (const auto& file : args.from_json)
    {
        nlohmann::json doc;
        try
        {
            std::ifstream in(file, std::ios::binary);
            if (!in)
            {
                throw IoError(file + ": cannot open this file.");
            }
            doc = nlohmann::json::parse(in);
            if (!doc.contains("settings") || !doc.contains("embeddings"))
            {
                throw IoError(
                    file +
                    ": not a trials file of `bench robustness --json-file` (no settings or "
                    "embeddings; files written before 2026-11-23 lack them).");
            }
            if (settings && *settings != doc.at("settings"))
            {
                throw IoError(file + ": its settings (" + doc.at("settings").dump() +
                              ") differ from those of " + args.from_json.front() + " (" +
                              settings->dump() +
                              "); only runs with the same "
                              "rule, strength, layout and seed can be merged.");
            }
            settings = doc.at("settings");
            for (const auto& e : doc.at("embeddings"))
            {
                embeddings.push_back(embedding_from_json(e));
                const std::string& mesh = embeddings.back().mesh;
                if (std::count_if(embeddings.begin(), embeddings.end(),
                                  [&](const MeshEmbedding& other)
                                  { return other.mesh == mesh; }) > 1)
                {
                    throw IoError(file + ": mesh " + mesh +
                                  " is already in an earlier file; its keys would be "
                                  "counted twice.");
                }
            }
            for (const auto& t : doc.at("trials"))
            {
                trials.push_back(trial_from_json(t));
                if (std::find(attack_names.begin(), attack_names.end(), trials.back().attack) ==
                    attack_names.end())
                {
                    attack_names.push_back(trials.back().attack);
                }
            }
        }
        catch (const nlohmann::json::exception& e)
        {
            throw IoError(file + ": not a valid trials file (" + std::string(e.what()) + ").");
        }
    }
    merged.rule = settings->at("rule").get<std::string>();
    merged.strength = settings->at("strength").get<double>();
    // Absent in files written before the surface measure: those measured vertex displacement.
    merged.strength_measure = settings->value("strength_measure", std::string("vertex"));
    merged.coefficients = settings->value("coefficients", EmbedOptions{}.coefficients);
    merged.repetitions = settings->at("repetitions").get<int>();
    merged.first_mode = settings->at("first_mode").get<int>();
    merged.basis_size =
        settings->value("basis_size", EmbedOptions{}.basis_size);  // absent in older files
    merged.wrong_keys = settings->at("wrong_keys").get<int>();
    merged.unmarked_keys = settings->at("unmarked_keys").get<int>();
    const std::string table =
        markdown_report(embeddings, trials, attack_names, merged, DetectOptions{});
    if (!args.markdown.empty())
    {
        write_file_atomically(args.markdown, [&](std::ostream& out) { out << table; });
    }
    std::fputs(table.c_str(), stdout);
    return 0;
}

}  // namespace meshmark::cli::robustness

// SPDX-License-Identifier: MIT
// `meshmark bench robustness`: embed with many keys into real meshes, attack the marked copies
// and the unmarked originals with the whole attack suite, detect everything, and tabulate
// (issue 4, docs/robustness.md). Everything runs in memory: one watermark per (mesh, key) serves
// every suspect, so the basis is built once per key.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <ostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "commands.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "bench_mesh.h"
#include "meshmark/pipeline/detect_file.h"
#include "report.h"

namespace meshmark::cli {
namespace {

namespace fs = std::filesystem;

// The attack suite at the levels of issue 4's targets (and a few more), in the grammar of
// `meshmark attack`.
const std::vector<std::string> kDefaultAttacks = {
    "similarity",        "reorder",          "noise=0.001",      "noise=0.005",
    "noise=0.01",        "quantize=10",      "quantize=8",       "smooth=5",
    "smooth=10",         "smooth=30",        "smooth=50",        "taubin=20",
    "simplify=0.1",      "simplify=0.02",    "remesh=0.25",      "remesh=0.05",
    "subdivide=loop",    "subdivide=sqrt3",  "crop=0.7",         "crop=0.5",
    "similarity,simplify=0.1,noise=0.001",
};

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
    int repetitions = EmbedOptions{}.repetitions;
    int first_mode = EmbedOptions{}.first_mode;
    std::string rule = "additive";
    std::string basis = "rbf";
    std::string centers = "random";
    std::int64_t gram_rows = EmbedOptions::kDefaultGramRows;
    std::string markdown;
    std::string json_path;
    std::vector<std::string> from_json;
    bool json = false;
};

struct Trial
{
    std::string mesh;
    int key = 0;
    std::string attack;
    std::string kind;  // "marked", "unmarked" or "wrong-key"
    Decision decision;
    double cropped_fraction = 0.0;
    double registration_rms = 0.0;  // fraction of the original's diagonal
    std::string alignment;          // how the suspect was put in correspondence
    double seconds = 0.0;
    std::string error;
};

struct MeshEmbedding
{
    std::string mesh;
    std::int64_t vertices = 0;
    int keys = 0;
    double mrms = 0.0;       // mean over keys, fraction of the diagonal
    double hausdorff = 0.0;  // mean over keys
    double rms_displacement = 0.0;
    double embed_seconds = 0.0;
};

double seconds_since(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::vector<fs::path> mesh_paths(const RobustnessArgs& args)
{
    std::vector<fs::path> paths;
    for (const auto& m : args.meshes)
    {
        paths.emplace_back(m);
    }
    if (!paths.empty())
    {
        return paths;
    }
    const fs::path dir = args.mesh_dir.empty() ? default_mesh_dir() : fs::path(args.mesh_dir);
    if (!fs::is_directory(dir))
    {
        throw IoError(dir.string() + ": no such mesh directory (use --mesh-dir or MESHMARK_MESH_DIR).");
    }
    paths = mesh_files_in(dir);
    return paths;
}

Key make_key(const TriangleMesh& original, std::uint64_t seed, const RobustnessArgs& args)
{
    Key key;
    key.seed = seed;
    key.options.rule = parse_embedding_rule(args.rule);
    key.options.strength = args.strength;
    key.options.repetitions = args.repetitions;
    key.options.first_mode = args.first_mode;
    key.options.basis = parse_basis_type(args.basis);
    key.options.centers = parse_center_selection(args.centers);
    key.options.gram_rows = args.gram_rows;
    key.payload = random_payload(seed, payload_bit_count(key.options));
    key.original = fingerprint(original);
    return key;
}

Trial run_trial(const SpectralWatermark& mark, const TriangleMesh& original, const TriangleMesh& suspect,
                const DetectFileOptions& options)
{
    Trial trial;
    const auto start = std::chrono::steady_clock::now();
    try
    {
        const DetectReport report = detect_mesh(mark, original, suspect, options);
        trial.decision = report.decision;
        trial.cropped_fraction = report.cropped_fraction;
        trial.registration_rms = report.registration_rms;
        trial.alignment = report.alignment;
    }
    catch (const std::exception& e)
    {
        trial.error = e.what();
    }
    trial.seconds = seconds_since(start);
    return trial;
}

nlohmann::json to_json(const Trial& t)
{
    return {{"mesh", t.mesh},
            {"key", t.key},
            {"attack", t.attack},
            {"kind", t.kind},
            {"detected", t.decision.is_present},
            {"score", t.decision.score},
            {"correlation", t.decision.correlation},
            {"false_positive_probability", t.decision.score_false_positive_probability},
            {"bits_false_positive_probability", t.decision.bits_false_positive_probability},
            {"cropped_fraction", t.cropped_fraction},
            {"registration_rms", t.registration_rms},
            {"alignment", t.alignment},
            {"seconds", t.seconds},
            {"error", t.error}};
}

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
    t.decision.score_false_positive_probability = j.at("false_positive_probability").get<double>();
    t.decision.bits_false_positive_probability = j.at("bits_false_positive_probability").get<double>();
    t.cropped_fraction = j.at("cropped_fraction").get<double>();
    t.registration_rms = j.value("registration_rms", 0.0);
    t.alignment = j.value("alignment", std::string());
    t.seconds = j.at("seconds").get<double>();
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
            {"embed_seconds", e.embed_seconds}};
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
    return e;
}

// The settings that make trials comparable: files merged with --from-json must agree on them.
nlohmann::json settings_json(const RobustnessArgs& args)
{
    return {{"rule", args.rule},
            {"strength", args.strength},
            {"repetitions", args.repetitions},
            {"first_mode", args.first_mode},
            {"seed", args.seed},
            {"wrong_keys", args.wrong_keys},
            {"unmarked_keys", args.unmarked_keys}};
}

// Per-attack summary of the marked trials.
struct Summary
{
    int trials = 0;
    int errors = 0;
    int detected = 0;       // correlation verdict (the default)
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
    s.min_fpp = std::min(s.min_fpp, t.decision.score_false_positive_probability);
    s.fpp.push_back(t.decision.score_false_positive_probability);
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

std::string percent(double fraction) { return format_number(100.0 * fraction, 3) + "%"; }

std::string markdown_report(const std::vector<MeshEmbedding>& embeddings, const std::vector<Trial>& trials,
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
       << ", strength " << (args.strength < 0 ? std::string("default") : format_number(args.strength))
       << ", repetitions " << args.repetitions << ", first mode " << args.first_mode << ", basis " << args.basis
       << (args.basis == "rbf" ? " (" + args.centers + " centers" +
                                     (args.gram_rows == EmbedOptions::kDefaultGramRows
                                          ? std::string()
                                          : ", Gram rows " + std::to_string(args.gram_rows)) +
                                     ")"
                                : std::string())
       << "; verdict: correlation bound <= "
       << format_number(decision.max_false_positive) << " (bits rule: R >= " << format_number(decision.threshold)
       << ").\n\n";

    md << "### Embedding distortion (mean over keys, fraction of the bounding-box diagonal)\n\n";
    md << "| mesh | vertices | keys | MRMS | Hausdorff | RMS displacement | embed s |\n|---|---:|---:|---:|---:|---:|---:|\n";
    for (const auto& e : embeddings)
    {
        md << "| " << e.mesh << " | " << e.vertices << " | " << e.keys << " | " << percent(e.mrms) << " | "
           << percent(e.hausdorff) << " | " << percent(e.rms_displacement) << " | "
           << format_number(e.embed_seconds) << " |\n";
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
       << "| attack | trials | detected | mean z | min z | median FPP | mean R | R >= " << format_number(decision.threshold)
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
        md << "| `" << a << "` | " << s.trials << (s.errors > 0 ? " (" + std::to_string(s.errors) + " errors)" : "")
           << " | " << s.detected << "/" << ok << " | " << format_number(ok > 0 ? s.sum_score / ok : 0.0) << " | "
           << format_number(ok > 0 ? s.min_score : 0.0) << " | " << format_number(median(s.fpp)) << " | "
           << format_number(ok > 0 ? s.sum_r / ok : 0.0, 3) << " | " << s.detected_bits << "/" << ok << " | "
           << missed << " |\n";
    }
    md << "\n### Marked copies per mesh (every attack)\n\n"
       << "| mesh | trials | detected | mean R | min z | missed (attack: copies) |\n|---|---:|---:|---:|---:|---|\n";
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
        md << "| " << e.mesh << " | " << s.trials << (s.errors > 0 ? " (" + std::to_string(s.errors) + " errors)" : "")
           << " | " << s.detected << "/" << ok << " | " << format_number(ok > 0 ? s.sum_r / ok : 0.0, 3) << " | "
           << format_number(ok > 0 ? s.min_score : 0.0) << " | " << missed << " |\n";
    }
    md << "\n### Unmarked copies and wrong keys (nothing may be claimed)\n\n"
       << "| suspect | trials | claimed | claimed by R >= " << format_number(decision.threshold)
       << " | largest z | largest R | smallest FPP |\n|---|---:|---:|---:|---:|---:|---:|\n";
    auto row = [&](const std::string& name, const Summary& s) {
        md << "| " << name << " | " << s.trials - s.errors << " | " << s.detected << " | " << s.detected_bits << " | "
           << format_number(s.trials > s.errors ? s.max_score : 0.0) << " | " << format_number(s.max_r, 3) << " | "
           << format_number(s.min_fpp) << " |\n";
    };
    row("wrong key on a marked copy", wrong);
    row("unmarked copies, all attacks", all_unmarked);
    for (const auto& a : attacks)
    {
        row("unmarked, `" + a + "`", unmarked[a]);
    }
    return md.str();
}

// Writes the trials so far (and the finished meshes' distortion) to --json-file.
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
    const nlohmann::json doc{{"settings", settings_json(args)}, {"embeddings", all_embeddings}, {"trials", all_trials}};
    write_file_atomically(args.json_path, [&](std::ostream& out) { out << doc.dump(1) << "\n"; });
}

// --from-json: tables from the trials of earlier runs (one per mesh, say), which must share
// their settings; nothing is embedded or detected.
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
                throw IoError(file + ": not a trials file of `bench robustness --json-file` (no settings or "
                              "embeddings; files written before 2026-11-23 lack them).");
            }
            if (settings && *settings != doc.at("settings"))
            {
                throw IoError(file + ": its settings (" + doc.at("settings").dump() + ") differ from those of " +
                              args.from_json.front() + " (" + settings->dump() + "); only runs with the same "
                              "rule, strength, layout and seed can be merged.");
            }
            settings = doc.at("settings");
            for (const auto& e : doc.at("embeddings"))
            {
                embeddings.push_back(embedding_from_json(e));
                const std::string& mesh = embeddings.back().mesh;
                if (std::count_if(embeddings.begin(), embeddings.end(),
                                  [&](const MeshEmbedding& other) { return other.mesh == mesh; }) > 1)
                {
                    throw IoError(file + ": mesh " + mesh + " is already in an earlier file; its keys would be "
                                  "counted twice.");
                }
            }
            for (const auto& t : doc.at("trials"))
            {
                trials.push_back(trial_from_json(t));
                if (std::find(attack_names.begin(), attack_names.end(), trials.back().attack) == attack_names.end())
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
    merged.repetitions = settings->at("repetitions").get<int>();
    merged.first_mode = settings->at("first_mode").get<int>();
    merged.wrong_keys = settings->at("wrong_keys").get<int>();
    merged.unmarked_keys = settings->at("unmarked_keys").get<int>();
    const std::string table = markdown_report(embeddings, trials, attack_names, merged, DetectOptions{});
    if (!args.markdown.empty())
    {
        write_file_atomically(args.markdown, [&](std::ostream& out) { out << table; });
    }
    std::fputs(table.c_str(), stdout);
    return 0;
}

int run_bench_robustness(const RobustnessArgs& args, const GlobalArgs& global)
{
    if (!args.from_json.empty())
    {
        return report_from_json(args);
    }
    // An empty --attacks "" leaves only the unattacked copies (and wrong keys): the null study.
    RobustnessArgs run = args;
    run.attacks.erase(std::remove(run.attacks.begin(), run.attacks.end(), std::string()), run.attacks.end());
    std::vector<std::vector<AttackSpec>> specs;
    for (const auto& a : run.attacks)
    {
        specs.push_back(parse_attack_spec(a));
    }
    DetectFileOptions detect_options;
    detect_options.threads = global.threads;
    const bool chatty = !global.quiet;

    std::vector<MeshEmbedding> embeddings;
    std::vector<Trial> trials;
    std::vector<std::string> attack_names = {"none"};
    attack_names.insert(attack_names.end(), run.attacks.begin(), run.attacks.end());
    const auto bench_start = std::chrono::steady_clock::now();
    for (const auto& path : mesh_paths(args))
    {
        const TriangleMesh original = read_mesh(path);
        const std::string name = path.filename().string();
        if (original.vertex_count() > args.max_vertices)
        {
            if (chatty)
            {
                std::fprintf(stderr, "meshmark bench robustness: skipping %s (%lld vertices > --max-vertices)\n",
                             name.c_str(), static_cast<long long>(original.vertex_count()));
            }
            continue;
        }
        MeshEmbedding embedding;
        embedding.mesh = name;
        embedding.vertices = original.vertex_count();
        // Unmarked attacked copies do not depend on the key: make them once per attack.
        std::vector<std::optional<TriangleMesh>> unmarked(specs.size());
        for (std::size_t a = 0; a < specs.size(); ++a)
        {
            try
            {
                unmarked[a] = apply_attacks(original, specs[a], derive_seed(args.seed, "unmarked/" + run.attacks[a]),
                                            global.threads)
                                  .mesh;
            }
            catch (const std::exception&)
            {
                // Recorded below as an error of each unmarked trial.
            }
        }
        for (int k = 0; k < args.keys; ++k)
        {
            const std::uint64_t key_seed = derive_seed(args.seed, name + "/key/" + std::to_string(k));
            const auto embed_start = std::chrono::steady_clock::now();
            const SpectralWatermark mark(original, make_key(original, key_seed, args), global.threads);
            EmbedStats stats;
            const TriangleMesh marked{original.V + mark.displacement(&stats), original.F};
            embedding.embed_seconds += seconds_since(embed_start);
            CompareOptions compare;
            compare.threads = global.threads;
            compare.samples = std::min<std::int64_t>(auto_sample_count(original), 200'000);
            const DistortionReport distortion = compare_meshes(original, marked, compare);
            embedding.mrms += distortion.mrms_rel;
            embedding.hausdorff += distortion.hausdorff_rel;
            embedding.rms_displacement += distortion.rms_displacement_rel;
            ++embedding.keys;

            auto record = [&](Trial t, const std::string& attack, const char* kind) {
                t.mesh = name;
                t.key = k;
                t.attack = attack;
                t.kind = kind;
                trials.push_back(std::move(t));
            };
            record(run_trial(mark, original, marked, detect_options), "none", "marked");
            if (k < args.unmarked_keys)
            {
                record(run_trial(mark, original, original, detect_options), "none", "unmarked");
            }
            for (std::size_t a = 0; a < specs.size(); ++a)
            {
                Trial t;
                try
                {
                    const TriangleMesh attacked =
                        apply_attacks(marked, specs[a], derive_seed(key_seed, "attack/" + run.attacks[a]),
                                      global.threads)
                            .mesh;
                    t = run_trial(mark, original, attacked, detect_options);
                }
                catch (const std::exception& e)
                {
                    t.error = e.what();
                }
                record(std::move(t), run.attacks[a], "marked");
                if (k < args.unmarked_keys)
                {
                    Trial u;
                    if (unmarked[a])
                    {
                        u = run_trial(mark, original, *unmarked[a], detect_options);
                    }
                    else
                    {
                        u.error = "the attack failed on the unmarked original";
                    }
                    record(std::move(u), run.attacks[a], "unmarked");
                }
            }
            for (int w = 0; w < args.wrong_keys; ++w)
            {
                const std::uint64_t wrong_seed = derive_seed(key_seed, "wrong/" + std::to_string(w));
                const SpectralWatermark other(original, make_key(original, wrong_seed, args), global.threads);
                record(run_trial(other, original, marked, detect_options), "none", "wrong-key");
            }
            if (chatty)
            {
                std::fprintf(stderr, "meshmark bench robustness: %s key %d/%d done (%.0f s)\n", name.c_str(), k + 1,
                             args.keys, seconds_since(bench_start));
            }
        }
        if (embedding.keys > 0)
        {
            embedding.mrms /= embedding.keys;
            embedding.hausdorff /= embedding.keys;
            embedding.rms_displacement /= embedding.keys;
            embedding.embed_seconds /= embedding.keys;
        }
        embeddings.push_back(embedding);
        if (!args.json_path.empty())
        {
            write_trials_json(args, embeddings, trials);  // a long run keeps its finished meshes
        }
    }

    const std::string table = markdown_report(embeddings, trials, attack_names, args, detect_options.decision);
    if (!args.markdown.empty())
    {
        write_file_atomically(args.markdown, [&](std::ostream& out) { out << table; });
    }
    nlohmann::json all = nlohmann::json::array();
    for (const auto& t : trials)
    {
        all.push_back(to_json(t));
    }
    if (!args.json_path.empty())
    {
        write_trials_json(args, embeddings, trials);
    }
    if (args.json)
    {
        print_json({{"trials", all}, {"seconds", seconds_since(bench_start)}});
    }
    else
    {
        std::fputs(table.c_str(), stdout);
    }
    return 0;
}

}  // namespace

void register_bench_robustness(CLI::App& bench, GlobalArgs& global, CommandRunner& runner)
{
    auto args = std::make_shared<RobustnessArgs>();
    auto* command = bench.add_subcommand(
        "robustness",
        "Embed with --keys random keys into each mesh, attack the marked copies and the unmarked "
        "original with every attack of --attacks, detect everything (and the marked copies with "
        "wrong keys), and print tables of detection rates, scores and distortion (markdown, or "
        "--json). Runs in memory; registration makes it slow: minutes per mesh.");
    command->add_option("--mesh-dir", args->mesh_dir,
                        "Meshes (.ply .obj .off .stl); default $MESHMARK_MESH_DIR, else ../shared/data/meshes");
    command->add_option("--mesh", args->meshes, "Mesh files instead of a directory (repeatable)");
    command->add_option("--keys", args->keys, "Random keys per mesh")->check(CLI::Range(1, 10000))->capture_default_str();
    command->add_option("--wrong-keys", args->wrong_keys, "Wrong keys tried on each marked copy")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    command->add_option("--unmarked-keys", args->unmarked_keys,
                        "Keys (the first N) also run on the unmarked original and its attacked copies")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    command->add_option("--max-vertices", args->max_vertices, "Skip meshes with more vertices")
        ->capture_default_str();
    command->add_option("--attacks", args->attacks,
                        "Attack specs (grammar of `meshmark attack`), separated by ';'")
        ->delimiter(';');
    command->add_option("--seed", args->seed, "Seed of keys and attacks")->capture_default_str();
    command->add_option("--strength", args->strength, "Embedding strength (default: the rule's default)");
    command->add_option("--repetitions", args->repetitions, "Coefficients per payload bit")->capture_default_str();
    command->add_option("--first-mode", args->first_mode, "First modulated mode")->capture_default_str();
    command->add_option("--rule", args->rule, "additive or paper")
        ->check(CLI::IsMember({"additive", "paper"}))
        ->capture_default_str();
    command->add_option("--basis", args->basis, "rbf or laplacian (the Laplacian eigenbasis baseline)")
        ->check(CLI::IsMember({"rbf", "laplacian"}))
        ->capture_default_str();
    command->add_option("--centers", args->centers, "RBF centers: random or decimate")
        ->check(CLI::IsMember({"random", "decimate"}))
        ->capture_default_str();
    command->add_option("--gram-rows", args->gram_rows,
                        "RBF Gram matrix from at most this many evenly spaced vertices (0 = all)")
        ->check(non_negative())
        ->capture_default_str();
    command->add_option("--markdown", args->markdown, "Also write the tables to this file");
    command->add_option("--json-file", args->json_path, "Also write every trial as JSON to this file");
    command->add_option("--from-json", args->from_json,
                        "Only tabulate: read the trials of earlier --json-file runs (repeatable; same settings) "
                        "instead of running")
        ->check(CLI::ExistingFile);
    command->add_flag("--json", args->json, "Print every trial as one JSON object instead of the tables");
    add_global_flags(*command, global);
    command->callback([args, &global, &runner]() {
        runner = [args, &global]() { return run_bench_robustness(*args, global); };
    });
}

}  // namespace meshmark::cli

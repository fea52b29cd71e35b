// SPDX-License-Identifier: MIT
// `meshmark bench robustness`: embed with many keys into real meshes, attack the marked copies
// and the unmarked originals with the whole attack suite, detect everything, and tabulate
// (issue 4, docs/robustness.md). Everything runs in memory: one watermark per (mesh, key) serves
// every suspect, so the basis is built once per key. The reports are in
// bench_robustness_report.cpp.
#include "bench_robustness.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "bench_mesh.h"
#include "commands.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/pipeline/detect_file.h"
#include "report.h"

namespace meshmark::cli
{

using namespace robustness;

namespace
{

namespace fs = std::filesystem;

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
        throw IoError(dir.string() +
                      ": no such mesh directory (use --mesh-dir or MESHMARK_MESH_DIR).");
    }
    paths = mesh_files_in(dir);
    return paths;
}

// The key of one trial: the bench's parameters, a random payload from \p seed.
Key trial_key(const TriangleMesh& original, std::uint64_t seed, const RobustnessArgs& args)
{
    EmbedOptions options;
    options.rule = parse_embedding_rule(args.rule);
    options.strength = args.strength;
    options.measure = parse_strength_measure(args.strength_measure);
    options.coefficients = args.coefficients;
    options.repetitions = args.repetitions;
    options.first_mode = args.first_mode;
    options.basis_size = args.basis_size;
    options.basis = parse_basis_type(args.basis);
    options.centers = parse_center_selection(args.centers);
    options.gram_rows = args.gram_rows;
    Key key = make_key(options, seed);
    key.original = fingerprint(original);
    if (args.recipients > 0)
    {
        key.recipients = RecipientCodes{};
        for (int r = 0; r < args.recipients; ++r)
        {
            std::string name(1,
                             'r');  // (appended: GCC 12 reports a false -Wrestrict on "r" + string)
            name += std::to_string(r);
            key.recipients->recipients.push_back({name, static_cast<std::uint32_t>(r)});
        }
    }
    return key;
}

Trial run_trial(const SpectralWatermark& mark, const TriangleMesh& original,
                const TriangleMesh& suspect, const DetectFileOptions& options, int colluders = 1)
{
    Trial trial;
    const auto start = std::chrono::steady_clock::now();
    try
    {
        const DetectReport report = detect_mesh(mark, original, suspect, options);
        trial.decision = report.decision;
        trial.cropped_fraction = report.cropped_fraction;
        trial.outlier_fraction = report.outlier_fraction;
        trial.registration_rms = report.registration_rms;
        trial.alignment = report.registration_method();
        trial.recipients_traced = report.recipients_traced;
        trial.owner_detected = report.owner_detected;
        trial.recipient_score = report.traced.empty() ? 0.0 : -1e300;
        for (const RecipientScore& r : report.traced)
        {
            if (r.index < static_cast<std::uint32_t>(colluders))
            {
                trial.recipient_score = std::max(trial.recipient_score, r.score);
                trial.recipient_accused = trial.recipient_accused || r.is_accused;
            }
            else
            {
                trial.others_accused += r.is_accused ? 1 : 0;
            }
        }
    }
    catch (const std::exception& e)
    {
        trial.error = e.what();
    }
    trial.seconds = seconds_since(start);
    return trial;
}

int run_bench_robustness(const RobustnessArgs& args, const GlobalArgs& global)
{
    if (!args.from_json.empty())
    {
        return report_from_json(args);
    }
    // An empty --attacks "" leaves only the unattacked copies (and wrong keys): the null study.
    RobustnessArgs run = args;
    run.attacks.erase(std::remove(run.attacks.begin(), run.attacks.end(), std::string()),
                      run.attacks.end());
    std::vector<std::vector<AttackSpec>> specs;
    for (const auto& a : run.attacks)
    {
        specs.push_back(parse_attack_spec(a));
    }
    DetectFileOptions detect_options;
    detect_options.threads = global.threads;
    detect_options.match_surface = !args.plain_resampling;
    detect_options.predict_voxel = !args.no_voxel_prediction;
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
                std::fprintf(
                    stderr,
                    "meshmark bench robustness: skipping %s (%lld vertices > --max-vertices)\n",
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
                unmarked[a] = apply_attacks(original, specs[a],
                                            derive_seed(args.seed, "unmarked/" + run.attacks[a]),
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
            const std::uint64_t key_seed =
                derive_seed(args.seed, name + "/key/" + std::to_string(k));
            const auto embed_start = std::chrono::steady_clock::now();
            SpectralWatermark mark(original, trial_key(original, key_seed, args), global.threads);
            // Calibrated as embed calibrates a new key (docs/algorithms/embedding.md, "Strength").
            Positions field = mark.displacement();
            mark.calibrate_strength(original, field);
            // A family key's marked copy is recipient 0's (or the average of the first --colluders
            // recipients' copies).
            if (args.recipients > 0)
            {
                // The average of the colluders' copies: the owner's mark and the mean of their
                // codes, each scaled as embed scales it so that its copy has the strength's
                // surface distance (the surface measure).
                const Key& key = mark.key();
                std::optional<SurfaceRmsOfSums> copy_surface;
                double target = 0.0;
                if (key.options.rule == EmbeddingRule::Additive &&
                    key.options.measure == StrengthMeasure::Surface)
                {
                    copy_surface.emplace(original, field);
                    target = key.options.resolved_strength() *
                             bounding_box(original.V, mark.mesh_rows()->active()).diagonal();
                }
                const int first_code = static_cast<int>(mark.coefficient_change().rows());
                Positions codes = Positions::Zero(original.V.rows(), 3);
                for (int c = 0; c < args.colluders; ++c)
                {
                    Eigen::MatrixX3d change =
                        Eigen::MatrixX3d::Zero(first_code + mark.recipient_modes(), 3);
                    change.bottomRows(mark.recipient_modes()) =
                        mark.recipient_change(static_cast<std::uint32_t>(c));
                    const Positions code = mark.basis().synthesize(change);
                    codes +=
                        (copy_surface ? copy_surface->terms(code).scale_to(target) : 1.0) * code;
                }
                field += codes / static_cast<double>(args.colluders);
            }
            const TriangleMesh marked{original.V + field, original.F};
            embedding.embed_seconds += seconds_since(embed_start);
            CompareOptions compare;
            compare.threads = global.threads;
            compare.samples = std::min<std::int64_t>(auto_sample_count(original), 200'000);
            const DistortionReport distortion = compare_meshes(original, marked, compare);
            embedding.mrms += distortion.mrms_rel;
            embedding.hausdorff += distortion.hausdorff_rel;
            embedding.rms_displacement += distortion.rms_displacement_rel;
            embedding.repetitions = mark.key().options.repetitions;
            ++embedding.keys;

            auto record = [&](Trial t, const std::string& attack, const char* kind)
            {
                t.mesh = name;
                t.key = k;
                t.attack = attack;
                t.kind = kind;
                trials.push_back(std::move(t));
            };
            record(run_trial(mark, original, marked, detect_options, args.colluders), "none",
                   "marked");
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
                        apply_attacks(marked, specs[a],
                                      derive_seed(key_seed, "attack/" + run.attacks[a]),
                                      global.threads)
                            .mesh;
                    t = run_trial(mark, original, attacked, detect_options, args.colluders);
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
                const std::uint64_t wrong_seed =
                    derive_seed(key_seed, "wrong/" + std::to_string(w));
                const SpectralWatermark other(original, trial_key(original, wrong_seed, args),
                                              global.threads);
                record(run_trial(other, original, marked, detect_options), "none", "wrong-key");
            }
            if (chatty)
            {
                std::fprintf(stderr, "meshmark bench robustness: %s key %d/%d done (%.0f s)\n",
                             name.c_str(), k + 1, args.keys, seconds_since(bench_start));
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

    const std::string table =
        markdown_report(embeddings, trials, attack_names, args, detect_options.decision);
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
        "Embed, attack and detect with many keys per mesh; tables of detection rates, scores and "
        "distortion (docs/cli.md)");
    command->add_option(
        "--mesh-dir", args->mesh_dir,
        "Meshes (.ply .obj .off .stl); default $MESHMARK_MESH_DIR, else ../shared/data/meshes");
    command->add_option("--mesh", args->meshes, "Mesh files instead of a directory (repeatable)");
    command->add_option("--keys", args->keys, "Random keys per mesh")
        ->check(CLI::Range(1, 10000))
        ->capture_default_str();
    command->add_option("--wrong-keys", args->wrong_keys, "Wrong keys tried on each marked copy")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    command
        ->add_option("--unmarked-keys", args->unmarked_keys,
                     "Keys (the first N) also run on the unmarked original and its attacked copies")
        ->check(CLI::Range(0, 10000))
        ->capture_default_str();
    command->add_option("--max-vertices", args->max_vertices, "Skip meshes with more vertices")
        ->capture_default_str();
    command
        ->add_option("--attacks", args->attacks,
                     "Attack specs (grammar of `meshmark attack`), separated by ';'")
        ->delimiter(';');
    command->add_option("--seed", args->seed, "Seed of keys and attacks")->capture_default_str();
    command->add_option("--strength", args->strength,
                        "Embedding strength (default: the rule's default)");
    command
        ->add_option("--strength-measure", args->strength_measure, "As embed's: surface or vertex")
        ->check(CLI::IsMember({"surface", "vertex"}))
        ->capture_default_str();
    command->add_option("--coefficients", args->coefficients, "m, payload bits per axis (3m bits)")
        ->capture_default_str();
    command
        ->add_option("--repetitions", args->repetitions,
                     "Coefficients per payload bit: auto (as embed) or a number")
        ->transform(repetitions_choice())
        ->type_name("auto|INT")
        ->default_str("auto");
    command->add_option("--first-mode", args->first_mode, "First modulated mode")
        ->capture_default_str();
    command
        ->add_option("--basis-size", args->basis_size,
                     "k, basis functions (first mode + m*r must not exceed it)")
        ->capture_default_str();
    command->add_option("--rule", args->rule, "additive or paper")
        ->check(CLI::IsMember({"additive", "paper"}))
        ->capture_default_str();
    command
        ->add_option("--basis", args->basis, "rbf or laplacian (the Laplacian eigenbasis baseline)")
        ->check(CLI::IsMember({"rbf", "laplacian"}))
        ->capture_default_str();
    command->add_option("--centers", args->centers, "RBF centers: random or decimate")
        ->check(CLI::IsMember({"random", "decimate"}))
        ->capture_default_str();
    command
        ->add_option("--gram-rows", args->gram_rows,
                     "RBF Gram matrix from at most this many evenly spaced vertices (0 = all)")
        ->check(non_negative())
        ->capture_default_str();
    command->add_option("--markdown", args->markdown, "Also write the tables to this file");
    command->add_option("--json-file", args->json_path,
                        "Also write every trial as JSON to this file");
    command
        ->add_option(
            "--recipients", args->recipients,
            "Family keys with this many recipients (0: single-owner keys); suspects are traced")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    command
        ->add_option("--colluders", args->colluders,
                     "With --recipients: the suspect averages the copies of this many recipients")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    command
        ->add_option("--from-json", args->from_json,
                     "Only tabulate the trials of earlier --json-file runs (repeatable)")
        ->check(CLI::ExistingFile);
    command->add_flag("--plain-resampling", args->plain_resampling,
                      "Ablation: read resampled copies against the original's vertices only");
    command->add_flag("--no-voxel-prediction", args->no_voxel_prediction,
                      "Ablation: read voxel-remeshed copies without the original's own remesh");
    command->add_flag("--json", args->json,
                      "Print every trial as one JSON object instead of the tables");
    add_global_flags(*command, global);
    command->callback(
        [args, &global, &runner, command]()
        {
            if (args->recipients > 0 && command->count("--repetitions") == 0)
            {
                args->repetitions =
                    kFamilyRepetitions;  // the family key's default owner mark, as in `embed`
            }
            runner = [args, &global]() { return run_bench_robustness(*args, global); };
        });
}

}  // namespace meshmark::cli

// SPDX-License-Identifier: MIT
// The file-level calls, each returning the JSON report of the matching `meshmark` command.
#include <chrono>
#include <optional>

#include <pybind11/stl.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/length_unit.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/meshmark.h"
#include "meshmark/pipeline/attack_file.h"
#include "meshmark/pipeline/embed_recipients.h"
#include "meshmark/pipeline/embed_record.h"
#include "meshmark/pipeline/report_json.h"
#include "meshmark/report/evidence_report.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

using Path = std::filesystem::path;

constexpr const char* kEmbedFileDoc =
    R"(Watermark a mesh file: `meshmark embed INPUT -o OUTPUT --key KEY_PATH`.

Writes the marked copy (format from output's extension; everything but the positions is kept
when it is the input's format) and the key file, atomically and together. Returns the report
of `meshmark embed --json` as a dict. Keywords: those of meshmark.embed, plus
  force          replace an existing key file, or the input itself when output names it
  memory_budget  MiB; above it a binary PLY is embedded out of core (0 = no budget)
  stream         always embed out of core (binary PLY only)
  lock_timeout   seconds to wait while another call writes the same key (default 60)
  unit           the coordinates' unit (um mm cm m in ft), overriding the file's (--unit)
  max_displacement  cap on the largest vertex displacement, a length such as '0.05mm' or a
                 number in the coordinates' unit; the strength is lowered to fit
                 (--max-displacement)
  record         also write the embed record (the report's 'record': SHA-256 of the files,
                 never the key) to this JSON file, for timestamping (--record)
Raises meshmark.Error subclasses with the program's message.)";

constexpr const char* kEmbedRecipientsDoc =
    R"(Issue one traceable copy per recipient: `meshmark embed INPUT --key KEY_PATH --recipient NAME... -o PATTERN --json`.

output_pattern holds {recipient}; key_path is the family key, created if absent, else extended
(a name it holds gets its copy again, byte for byte; a name given twice is issued once). Safe
from any number of threads and processes at once: the key is read, extended and written durably
in one step under its lock (waiting up to lock_timeout seconds) before any copy is written.
Returns the report of the program's --json as a dict. Keywords: those of meshmark.embed_file
for a new key but rule and basis (a family key is additive on the RBF basis), plus
  recipients_file  a file of names, one per line ('#' comments): the program's --recipients,
                   added after recipients
  recipient_modes, recipient_share  a new family key's codes (--recipient-modes, --recipient-share)
  lock_timeout)";

constexpr const char* kDetectFileDoc =
    R"(Look for a key's mark in a suspect file: `meshmark detect SUSPECT --original ORIGINAL --key KEY_PATH --json`.

Returns the report of `meshmark detect --json` as a dict ('detected', 'score',
'false_positive_probability', ...). Keywords: those of meshmark.detect, plus
  report   also write an evidence report (docs/evidence.md), a .html or .pdf file: the
           program's --report.)";

}  // namespace

void bind_files(py::module_& m)
{
    m.def(
        "read_mesh",
        [](const Path& path) -> MeshArrays
        {
            std::optional<TriangleMesh> mesh;
            {
                py::gil_scoped_release release;
                mesh.emplace(read_mesh(path));
            }
            const bool cloud = mesh->is_point_cloud();
            py::object faces =
                cloud ? py::object(py::none()) : py::object(to_numpy(std::move(mesh->F)));
            return py::make_tuple(to_numpy(std::move(mesh->V)), faces);
        },
        py::arg("path"),
        "Read a mesh file (.ply .obj .off .stl .gltf .glb .3mf) as (V, F): (n, 3) float64 "
        "positions and "
        "(m, 3) int32 triangles (polygons fan-triangulated), F None for a point cloud. Raises "
        "IoError, "
        "InvalidMesh.");
    m.def(
        "write_mesh",
        [](const Path& path, const ArrayLike& V, const OptionalArrayLike& F, bool binary)
        {
            const TriangleMesh mesh = mesh_from_arrays(V.handle(), F.handle(), "");
            py::gil_scoped_release release;
            write_mesh(path, mesh,
                       WriteOptions{.is_binary = binary,
                                    .use_single_precision = false,
                                    .vertex_colors = nullptr,
                                    .link_folder = {}});
        },
        py::arg("path"), py::arg("V"), py::arg("F") = py::none(), py::kw_only(),
        py::arg("binary") = true,
        "Write (V, F) to a mesh file, format from the extension, atomically; positions in double "
        "precision "
        "where the format allows (binary PLY by default), so a file written here reads back "
        "exactly.");
    m.def(
        "embed_file",
        [](const Path& input, const Path& output, const Path& key_path, const OptionalStr& message,
           const OptionalStr& bits, const OptionalInt& seed, const OptionalFloat& strength,
           std::string rule, std::string strength_measure, std::string basis, std::string centers,
           int basis_size, int coefficients, const Repetitions& repetitions, int first_mode,
           double sigma_factor, std::int64_t gram_rows, int threads, bool force,
           std::int64_t memory_budget, bool stream, double lock_timeout,
           const OptionalStr& unit_arg, const LengthArg& max_displacement_arg,
           const OptionalPath& record_arg) -> Report
        {
            const std::optional<std::string> unit = text_from(unit_arg.handle(), "unit");
            const std::optional<Length> max_displacement =
                length_from(max_displacement_arg.handle(), "max_displacement");
            const std::optional<Path> record = path_from(record_arg.handle(), "record");
            if (!(lock_timeout >= 0.0))
            {
                throw InvalidOption("lock_timeout must be >= 0 seconds.");
            }
            EmbedFileOptions options;
            fill_embed_options({message.object, bits.object, seed.object, strength.object, rule,
                                strength_measure, basis, centers, basis_size, coefficients,
                                repetitions.object, first_mode, sigma_factor, gram_rows, threads},
                               options);
            options.force = force;
            options.lock_timeout =
                std::chrono::milliseconds(static_cast<std::int64_t>(1000.0 * lock_timeout));
            options.replace_input =
                force;  // as the program: the output may name the input only with force
            options.memory_budget_mib = memory_budget;
            options.force_stream = stream;
            if (unit)
            {
                options.unit = parse_length_unit(*unit);
            }
            options.max_displacement_length = max_displacement;
            if (record &&
                (is_same_file(*record, input) || *record == output || *record == key_path))
            {
                throw InvalidOption("record " + record->string() +
                                    " must differ from the input, the output and the key.");
            }
            std::optional<EmbedReport> report;
            nlohmann::json out;
            {
                py::gil_scoped_release release;
                // As `embed --json`: the record of the files as written (docs/evidence.md); in
                // place, the original hashed before the marked copy replaces it.
                std::optional<RecordedFile> original_before;
                if (std::filesystem::exists(output) && std::filesystem::equivalent(input, output))
                {
                    original_before = recorded_file(input);
                }
                report.emplace(embed_file(input, output, key_path, options));
                out =
                    embed_report_json(*report, input.string(), output.string(), key_path.string());
                const EmbedRecord written =
                    make_embed_record(input, output, key_path, report->key,
                                      original_before ? &*original_before : nullptr);
                if (record)
                {
                    write_embed_record(*record, written);
                }
                out["record"] = to_json(written);
            }
            return to_python(out);
        },
        py::arg("input"), py::arg("output"), py::arg("key_path"), py::kw_only(),
        py::arg("message") = py::none(), py::arg("bits") = py::none(), py::arg("seed") = py::none(),
        py::arg("strength") = py::none(), py::arg("rule") = "additive",
        py::arg("strength_measure") = "surface", py::arg("basis") = "rbf",
        py::arg("centers") = "random", py::arg("basis_size") = EmbedOptions{}.basis_size,
        py::arg("coefficients") = EmbedOptions{}.coefficients, py::arg("repetitions") = "auto",
        py::arg("first_mode") = EmbedOptions{}.first_mode,
        py::arg("sigma_factor") = EmbedOptions{}.sigma_factor,
        py::arg("gram_rows") = EmbedOptions{}.gram_rows, py::arg("threads") = 0,
        py::arg("force") = false, py::arg("memory_budget") = 0, py::arg("stream") = false,
        py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
        py::arg("unit") = py::none(), py::arg("max_displacement") = py::none(),
        py::arg("record") = py::none(), kEmbedFileDoc);

    m.def(
        "embed_recipients",
        [](const Path& input, const std::string& output_pattern, const Path& key_path,
           const std::vector<std::string>& recipients, const OptionalPath& recipients_file,
           const OptionalStr& message, const OptionalStr& bits, const OptionalInt& seed,
           const OptionalFloat& strength, std::string strength_measure, std::string centers,
           int basis_size, int coefficients, const Repetitions& repetitions, int first_mode,
           double sigma_factor, std::int64_t gram_rows, int recipient_modes, double recipient_share,
           double lock_timeout, int threads) -> Report
        {
            EmbedRecipientsOptions options;
            fill_embed_options(
                {message.object, bits.object, seed.object, strength.object, "additive",
                 strength_measure, "rbf", centers, basis_size, coefficients, repetitions.object,
                 first_mode, sigma_factor, gram_rows, threads},
                options);
            const py::object& r = repetitions.object;
            if (r.is_none() || (py::isinstance<py::str>(r) && r.cast<std::string>() == "auto"))
            {
                // As the program: the owner's mark of a family.
                options.embed.repetitions = kFamilyRepetitions;
            }
            options.recipients = recipients;
            if (const auto file = path_from(recipients_file.handle(), "recipients_file"))
            {
                // As the program's --recipients: the file's names after the list's.
                const std::vector<std::string> listed = read_recipients_file(*file);
                options.recipients.insert(options.recipients.end(), listed.begin(), listed.end());
            }
            options.recipient_modes = recipient_modes;
            options.recipient_share = recipient_share;
            if (!(lock_timeout >= 0.0))
            {
                throw InvalidOption("lock_timeout must be >= 0 seconds.");
            }
            options.lock_timeout =
                std::chrono::milliseconds(static_cast<std::int64_t>(1000.0 * lock_timeout));
            std::optional<EmbedRecipientsReport> report;
            {
                py::gil_scoped_release release;
                report.emplace(embed_recipients(input, output_pattern, key_path, options));
            }
            return to_python(
                embed_recipients_report_json(*report, input.string(), key_path.string()));
        },
        py::arg("input"), py::arg("output_pattern"), py::arg("key_path"),
        py::arg("recipients") = std::vector<std::string>{}, py::kw_only(),
        py::arg("recipients_file") = py::none(), py::arg("message") = py::none(),
        py::arg("bits") = py::none(), py::arg("seed") = py::none(),
        py::arg("strength") = py::none(), py::arg("strength_measure") = "surface",
        py::arg("centers") = "random", py::arg("basis_size") = EmbedOptions{}.basis_size,
        py::arg("coefficients") = EmbedOptions{}.coefficients, py::arg("repetitions") = "auto",
        py::arg("first_mode") = EmbedOptions{}.first_mode,
        py::arg("sigma_factor") = EmbedOptions{}.sigma_factor,
        py::arg("gram_rows") = EmbedOptions{}.gram_rows,
        py::arg("recipient_modes") = RecipientCodes{}.modes,
        py::arg("recipient_share") = RecipientCodes{}.energy_share,
        py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
        py::arg("threads") = 0, kEmbedRecipientsDoc);

    m.def(
        "detect_file",
        [](const Path& suspect, const Path& original, const Path& key_path,
           const std::string& verdict, double max_fpp, double threshold, double epsilon,
           bool register_suspect, const Pairs& pairs, bool trace, int threads, bool verbose,
           const OptionalPath& report_arg) -> Report
        {
            const DetectFileOptions options =
                make_detect_options(verdict, max_fpp, threshold, epsilon, register_suspect,
                                    pairs.handle(), trace, threads);
            // As `detect --report`: an .html or .pdf file that is none of the inputs, checked
            // before detecting.
            const std::optional<Path> evidence = path_from(report_arg.handle(), "report");
            const std::optional<Path> pairs_file = path_from(
                py::isinstance<py::str>(pairs.object) || py::hasattr(pairs.object, "__fspath__")
                    ? pairs.handle()
                    : py::none(),
                "pairs");
            if (evidence)
            {
                (void)evidence_format(*evidence);
                for (const Path* input : {&suspect, &original, &key_path})
                {
                    if (is_same_file(*evidence, *input) ||
                        (pairs_file && is_same_file(*evidence, *pairs_file)))
                    {
                        throw InvalidOption("report " + evidence->string() +
                                            " would overwrite an input file.");
                    }
                }
            }
            std::optional<DetectReport> report;
            {
                py::gil_scoped_release release;
                report.emplace(detect_file(suspect, original, key_path, options));
                if (evidence)
                {
                    // The evidence report states what the dict states: written from the same
                    // object, with the command that repeats the check.
                    DetectionReportOptions report_options;
                    report_options.pictures.threads = threads;
                    report_options.version = "meshmark " MESHMARK_VERSION;
                    report_options.command =
                        detect_command(suspect.string(), original.string(), key_path.string(),
                                       pairs_file ? pairs_file->string() : std::string(), options);
                    write_detection_report(*evidence, suspect, original, key_path,
                                           detect_report_json(*report, options.decision),
                                           report_options);
                }
            }
            return to_python(detect_report_json(*report, options.decision, verbose));
        },
        py::arg("suspect"), py::arg("original"), py::arg("key_path"), py::kw_only(),
        py::arg("verdict") = std::string(to_string(DetectOptions{}.verdict)),
        py::arg("max_fpp") = DetectOptions{}.max_false_positive,
        py::arg("threshold") = DetectOptions{}.threshold,
        py::arg("epsilon") = DetectOptions{}.epsilon, py::arg("register") = true,
        py::arg("pairs") = py::none(), py::arg("trace") = true, py::arg("threads") = 0,
        py::arg("verbose") = false, py::arg("report") = py::none(), kDetectFileDoc);

    m.def(
        "attack",
        [](const Path& input, const std::string& spec, const Path& output, const SeedInt& seed,
           bool force, int threads) -> Report
        {
            AttackFileOptions options;
            options.seed = seed_from(seed.handle()).value_or(0);
            options.force = force;
            options.threads = threads;
            std::optional<AttackFileReport> report;
            {
                py::gil_scoped_release release;
                report.emplace(attack_file(input, output, spec, options));
            }
            return to_python(attack_report_json(*report, input.string(), output.string()));
        },
        py::arg("input"), py::arg("spec"), py::arg("output"), py::kw_only(), py::arg("seed") = 0,
        py::arg("force") = false, py::arg("threads") = 0,
        "Apply an attack chain to a mesh file and write the result: `meshmark attack INPUT SPEC -o "
        "OUTPUT "
        "--seed SEED --json`. spec follows the grammar of `meshmark attack --help`, e.g. "
        "'similarity,simplify=0.1,noise=0.001'. Returns the program's JSON report as a dict.");
}

}  // namespace meshmark::python

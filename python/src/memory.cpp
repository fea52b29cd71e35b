// SPDX-License-Identifier: MIT
// The in-memory calls on numpy arrays: embed, detect (and its DetectResult), attack_mesh.
#include <pybind11/stl.h>

#include "bindings.h"
#include "convert.h"
#include "meshmark/attacks/attack_spec.h"
#include "meshmark/core/error.h"
#include "meshmark/meshmark.h"
#include "meshmark/pipeline/report_json.h"
#include "meshmark/pipeline/verdict.h"
#include "meshmark/registration/point_pairs.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

std::vector<PointPair> pairs_from_array(py::handle object)
{
    const py::array array = py::array::ensure(object);
    if (!array || array.ndim() != 2 || array.shape(1) != 6 || array.shape(0) < 3 ||
        (array.dtype().kind() != 'f' && array.dtype().kind() != 'i'))
    {
        throw InvalidOption(
            "pairs: expected a point-pair file or a (k, 6) array of k >= 3 rows "
            "'xs ys zs xo yo zo' (suspect point, original point).");
    }
    const auto rows = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(array);
    std::vector<PointPair> pairs(static_cast<std::size_t>(rows.shape(0)));
    for (std::size_t i = 0; i < pairs.size(); ++i)
    {
        const double* row = rows.data() + 6 * i;
        pairs[i].suspect = Eigen::Vector3d(row[0], row[1], row[2]);
        pairs[i].reference = Eigen::Vector3d(row[3], row[4], row[5]);
        if (!pairs[i].suspect.allFinite() || !pairs[i].reference.allFinite())
        {
            throw InvalidOption("pairs: row " + std::to_string(i) +
                                " has a non-finite coordinate.");
        }
    }
    return pairs;
}

/// What detect() returns: the report and the options it was decided under.
struct DetectResult
{
    DetectReport report;
    DetectOptions options;
    bool verbose = false;
    [[nodiscard]] nlohmann::json json() const
    {
        return detect_report_json(report, options, verbose);
    }
};

constexpr const char* kEmbedDoc = R"(Watermark a mesh (or point cloud) given as numpy arrays.

Returns (key, marked): a meshmark.Key to keep with the original, and the marked (n, 3)
float64 positions, row for row those of V (the faces do not change). With report=True returns
(key, marked, report), report a dict of the fields of `meshmark embed --json` that do not
concern files (distortion relative to the bounding-box diagonal, parameters, bits, seconds).

V: (n, 3) real array of positions. F: (m, 3) integer array of vertex indices, or None for a
point cloud (the Laplacian basis and decimated centers need faces).
The keywords are the options of `meshmark embed` (docs/cli.md):
  message      payload from a text (hashed to the 3m payload bits); or
  bits         payload as exactly ceil(3m/4) hex digits; neither: random from the seed
  seed         secret seed (int in [0, 2^64)); drawn from the OS when None
  strength     additive rule: the displacement / bbox diagonal in strength_measure (default
               0.00059 surface, 0.001 vertex; 0.001 surface for assets that will be
               decimated to a few percent, docs/robustness.md); paper: rho
  strength_measure  'surface' (RMS distance between the marked and original surface) or
               'vertex' (RMS vertex displacement)
  rule         'additive' or 'paper'
  basis        'rbf' or 'laplacian';  centers: 'random' or 'decimate'
  basis_size (k), coefficients (m), repetitions (r), first_mode, sigma_factor, gram_rows
  repetitions  'auto' (default: 5 on meshes of 5,000+ analysed vertices, else 4; the Key
               records the number chosen) or a whole number >= 1
  threads      worker threads, 0 = all cores (the result does not depend on it)
The same mesh, seed and options give exactly the positions and key of `meshmark embed`.
Raises meshmark.InvalidMesh for bad arrays, meshmark.InvalidOption for bad options,
meshmark.NumericalError. The GIL is released while the mark is computed.)";

constexpr const char* kDetectDoc = R"(Look for the watermark of key in a suspect mesh.

V_suspect, F_suspect: the suspect (F_suspect None for a point cloud); V_original, F_original:
the original the key was made from (checked against the key's fingerprint: IoError if not).
A suspect with the original's vertex count is read vertex for vertex; any other is registered
onto the original and resampled (register=False refuses it instead).
Keywords (the options of `meshmark detect`):
  verdict    the library's default rule, or 'correlation' (claim when the false-positive
             bound <= max_fpp) or 'bits'
             (the paper's rule, claim when R >= threshold)
  max_fpp, threshold, epsilon
  pairs      None, a point-pair file, or a (k, 6) array 'xs ys zs xo yo zo' to start from
  register   False = the `--no-register` flag
  trace      False = the `--no-trace` flag: with a family key, decide on the owner's mark
             alone, without naming recipients
  threads    0 = all cores;  verbose: to_dict() adds the per-coefficient diagnostics
Returns a DetectResult (.detected, .score, .false_positive_probability, ..., .to_dict()).
"Not found" is a result, not an error.)";

constexpr const char* kDetectAgainstFileDoc = R"(detect() with the original and the key as files.

V_suspect, F_suspect: the suspect (an editor's current mesh); original: the original's file, read
as `meshmark detect` reads it, so its other instances and its animation (a copy posed at a frame
of it) are used; key_path: the key file. Keywords and result as detect().)";

// A DetectResult of \p run (a detection, run without the GIL) under \p options.
template <class Run>
DetectResult detect_result(const DetectFileOptions& options, bool verbose, Run&& run)
{
    DetectResult result;
    result.options = options.decision;
    result.verbose = verbose;
    {
        py::gil_scoped_release release;
        result.report = run();
    }
    return result;
}

}  // namespace

void fill_embed_options(const EmbedKeywords& k, EmbedMeshOptions& options)
{
    options.embed.rule = parse_embedding_rule(k.rule);
    options.embed.measure = parse_strength_measure(k.strength_measure);
    options.embed.basis = parse_basis_type(k.basis);
    options.embed.centers = parse_center_selection(k.centers);
    options.embed.basis_size = k.basis_size;
    options.embed.coefficients = k.coefficients;
    // "auto" (or 0, as the library's kAutoRepetitions) lets the watermark choose on the mesh.
    if (py::isinstance<py::str>(k.repetitions) && k.repetitions.cast<std::string>() == "auto")
    {
        options.embed.repetitions = EmbedOptions::kAutoRepetitions;
    }
    else if (py::isinstance<py::int_>(k.repetitions) && !py::isinstance<py::bool_>(k.repetitions))
    {
        options.embed.repetitions = k.repetitions.cast<int>();
    }
    else
    {
        throw InvalidOption("repetitions must be 'auto' or a whole number >= 1, got " +
                            py::repr(k.repetitions).cast<std::string>() + ".");
    }
    options.embed.first_mode = k.first_mode;
    options.embed.sigma_factor = k.sigma_factor;
    options.embed.gram_rows = k.gram_rows;
    if (const std::optional<double> strength = number_from(k.strength, "strength"))
    {
        options.embed.strength = *strength;
        if (!(options.embed.strength > 0.0))
        {
            throw InvalidOption("strength must be positive, got " +
                                std::string(py::str(k.strength)) + ".");
        }
    }
    options.message = text_from(k.message, "message");
    options.bits_hex = text_from(k.bits, "bits");
    if (options.message && options.bits_hex)
    {
        throw InvalidOption("message and bits both give the payload; pass one of them.");
    }
    options.seed = seed_from(k.seed);
    options.threads = k.threads;
}

DetectFileOptions make_detect_options(const std::string& verdict, double max_fpp, double threshold,
                                      double epsilon, bool allow_registration, py::handle pairs,
                                      bool trace, int threads)
{
    DetectFileOptions options;
    options.decision.verdict = parse_verdict_rule(verdict);
    options.decision.max_false_positive = max_fpp;
    options.decision.threshold = threshold;
    options.decision.epsilon = epsilon;
    options.allow_registration = allow_registration;
    options.trace = trace;
    options.threads = threads;
    if (py::isinstance<py::str>(pairs) || py::hasattr(pairs, "__fspath__"))
    {
        options.pairs = read_point_pairs(pairs.cast<std::filesystem::path>());
    }
    else if (!pairs.is_none())
    {
        options.pairs = pairs_from_array(pairs);
    }
    return options;
}

void bind_memory(py::module_& m)
{
    m.def(
        "embed",
        [](const ArrayLike& V, const OptionalArrayLike& F, const OptionalStr& message,
           const OptionalStr& bits, const OptionalInt& seed, const OptionalFloat& strength,
           std::string rule, std::string strength_measure, std::string basis, std::string centers,
           int basis_size, int coefficients, const Repetitions& repetitions, int first_mode,
           double sigma_factor, std::int64_t gram_rows, int threads, bool report) -> EmbedReturn
        {
            EmbedMeshOptions options;
            fill_embed_options({message.object, bits.object, seed.object, strength.object, rule,
                                strength_measure, basis, centers, basis_size, coefficients,
                                repetitions.object, first_mode, sigma_factor, gram_rows, threads},
                               options);
            TriangleMesh mesh = mesh_from_arrays(V.handle(), F.handle(), "");
            std::optional<EmbedResult> result;
            {
                py::gil_scoped_release release;
                result.emplace(embed(mesh, options));
            }
            py::object marked = to_numpy(std::move(result->positions));
            if (!report)
            {
                return py::make_tuple(result->key, marked);
            }
            nlohmann::json info = embed_stats_json(result->key, result->stats);
            info["vertices"] = mesh.vertex_count();
            info["faces"] = mesh.face_count();
            info["seconds"] = to_json(result->seconds);
            return py::make_tuple(result->key, marked, to_python(info));
        },
        py::arg("V"), py::arg("F") = py::none(), py::kw_only(), py::arg("message") = py::none(),
        py::arg("bits") = py::none(), py::arg("seed") = py::none(),
        py::arg("strength") = py::none(), py::arg("rule") = "additive",
        py::arg("strength_measure") = "surface", py::arg("basis") = "rbf",
        py::arg("centers") = "random", py::arg("basis_size") = EmbedOptions{}.basis_size,
        py::arg("coefficients") = EmbedOptions{}.coefficients, py::arg("repetitions") = "auto",
        py::arg("first_mode") = EmbedOptions{}.first_mode,
        py::arg("sigma_factor") = EmbedOptions{}.sigma_factor,
        py::arg("gram_rows") = EmbedOptions{}.gram_rows, py::arg("threads") = 0,
        py::arg("report") = false, kEmbedDoc);

    py::class_<DetectResult>(
        m, "DetectResult",
        "What detect found: the verdict and its statistics. to_dict() gives the fields "
        "of `meshmark detect --json`.")
        .def_property_readonly(
            "detected", [](const DetectResult& r) { return r.report.detected(); },
            "True when the copy is claimed (with a family key: ownership shown or a "
            "recipient accused; see headline, owner_detected).")
        .def_property_readonly(
            "headline",
            [](const DetectResult& r)
            { return headline(verdict_of(r.report, r.options.max_false_positive)); },
            "The verdict in one sentence: claimed or not, whose copy, and the chance that a mesh "
            "without "
            "the mark gives it (meshmark detect's first line).")
        .def_property_readonly(
            "owner_detected", [](const DetectResult& r) { return r.report.owner_detected; },
            "Whether the owner's claim holds (with a family key: its mark alone or read jointly "
            "with a "
            "recipient's code; docs/fingerprinting.md).")
        .def_property_readonly(
            "recipients",
            [](const DetectResult& r) -> Recipients
            {
                py::list accused;
                for (const RecipientScore& s : r.report.accused)
                {
                    py::dict entry;
                    entry["name"] = s.name;
                    entry["score"] = s.score;
                    entry["false_positive_probability"] = s.false_positive_probability;
                    accused.append(entry);
                }
                return accused;
            },
            "With a family key (meshmark embed --recipient): the accused recipients, strongest "
            "first, as "
            "dicts (name, score, false_positive_probability); empty otherwise.")
        .def_property_readonly("verdict", [](const DetectResult& r)
                               { return std::string(to_string(r.report.decision.verdict)); })
        .def_property_readonly(
            "score", [](const DetectResult& r) { return r.report.decision.score; },
            "z: about sqrt(coefficient_count) for an intact mark, ~N(0,1) without.")
        .def_property_readonly(
            "false_positive_probability",
            [](const DetectResult& r) {
                return verdict_of(r.report, r.options.max_false_positive)
                    .false_positive_probability;
            },
            "Bound on the probability that a mesh without the mark gets this verdict (with a "
            "family key: the strongest accusation's, else the ownership's).")
        .def_property_readonly("score_false_positive_probability", [](const DetectResult& r)
                               { return r.report.decision.score_false_positive_probability; })
        .def_property_readonly("bits_false_positive_probability", [](const DetectResult& r)
                               { return r.report.decision.bits_false_positive_probability; })
        .def_property_readonly(
            "correlation", [](const DetectResult& r) { return r.report.decision.correlation; },
            "R: fraction of the payload bits read back.")
        .def_property_readonly("matches",
                               [](const DetectResult& r) { return r.report.decision.matches; })
        .def_property_readonly("bit_count",
                               [](const DetectResult& r) { return r.report.decision.bit_count; })
        .def_property_readonly("coefficient_count", [](const DetectResult& r)
                               { return r.report.decision.coefficient_count; })
        .def_property_readonly(
            "bits_expected", [](const DetectResult& r) { return r.report.decision.bits_expected; })
        .def_property_readonly("bits_found",
                               [](const DetectResult& r) { return r.report.decision.bits_found; })
        .def_property_readonly("cropped_fraction",
                               [](const DetectResult& r) { return r.report.cropped_fraction; })
        .def_property_readonly(
            "outlier_fraction", [](const DetectResult& r) { return r.report.outlier_fraction; },
            "Fraction of the original's rows left out of the reading because the suspect "
            "is far from them (crops aside): a resampled suspect's surface, or a "
            "vertex-for-vertex suspect's own vertices.")
        .def_property_readonly(
            "alignment", [](const DetectResult& r) { return r.report.registration_method(); },
            "How the suspect was put in correspondence, as the JSON report's "
            "registration.method ('none', 'same-connectivity', 'registration', ...).")
        .def_property_readonly("registration_rms",
                               [](const DetectResult& r) { return r.report.registration_rms; })
        .def_property_readonly(
            "mark_strength", [](const DetectResult& r) { return r.report.mark_strength; },
            "The mark's RMS amplitude over the original's bounding-box diagonal (the key's "
            "strength): registration_rms / mark_strength is how many times further than the "
            "mark the suspect lies from the original.")
        .def_property_readonly(
            "voxel_resolution", [](const DetectResult& r) { return r.report.voxel_resolution; },
            "A voxel-remeshed suspect read beside the original's own voxel remesh: that "
            "remesh's voxels along the original's diagonal; 0 when none was used.")
        .def_property_readonly(
            "is_far_copy", [](const DetectResult& r) { return r.report.is_far_copy(); },
            "Registered and at least 3 times the mark's strength from the original: marked "
            "copies that far are mostly lost, so 'not found' says little about whose copy "
            "it is (docs/robustness.md, \"What an attack leaves of the mark\").")
        .def_property_readonly(
            "transform",
            [](const DetectResult& r)
            {
                py::array_t<double> matrix({4, 4});
                auto out = matrix.mutable_unchecked<2>();
                for (int i = 0; i < 4; ++i)
                {
                    for (int j = 0; j < 4; ++j)
                    {
                        out(i, j) = r.report.transform(i, j);
                    }
                }
                return matrix;
            },
            "4x4 similarity, suspect -> original frame.")
        .def_property_readonly("suspect_vertices",
                               [](const DetectResult& r) { return r.report.suspect_vertices; })
        .def_property_readonly("original_vertices",
                               [](const DetectResult& r) { return r.report.original_vertices; })
        .def(
            "to_dict", [](const DetectResult& r) -> Report { return to_python(r.json()); },
            "The fields of `meshmark detect --json` (with verbose=True, also those of --verbose).")
        .def("__repr__",
             [](const DetectResult& r)
             {
                 const Decision& d = r.report.decision;
                 return std::string("<meshmark.DetectResult detected=") +
                        (r.report.detected() ? "True" : "False") +
                        " score=" + std::to_string(d.score) + " false_positive_probability=" +
                        std::to_string(d.false_positive_probability) + ">";
             });

    m.def(
        "detect",
        [](const ArrayLike& V_suspect, const OptionalArrayLike& F_suspect,
           const ArrayLike& V_original, const OptionalArrayLike& F_original, const Key& key,
           const std::string& verdict, double max_fpp, double threshold, double epsilon,
           bool register_suspect, const Pairs& pairs, bool trace, int threads, bool verbose)
        {
            const DetectFileOptions options =
                make_detect_options(verdict, max_fpp, threshold, epsilon, register_suspect,
                                    pairs.handle(), trace, threads);
            const TriangleMesh suspect =
                mesh_from_arrays(V_suspect.handle(), F_suspect.handle(), "suspect");
            const TriangleMesh original =
                mesh_from_arrays(V_original.handle(), F_original.handle(), "original");
            return detect_result(options, verbose,
                                 [&] { return detect(suspect, original, key, options); });
        },
        py::arg("V_suspect"), py::arg("F_suspect"), py::arg("V_original"), py::arg("F_original"),
        py::arg("key"), py::kw_only(),
        py::arg("verdict") = std::string(to_string(DetectOptions{}.verdict)),
        py::arg("max_fpp") = DetectOptions{}.max_false_positive,
        py::arg("threshold") = DetectOptions{}.threshold,
        py::arg("epsilon") = DetectOptions{}.epsilon, py::arg("register") = true,
        py::arg("pairs") = py::none(), py::arg("trace") = true, py::arg("threads") = 0,
        py::arg("verbose") = false, kDetectDoc);

    m.def(
        "detect_against_file",
        [](const ArrayLike& V_suspect, const OptionalArrayLike& F_suspect,
           const std::filesystem::path& original, const std::filesystem::path& key_path,
           const std::string& verdict, double max_fpp, double threshold, double epsilon,
           bool register_suspect, const Pairs& pairs, bool trace, int threads, bool verbose)
        {
            const DetectFileOptions options =
                make_detect_options(verdict, max_fpp, threshold, epsilon, register_suspect,
                                    pairs.handle(), trace, threads);
            const TriangleMesh suspect =
                mesh_from_arrays(V_suspect.handle(), F_suspect.handle(), "suspect");
            return detect_result(
                options, verbose,
                [&] { return detect_against_file(suspect, original, key_path, options); });
        },
        py::arg("V_suspect"), py::arg("F_suspect"), py::arg("original"), py::arg("key_path"),
        py::kw_only(), py::arg("verdict") = std::string(to_string(DetectOptions{}.verdict)),
        py::arg("max_fpp") = DetectOptions{}.max_false_positive,
        py::arg("threshold") = DetectOptions{}.threshold,
        py::arg("epsilon") = DetectOptions{}.epsilon, py::arg("register") = true,
        py::arg("pairs") = py::none(), py::arg("trace") = true, py::arg("threads") = 0,
        py::arg("verbose") = false, kDetectAgainstFileDoc);

    m.def(
        "attack_mesh",
        [](const ArrayLike& V, const OptionalArrayLike& F, const std::string& spec,
           const SeedInt& seed, int threads) -> MeshArrays
        {
            const auto specs = parse_attack_spec(spec);
            const std::uint64_t s = seed_from(seed.handle()).value_or(0);
            const TriangleMesh mesh = mesh_from_arrays(V.handle(), F.handle(), "");
            std::optional<AttackResult> result;
            {
                py::gil_scoped_release release;
                result.emplace(apply_attacks(mesh, specs, s, threads));
            }
            py::object faces = result->mesh.F.rows() == 0 && mesh.F.rows() == 0
                                   ? py::object(py::none())
                                   : py::object(to_numpy(std::move(result->mesh.F)));
            return py::make_tuple(to_numpy(std::move(result->mesh.V)), faces);
        },
        py::arg("V"), py::arg("F"), py::arg("spec"), py::kw_only(), py::arg("seed") = 0,
        py::arg("threads") = 0,
        "Apply an attack chain (the grammar of `meshmark attack --help`, e.g. "
        "'similarity,noise=0.001') "
        "to arrays; returns (V, F) of the attacked mesh (F None for a point cloud). Deterministic "
        "in seed.");
}

}  // namespace meshmark::python

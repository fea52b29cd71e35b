// SPDX-License-Identifier: MIT
// meshmark.Error and its subclasses; meshmark.Key.
#include <chrono>
#include <filesystem>

#include <pybind11/stl.h>

#include "bindings.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"
#include "meshmark/core/file_lock.h"
#include "meshmark/watermark/key.h"
#include "typed.h"

namespace meshmark::python
{

void bind_errors(py::module_& m)
{
    // pybind11 tries translators newest first, so the base class is registered first.
    auto& error = py::register_exception<Error>(m, "Error");
    error.attr("__doc__") =
        "Base of every meshmark error; str(e) is the one-sentence message the meshmark "
        "program prints.";
    auto& io_error = py::register_exception<IoError>(m, "IoError", error.ptr());
    io_error.attr("__doc__") =
        "A file could not be opened, read, parsed or written, or an original is not "
        "the key's (the program's exit code 3).";
    auto& invalid_mesh = py::register_exception<InvalidMesh>(m, "InvalidMesh", error.ptr());
    invalid_mesh.attr("__doc__") =
        "The mesh or array is unusable: wrong shape or dtype, non-finite coordinates, "
        "indices out of range, too few vertices (exit code 3).";
    auto& invalid_option = py::register_exception<InvalidOption>(m, "InvalidOption", error.ptr());
    invalid_option.attr("__doc__") =
        "An option is out of its range or conflicts with another (exit code 2).";
    auto& numerical_error =
        py::register_exception<NumericalError>(m, "NumericalError", error.ptr());
    numerical_error.attr("__doc__") =
        "A factorization failed, e.g. a degenerate basis (exit code 4).";
}

void bind_key(py::module_& m)
{
    py::class_<Key>(
        m, "Key",
        "A watermark key: the secret seed, the parameters, the payload and the fingerprint of "
        "the original mesh. With the original it regenerates and detects the mark; the same "
        "JSON file as the meshmark program's --key.")
        .def_static(
            "load",
            [](const std::filesystem::path& path)
            {
                py::gil_scoped_release release;
                return read_key(path);
            },
            py::arg("path"),
            "Read a key file (written by Key.save or `meshmark embed`). Raises IoError.")
        .def(
            "save",
            [](const Key& key, const std::filesystem::path& path, bool force, double lock_timeout)
            {
                if (!(lock_timeout >= 0.0))
                {
                    throw InvalidOption("lock_timeout must be >= 0 seconds.");
                }
                py::gil_scoped_release release;
                // The check and the write as one step: two saves to one new path cannot both
                // succeed.
                create_parent_directories(path);
                const FileLock lock =
                    lock_file(path, {.timeout = std::chrono::milliseconds(
                                         static_cast<std::int64_t>(1000.0 * lock_timeout))});
                if (!force && std::filesystem::exists(path))
                {
                    throw InvalidOption(
                        path.string() +
                        ": a key file already exists there; it may be the only proof for "
                        "copies marked earlier. Choose another path or pass force=True.");
                }
                write_key(path, key);
            },
            py::arg("path"), py::kw_only(), py::arg("force") = false,
            py::arg("lock_timeout") = std::chrono::duration<double>(kDefaultLockTimeout).count(),
            "Write the key file atomically and durably, mode 0600 (what `meshmark detect --key` "
            "reads), its "
            "folder created if missing. Refuses (InvalidOption) to replace an existing file unless "
            "force=True; "
            "waits up to lock_timeout seconds while another call writes the same key.")
        .def_static(
            "from_json", [](const std::string& text) { return parse_key(text, "key text"); },
            py::arg("text"),
            "A key from its JSON text (Key.to_json). Raises IoError when malformed or tampered "
            "with.")
        .def(
            "to_json", [](const Key& key) { return to_json(key); }, "The key file's JSON text.")
        .def_property_readonly(
            "seed", [](const Key& k) { return k.seed; }, "The secret seed.")
        .def_property_readonly(
            "message", [](const Key& k) { return k.message; },
            "The text the payload came from, or None.")
        .def_property_readonly(
            "bits", [](const Key& k) { return to_hex(k.payload); },
            "The payload as hex digits (the `bits=` of embed).")
        .def_property_readonly(
            "payload", [](const Key& k) { return to_bit_string(k.payload); },
            "The payload as a string of '0' and '1' (3m bits).")
        .def_property_readonly("rule",
                               [](const Key& k) { return std::string(to_string(k.options.rule)); })
        .def_property_readonly(
            "strength", [](const Key& k) { return k.options.strength; },
            "The strength used (the rule's default resolved), in strength_measure.")
        .def_property_readonly(
            "strength_measure",
            [](const Key& k) { return std::string(to_string(k.options.measure)); },
            "'surface' (RMS surface distance) or 'vertex' (RMS vertex displacement).")
        .def_property_readonly(
            "vertex_strength", [](const Key& k) { return k.options.modulation_strength(); },
            "The RMS vertex displacement / principal diagonal the mark was built with "
            "(the surface measure's calibration on the original).")
        .def_property_readonly("basis",
                               [](const Key& k) { return std::string(to_string(k.options.basis)); })
        .def_property_readonly(
            "centers", [](const Key& k) { return std::string(to_string(k.options.centers)); })
        .def_property_readonly("basis_size", [](const Key& k) { return k.options.basis_size; })
        .def_property_readonly("coefficients", [](const Key& k) { return k.options.coefficients; })
        .def_property_readonly("repetitions", [](const Key& k) { return k.options.repetitions; })
        .def_property_readonly("first_mode", [](const Key& k) { return k.options.first_mode; })
        .def_property_readonly("sigma_factor", [](const Key& k) { return k.options.sigma_factor; })
        .def_property_readonly("gram_rows", [](const Key& k) { return k.options.gram_rows; })
        .def_property_readonly(
            "original_vertices", [](const Key& k) { return k.original.vertex_count; },
            "Vertex count of the original the key was made for.")
        .def_property_readonly(
            "original_faces", [](const Key& k) { return k.original.face_count; },
            "Face count of the original the key was made for.")
        .def("__eq__", [](const Key& a, const Key& b) { return to_json(a) == to_json(b); })
        .def("__repr__",
             [](const Key& k)
             {
                 return "<meshmark.Key seed=" + std::to_string(k.seed) +
                        " bits=" + to_hex(k.payload) + " rule=" + to_string(k.options.rule) +
                        " original=" + std::to_string(k.original.vertex_count) + " vertices>";
             });
}

}  // namespace meshmark::python

// SPDX-License-Identifier: MIT
#pragma once

// The parts of the extension module _meshmark, one function per source file.

#include <chrono>

#include <pybind11/pybind11.h>

#include "meshmark/catalog/catalog_add.h"
#include "meshmark/pipeline/detect_file.h"
#include "meshmark/pipeline/embed_file.h"
#include "typed.h"

namespace meshmark::python
{

namespace py = pybind11;

/// The embed keywords shared by embed() and embed_file() (everything but the files').
struct EmbedKeywords
{
    py::object message, bits, seed, strength;
    std::string rule, strength_measure, basis, centers;
    int basis_size, coefficients;
    py::object repetitions;  ///< "auto" or an int >= 1
    int first_mode;
    double sigma_factor;
    std::int64_t gram_rows;
    int threads;
};

/// \brief The library's options from the keywords (the CLI's parsing of the same flags).
/// \throws InvalidOption for unknown names or out-of-range values.
void fill_embed_options(const EmbedKeywords& keywords, EmbedMeshOptions& options);

/// \brief The detect keywords shared by detect() and detect_file().
/// \p pairs: None, a point-pair file (the CLI's --pairs) or a (k, 6) array of suspect and
/// original points. \p trace false: the CLI's --no-trace.
DetectFileOptions make_detect_options(const std::string& verdict, double max_fpp, double threshold,
                                      double epsilon, bool allow_registration, py::handle pairs,
                                      bool trace, int threads);

/// A lock timeout in seconds (lock_timeout=). \throws InvalidOption when negative.
std::chrono::milliseconds timeout_of(double seconds);

/// \brief catalog add's options from the keywords Catalog.add and meshmark.cluster share.
/// \throws InvalidOption for out-of-range values.
CatalogAddOptions catalog_add_options(const OptionalInt& seed, const OptionalFloat& strength,
                                      const OptionalStr& message, int basis_size, int coefficients,
                                      bool force);

void bind_errors(py::module_& m);
void bind_key(py::module_& m);
void bind_memory(py::module_& m);   ///< embed, detect, DetectResult, attack_mesh
void bind_files(py::module_& m);    ///< read_mesh, write_mesh, embed_file, detect_file, attack
void bind_compare(py::module_& m);  ///< compare (and its heatmap)
void bind_catalog(py::module_& m);  ///< Catalog
void bind_cluster(py::module_& m);  ///< catalog add's steps for meshmark.cluster

}  // namespace meshmark::python

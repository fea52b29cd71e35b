// SPDX-License-Identifier: MIT
#pragma once

// numpy arrays, Python values and paths to and from the library's types, for the bindings.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "meshmark/core/length_unit.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark::python
{

namespace py = pybind11;

/// \brief A mesh from an (n, 3) array of positions and an (m, 3) array of vertex indices, or
/// None for a point cloud. Anything numpy can make an array of is accepted; the positions are
/// converted to float64 and the indices to int32, checked on the way.
/// \param what  Names the mesh in error messages ("V_suspect", ...).
/// \throws InvalidMesh for a wrong shape or dtype, non-finite coordinates, negative or
/// out-of-range indices.
[[nodiscard]] TriangleMesh mesh_from_arrays(py::handle positions, py::handle faces,
                                            const std::string& what);

/// \brief The positions as an (n, 3) float64 array that takes ownership of them (no copy).
[[nodiscard]] py::array_t<double> to_numpy(Positions&& positions);
/// \brief The faces as an (m, 3) int32 array that takes ownership of them (no copy).
[[nodiscard]] py::array_t<std::int32_t> to_numpy(Faces&& faces);

/// A JSON value as the Python value json.loads would give.
[[nodiscard]] py::object to_python(const nlohmann::json& value);

/// \brief A seed from a Python int (None = absent).
/// \throws InvalidOption unless it is in [0, 2^64).
[[nodiscard]] std::optional<std::uint64_t> seed_from(py::handle seed, const char* name = "seed");

/// \brief A text from a Python str (None = absent).
/// \throws InvalidOption naming \p name for any other type.
[[nodiscard]] std::optional<std::string> text_from(py::handle value, const char* name);

/// \brief A real number from anything Python converts to a float (None = absent).
/// \throws InvalidOption naming \p name for anything else (pybind11 would raise RuntimeError).
[[nodiscard]] std::optional<double> number_from(py::handle value, const char* name);

/// \brief A length from a str such as "0.05mm" (parse_length) or a number in the coordinates'
/// unit (None = absent).
/// \throws InvalidOption naming \p name for another type or a text parse_length refuses.
[[nodiscard]] std::optional<Length> length_from(py::handle value, const char* name);

/// \brief A path from a str or an os.PathLike (None = absent).
/// \throws InvalidOption naming \p name for any other type.
[[nodiscard]] std::optional<std::filesystem::path> path_from(py::handle value, const char* name);

}  // namespace meshmark::python

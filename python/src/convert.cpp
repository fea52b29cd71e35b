// SPDX-License-Identifier: MIT
#include "convert.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "meshmark/core/error.h"
#include "typed.h"

namespace meshmark::python
{
namespace
{

std::string shape_text(const py::array& array)
{
    std::string text = "(";
    for (py::ssize_t d = 0; d < array.ndim(); ++d)
    {
        text += (d ? ", " : "") + std::to_string(array.shape(d));
    }
    return text + (array.ndim() == 1 ? ",)" : ")");
}

// numpy's view of \p object, or an InvalidMesh naming \p what when numpy cannot make one.
py::array as_array(py::handle object, const std::string& what, const char* expected)
{
    py::array array = py::array::ensure(object);
    if (!array)
    {
        throw InvalidMesh(what + ": expected " + expected + ", got a " +
                          std::string(py::str(py::type::handle_of(object).attr("__name__"))) + ".");
    }
    if (array.ndim() != 2 || array.shape(1) != 3)
    {
        throw InvalidMesh(what + ": expected " + expected + ", got an array of shape " +
                          shape_text(array) + ".");
    }
    return array;
}

Positions positions_from(py::handle object, const std::string& what)
{
    constexpr const char* expected = "an (n, 3) array of vertex positions";
    if (object.is_none())
    {
        throw InvalidMesh(what + ": expected " + expected + ", got None.");
    }
    const py::array array = as_array(object, what, expected);
    const char kind = array.dtype().kind();
    if (kind != 'f' && kind != 'i' && kind != 'u')
    {
        throw InvalidMesh(what + ": expected real coordinates, got dtype " +
                          std::string(py::str(array.dtype())) + ".");
    }
    // No copy here when the array already is C-contiguous float64; the one copy is into the mesh.
    using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
    const Doubles doubles = Doubles::ensure(array);
    if (!doubles)
    {
        throw InvalidMesh(what + ": its coordinates cannot be converted to float64.");
    }
    Positions positions(doubles.shape(0), 3);
    if (positions.size() > 0)
    {
        std::memcpy(positions.data(), doubles.data(),
                    sizeof(double) * static_cast<std::size_t>(positions.size()));
    }
    return positions;
}

Faces faces_from(py::handle object, Eigen::Index vertex_count, const std::string& what)
{
    if (object.is_none())
    {
        return Faces(0, 3);
    }
    const py::array array = as_array(object, what, "an (m, 3) array of vertex indices, or None");
    const char kind = array.dtype().kind();
    if (kind != 'i' && kind != 'u')
    {
        throw InvalidMesh(what + ": expected integer vertex indices, got dtype " +
                          std::string(py::str(array.dtype())) + ".");
    }
    if (kind == 'u' && array.itemsize() == 8)
    {
        // uint64 indices beyond int64 would wrap in the conversion below; none can be in range.
        const auto unsigned_indices =
            py::array_t<std::uint64_t, py::array::c_style | py::array::forcecast>::ensure(array);
        const std::uint64_t* data = unsigned_indices.data();
        for (py::ssize_t i = 0; i < unsigned_indices.size(); ++i)
        {
            if (data[i] >= static_cast<std::uint64_t>(vertex_count))
            {
                throw InvalidMesh(what + ": face " + std::to_string(i / 3) + " uses vertex " +
                                  std::to_string(data[i]) + ", but there are " +
                                  std::to_string(vertex_count) + " vertices.");
            }
        }
    }
    const auto indices =
        py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(array);
    Faces faces(indices.shape(0), 3);
    const std::int64_t* data = indices.data();
    for (py::ssize_t i = 0; i < indices.size(); ++i)
    {
        if (data[i] < 0 || data[i] >= vertex_count)
        {
            throw InvalidMesh(what + ": face " + std::to_string(i / 3) + " uses vertex " +
                              std::to_string(data[i]) + ", but indices must be in [0, " +
                              std::to_string(vertex_count) + ").");
        }
        faces.data()[i] = static_cast<std::int32_t>(data[i]);
    }
    return faces;
}

}  // namespace

TriangleMesh mesh_from_arrays(py::handle positions, py::handle faces, const std::string& what)
{
    const std::string v_name = "V" + (what.empty() ? std::string() : "_" + what);
    const std::string f_name = "F" + (what.empty() ? std::string() : "_" + what);
    TriangleMesh mesh;
    mesh.V = positions_from(positions, v_name);
    mesh.F = faces_from(faces, mesh.V.rows(), f_name);
    validate(mesh, v_name.c_str());  // non-finite coordinates
    return mesh;
}

py::array_t<double> to_numpy(Positions&& positions)
{
    auto* owned = new Positions(std::move(positions));
    py::capsule owner(owned, [](void* p) { delete static_cast<Positions*>(p); });
    return py::array_t<double>(
        {owned->rows(), Eigen::Index{3}},
        {static_cast<py::ssize_t>(3 * sizeof(double)), static_cast<py::ssize_t>(sizeof(double))},
        owned->data(), owner);
}

py::array_t<std::int32_t> to_numpy(Faces&& faces)
{
    auto* owned = new Faces(std::move(faces));
    py::capsule owner(owned, [](void* p) { delete static_cast<Faces*>(p); });
    return py::array_t<std::int32_t>({owned->rows(), Eigen::Index{3}},
                                     {static_cast<py::ssize_t>(3 * sizeof(std::int32_t)),
                                      static_cast<py::ssize_t>(sizeof(std::int32_t))},
                                     owned->data(), owner);
}

py::object to_python(const nlohmann::json& value)
{
    switch (value.type())
    {
        case nlohmann::json::value_t::null:
            return py::none();
        case nlohmann::json::value_t::boolean:
            return py::bool_(value.get<bool>());
        case nlohmann::json::value_t::number_integer:
            return py::int_(value.get<std::int64_t>());
        case nlohmann::json::value_t::number_unsigned:
            return py::int_(value.get<std::uint64_t>());
        case nlohmann::json::value_t::number_float:
            return py::float_(value.get<double>());
        case nlohmann::json::value_t::string:
            return py::str(value.get_ref<const std::string&>());
        case nlohmann::json::value_t::array:
        {
            py::list list;
            for (const auto& item : value)
            {
                list.append(to_python(item));
            }
            return std::move(list);
        }
        case nlohmann::json::value_t::object:
        {
            py::dict dict;
            for (const auto& [key, item] : value.items())
            {
                dict[py::str(key)] = to_python(item);
            }
            return std::move(dict);
        }
        default:
            return py::none();
    }
}

std::optional<std::uint64_t> seed_from(py::handle seed, const char* name)
{
    if (seed.is_none())
    {
        return std::nullopt;
    }
    if (!py::isinstance<py::int_>(seed) || py::isinstance<py::bool_>(seed))
    {
        throw InvalidOption(std::string(name) + " must be an integer in [0, 2^64), got a " +
                            std::string(py::str(py::type::handle_of(seed).attr("__name__"))) + ".");
    }
    const py::int_ value = py::reinterpret_borrow<py::int_>(seed);
    if (value < py::int_(0) || value > py::int_(std::numeric_limits<std::uint64_t>::max()))
    {
        throw InvalidOption(std::string(name) + " must be in [0, 2^64), got " +
                            std::string(py::str(seed)) + ".");
    }
    return value.cast<std::uint64_t>();
}

std::optional<std::string> text_from(py::handle value, const char* name)
{
    if (value.is_none())
    {
        return std::nullopt;
    }
    if (!py::isinstance<py::str>(value))
    {
        throw InvalidOption(std::string(name) + " must be a str or None, got a " +
                            std::string(py::str(py::type::handle_of(value).attr("__name__"))) +
                            ".");
    }
    return value.cast<std::string>();
}

std::optional<std::filesystem::path> path_from(py::handle value, const char* name)
{
    if (value.is_none())
    {
        return std::nullopt;
    }
    if (!py::isinstance<py::str>(value) && !py::hasattr(value, "__fspath__"))
    {
        throw InvalidOption(std::string(name) + " must be a str, an os.PathLike or None, got a " +
                            std::string(py::str(py::type::handle_of(value).attr("__name__"))) +
                            ".");
    }
    return value.cast<std::filesystem::path>();
}

std::optional<double> number_from(py::handle value, const char* name)
{
    if (value.is_none())
    {
        return std::nullopt;
    }
    try
    {
        return value.cast<double>();  // what converts to a float (numpy scalars included)
    }
    catch (const py::cast_error&)
    {
        throw InvalidOption(std::string(name) + " must be a number or None, got a " +
                            std::string(py::str(py::type::handle_of(value).attr("__name__"))) +
                            ".");
    }
}

std::optional<Length> length_from(py::handle value, const char* name)
{
    if (value.is_none())
    {
        return std::nullopt;
    }
    if (py::isinstance<py::str>(value))
    {
        return parse_length(value.cast<std::string>(), name);
    }
    double number = 0.0;
    try
    {
        number = value.cast<double>();
    }
    catch (const py::cast_error&)
    {
        throw InvalidOption(
            std::string(name) + " must be a length such as '0.05mm', a number or None, got a " +
            std::string(py::str(py::type::handle_of(value).attr("__name__"))) + ".");
    }
    if (!(std::isfinite(number) && number > 0.0))
    {
        throw InvalidOption(std::string(name) + " must be a positive length, got " +
                            std::string(py::str(value)) + ".");
    }
    return Length{number, std::nullopt};
}

}  // namespace meshmark::python

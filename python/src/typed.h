// SPDX-License-Identifier: MIT
#pragma once

// The types the extension's signatures show (help(), __doc__'s first line, the stubs in
// meshmark/_meshmark.pyi): pybind11 2.10 would show `handle` or `object` for arguments taken
// as they come and checked by the bindings themselves (arrays, seeds, optional values: their
// errors are meshmark's, naming the argument), and `os.PathLike` for paths that also accept a
// str. Every source of the extension includes this header, never <pybind11/stl/filesystem.h>:
// one caster of paths for the whole module.

#include <filesystem>
#include <string>
#include <type_traits>

#include <pybind11/pybind11.h>

namespace meshmark::python
{

namespace py = pybind11;

/// \brief A Python value taken as it is, whatever its type, shown as Tag::name in signatures.
/// The binding checks it (with meshmark's errors); nothing is converted on the way in or out.
template <class Tag>
struct Loose
{
    py::object object;
    Loose() = default;
    // NOLINTNEXTLINE(google-explicit-constructor): returned from the bindings as it is
    Loose(py::object o) : object(std::move(o)) {}
    [[nodiscard]] py::handle handle() const { return object; }
};

// The names (valid Python annotations, the stubs' spelling).
#define MESHMARK_PY_TYPE_NAME(NAME, TEXT)                                \
    struct NAME##Tag                                                     \
    {                                                                    \
        static constexpr auto name = pybind11::detail::const_name(TEXT); \
    };                                                                   \
    using NAME = Loose<NAME##Tag>;

MESHMARK_PY_TYPE_NAME(ArrayLike, "numpy.typing.ArrayLike")
MESHMARK_PY_TYPE_NAME(OptionalArrayLike, "numpy.typing.ArrayLike | None")
MESHMARK_PY_TYPE_NAME(OptionalInt, "int | None")
MESHMARK_PY_TYPE_NAME(SeedInt, "int")
MESHMARK_PY_TYPE_NAME(OptionalStr, "str | None")
MESHMARK_PY_TYPE_NAME(OptionalFloat, "float | None")
MESHMARK_PY_TYPE_NAME(Repetitions, "int | str")
MESHMARK_PY_TYPE_NAME(Pairs, "str | os.PathLike | numpy.typing.ArrayLike | None")
MESHMARK_PY_TYPE_NAME(LengthArg, "str | float | None")
MESHMARK_PY_TYPE_NAME(OptionalPath, "str | os.PathLike | None")
MESHMARK_PY_TYPE_NAME(Report, "dict[str, typing.Any]")
MESHMARK_PY_TYPE_NAME(OptionalClient, "distributed.Client | None")
MESHMARK_PY_TYPE_NAME(ReportList, "list[dict[str, typing.Any]]")
MESHMARK_PY_TYPE_NAME(MeshArrays,
                      "tuple[numpy.typing.NDArray[numpy.float64], "
                      "numpy.typing.NDArray[numpy.int32] | None]")
MESHMARK_PY_TYPE_NAME(EmbedReturn,
                      "tuple[Key, numpy.typing.NDArray[numpy.float64]] | "
                      "tuple[Key, numpy.typing.NDArray[numpy.float64], dict[str, typing.Any]]")
MESHMARK_PY_TYPE_NAME(Recipients, "list[dict[str, typing.Any]]")
MESHMARK_PY_TYPE_NAME(PathlibPath, "pathlib.Path")

#undef MESHMARK_PY_TYPE_NAME

}  // namespace meshmark::python

namespace pybind11::detail
{

template <class Tag>
struct type_caster<meshmark::python::Loose<Tag>>
{
    PYBIND11_TYPE_CASTER(meshmark::python::Loose<Tag>, Tag::name);
    bool load(handle source, bool /*convert*/)
    {
        value.object = reinterpret_borrow<object>(source);
        return true;
    }
    static handle cast(const meshmark::python::Loose<Tag>& source, return_value_policy /*policy*/,
                       handle /*parent*/)
    {
        return source.object.inc_ref();
    }
};

/// std::filesystem::path from a str or an os.PathLike (os.fspath), to a pathlib.Path: pybind11's
/// own caster (pybind11/stl/filesystem.h), under the name of what it accepts.
template <>
struct type_caster<std::filesystem::path>
{
    PYBIND11_TYPE_CASTER(std::filesystem::path, const_name("str | os.PathLike"));
    static handle cast(const std::filesystem::path& path, return_value_policy /*policy*/,
                       handle /*parent*/)
    {
        const std::string& native = path.native();
        if (PyObject* text =
                PyUnicode_DecodeFSDefaultAndSize(native.c_str(), ssize_t(native.size())))
        {
            return module_::import("pathlib")
                .attr("Path")(reinterpret_steal<object>(text))
                .release();
        }
        return nullptr;
    }
    bool load(handle source, bool /*convert*/)
    {
        PyObject* buffer = PyOS_FSPath(source.ptr());
        if (!buffer)
        {
            PyErr_Clear();
            return false;
        }
        PyObject* native = nullptr;
        if (PyUnicode_FSConverter(buffer, &native) != 0)
        {
            if (const char* text = PyBytes_AsString(native))
            {
                value = text;
            }
        }
        Py_XDECREF(native);
        Py_DECREF(buffer);
        if (PyErr_Occurred())
        {
            PyErr_Clear();
            return false;
        }
        return true;
    }
};

}  // namespace pybind11::detail

// SPDX-License-Identifier: MIT
// 3MF internals shared by the reader (three_mf_read.cpp) and the writers
// (three_mf_write.cpp): the model XML vocabulary matched through pugixml
// (three_mf_xml.cpp) and the package of model parts in a zip archive (three_mf_package.cpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <pugixml.hpp>

#include "meshmark/core/error.h"
#include "support.h"
#include "zip_archive.h"

namespace meshmark::detail
{

inline constexpr std::string_view kCoreNamespace =
    "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
/// The vertex attributes of the three axes.
inline constexpr std::array<const char*, 3> kAxes = {"x", "y", "z"};

// ---------------------------------------------------------------------------------------
// XML names. pugixml does not resolve namespaces, so elements are matched by local name and
// the namespace their prefix is bound to (xmlns declarations on the element or an ancestor).

[[nodiscard]] inline std::string_view local_name(std::string_view qualified)
{
    const auto colon = qualified.find(':');
    return colon == std::string_view::npos ? qualified : qualified.substr(colon + 1);
}

[[nodiscard]] inline std::string_view prefix_of(std::string_view qualified)
{
    const auto colon = qualified.find(':');
    return colon == std::string_view::npos ? std::string_view() : qualified.substr(0, colon);
}

[[nodiscard]] inline bool declares_namespaces(pugi::xml_node node)
{
    for (const auto attribute : node.attributes())
    {
        if (std::string_view(attribute.name()).starts_with("xmlns"))
        {
            return true;
        }
    }
    return false;
}

/// The namespace bound to \p prefix ("" for the default namespace) at \p node.
[[nodiscard]] std::string_view namespace_of(pugi::xml_node node, std::string_view prefix);

/// Whether \p node is the element \p ns : \p local.
[[nodiscard]] bool is_element(pugi::xml_node node, std::string_view ns, std::string_view local);

/// The children of one element that are ns:local, resolving each distinct qualified name once
/// (a <vertices> element has millions of <vertex> children); a child that declares namespaces
/// itself is resolved on its own.
class ChildFilter
{
public:
    ChildFilter(pugi::xml_node parent, std::string_view ns, std::string_view local)
        : parent_(parent), ns_(ns), local_(local)
    {
    }
    bool operator()(pugi::xml_node child)
    {
        if (child.type() != pugi::node_element)
        {
            return false;
        }
        const std::string_view name = child.name();
        if (local_name(name) != local_)
        {
            return false;
        }
        if (declares_namespaces(child))
        {
            return namespace_of(child, prefix_of(name)) == ns_;
        }
        if (name != last_name_)
        {
            last_name_ = name;
            last_match_ = namespace_of(parent_, prefix_of(name)) == ns_;
        }
        return last_match_;
    }

private:
    pugi::xml_node parent_;
    std::string_view ns_;
    std::string_view local_;
    std::string_view last_name_;
    bool last_match_ = false;
};

/// The first child of \p parent that is the core element \p local, or null.
[[nodiscard]] pugi::xml_node first_child(pugi::xml_node parent, std::string_view local);

/// The p:path attribute of an <item> or <component> (production extension), or null.
[[nodiscard]] pugi::xml_attribute production_path(pugi::xml_node node);

/// An attribute value without the white space XML Schema collapses around numbers.
[[nodiscard]] inline std::string_view trimmed(const char* value)
{
    std::string_view text(value);
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t' || text.front() == '\n' ||
                             text.front() == '\r'))
    {
        text.remove_prefix(1);
    }
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\n' ||
                             text.back() == '\r'))
    {
        text.remove_suffix(1);
    }
    return text;
}

/// A resource id (an unsigned 32-bit integer) from attribute text; false when it is none.
[[nodiscard]] bool parse_id(const char* value, std::uint32_t& id);

/// \brief The "transform" attribute of \p node (identity when absent) as a 4x4 matrix for
/// column vectors; \p what names the node in errors.
[[nodiscard]] Eigen::Matrix4d parse_transform(const std::filesystem::path& path,
                                              pugi::xml_node node, const std::string& what);

/// Coordinate \p axis of <vertex> \p i of \p object (named in errors).
[[nodiscard]] double parse_coordinate(const std::filesystem::path& path, pugi::xml_node vertex,
                                      int axis, std::size_t i, const std::string& object);

/// Calls f(i, <vertex>) for vertex i of the <mesh> \p mesh, in file order.
template <typename F>
void for_each_vertex(pugi::xml_node mesh, F&& f)
{
    const auto vertices = first_child(mesh, "vertices");
    ChildFilter is_vertex(vertices, kCoreNamespace, "vertex");
    std::size_t i = 0;
    for (const auto vertex : vertices.children())
    {
        if (is_vertex(vertex))
        {
            f(i++, vertex);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Package parts.

/// The zip entry name of OPC part \p target, relative to the part \p source_name (a zip entry
/// name; "" for the package root).
[[nodiscard]] std::string part_entry_name(std::string_view target, std::string_view source_name);

/// One model part, parsed in place: the DOM's strings point into \p buffer, a copy of the
/// part's text, at the same offsets as in the text (pugixml's in-situ parsing shortens values
/// that hold escapes or line breaks in place but never moves where a value starts).
struct ModelPart
{
    std::string name;    // zip entry name
    std::string text;    // the part as stored
    std::string buffer;  // what pugixml parsed in place
    pugi::xml_document document;
    pugi::xml_node model;
    std::map<std::uint32_t, pugi::xml_node> objects;  // <object> by id
    std::vector<std::uint32_t> object_order;          // ids in document order
};

/// "object <id> in <part>", for messages.
[[nodiscard]] std::string describe(const ModelPart& part, std::uint32_t id);

/// The zip archive and its model parts, each read and parsed on first use.
class Package
{
public:
    Package(const std::filesystem::path& path, const std::string& bytes)
        : path_(path), zip_(path, bytes)
    {
    }

    /// The root model part: the target of the 3D model relationship in _rels/.rels.
    ModelPart& root();

    /// Model part \p name (a zip entry name, any ASCII case), which \p referrer refers to.
    ModelPart& part(const std::string& name, const std::string& referrer);

    [[nodiscard]] const std::vector<std::unique_ptr<ModelPart>>& parts() const { return parts_; }

private:
    const std::filesystem::path& path_;
    ZipArchive zip_;
    std::vector<std::unique_ptr<ModelPart>> parts_;
    std::uint64_t model_bytes_ = 0;
};

/// pugixml and libzip report failures as results; a std::bad_alloc or similar from a hostile
/// package becomes one IoError naming the file.
template <typename F>
auto guarded(const std::filesystem::path& path, F&& body)
{
    try
    {
        return body();
    }
    catch (const Error&)
    {
        throw;
    }
    catch (const std::exception& e)
    {
        fail_io(path, std::string("not a valid 3MF package: ") + e.what());
    }
}

}  // namespace meshmark::detail

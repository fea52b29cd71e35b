// SPDX-License-Identifier: MIT
// The 3MF model XML vocabulary: namespace-aware element and attribute matching over
// pugixml (which does not resolve namespaces), resource ids, transforms and vertex
// coordinates as the core specification writes them.
#include <cstdint>

#include "io/detail/numbers.h"
#include "io/detail/three_mf.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

constexpr std::string_view kProductionNamespace =
    "http://schemas.microsoft.com/3dmanufacturing/production/2015/06";

}  // namespace

std::string_view namespace_of(pugi::xml_node node, std::string_view prefix)
{
    for (; node; node = node.parent())
    {
        for (const auto attribute : node.attributes())
        {
            const std::string_view name = attribute.name();
            if (prefix.empty() ? name == "xmlns"
                               : name.starts_with("xmlns:") && name.substr(6) == prefix)
            {
                return attribute.value();
            }
        }
    }
    return {};
}

bool is_element(pugi::xml_node node, std::string_view ns, std::string_view local)
{
    return node.type() == pugi::node_element && local_name(node.name()) == local &&
           namespace_of(node, prefix_of(node.name())) == ns;
}

pugi::xml_node first_child(pugi::xml_node parent, std::string_view local)
{
    ChildFilter is_wanted(parent, kCoreNamespace, local);
    for (const auto child : parent.children())
    {
        if (is_wanted(child))
        {
            return child;
        }
    }
    return {};
}

pugi::xml_attribute production_path(pugi::xml_node node)
{
    for (const auto attribute : node.attributes())
    {
        const std::string_view name = attribute.name();
        if (local_name(name) == "path" && !prefix_of(name).empty() &&
            namespace_of(node, prefix_of(name)) == kProductionNamespace)
        {
            return attribute;
        }
    }
    return {};
}

bool parse_id(const char* value, std::uint32_t& id)
{
    std::int64_t parsed = 0;
    if (!parse_integer(trimmed(value), parsed) || parsed < 0 || parsed > 0xffffffffLL)
    {
        return false;
    }
    id = static_cast<std::uint32_t>(parsed);
    return true;
}

// The 3MF transform "m00 m01 m02 m10 m11 m12 m20 m21 m22 m30 m31 m32" is a 4x3 matrix for
// row vectors (p' = [p 1] M); as a 4x4 matrix for column vectors, column c holds row c of M.
Eigen::Matrix4d parse_transform(const fs::path& path, pugi::xml_node node, const std::string& what)
{
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    const auto attribute = node.attribute("transform");
    if (!attribute)
    {
        return m;
    }
    TokenCursor tokens(attribute.value());
    std::string_view token;
    for (int i = 0; i < 12; ++i)
    {
        double value = 0.0;
        if (!tokens.next(token) || !parse_double(token, value))
        {
            fail_io(path, "the transform of " + what +
                              " is not 12 numbers: " + quoted(attribute.value()));
        }
        m(i % 3, i / 3) = value;
    }
    if (tokens.next(token))
    {
        fail_io(path,
                "the transform of " + what + " is not 12 numbers: " + quoted(attribute.value()));
    }
    return m;
}

double parse_coordinate(const fs::path& path, pugi::xml_node vertex, int axis, std::size_t i,
                        const std::string& object)
{
    const auto attribute = vertex.attribute(kAxes[static_cast<std::size_t>(axis)]);
    double value = 0.0;
    if (!attribute)
    {
        fail_io(path, "vertex " + std::to_string(i) + " of " + object + " has no " +
                          kAxes[static_cast<std::size_t>(axis)] + " coordinate");
    }
    if (!parse_double(trimmed(attribute.value()), value))
    {
        fail_io(path, "vertex " + std::to_string(i) + " of " + object + " has a bad " +
                          kAxes[static_cast<std::size_t>(axis)] + " coordinate " +
                          quoted(attribute.value()));
    }
    return value;
}

}  // namespace meshmark::detail

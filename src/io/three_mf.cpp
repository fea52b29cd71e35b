// SPDX-License-Identifier: MIT
// 3MF packages: the zip container through libzip, the model XML through pugixml. Every mesh
// object reached from the build is read in the build's world frame (build item and component
// transforms, components in other model parts through the production extension's p:path) and
// welded like glTF parts. The preserving writer rewrites only the x/y/z attribute values of
// moved vertices in the model parts' text and replaces those parts in the zip; every other
// entry, and every other byte of the model parts, stays as it was.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>

#include <Eigen/Core>
#include <Eigen/LU>
#include <pugixml.hpp>

#include "io/detail/formats.h"
#include "io/detail/support.h"
#include "io/detail/weld.h"
#include "io/detail/zip_archive.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {
namespace {

namespace fs = std::filesystem;

constexpr std::string_view kCoreNamespace =
    "http://schemas.microsoft.com/3dmanufacturing/core/2015/02";
constexpr std::string_view kProductionNamespace =
    "http://schemas.microsoft.com/3dmanufacturing/production/2015/06";
constexpr std::string_view kModelRelationship =
    "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel";
// Where the 3MF specification puts the root model part; used when _rels/.rels names none.
constexpr std::string_view kDefaultModelPart = "3D/3dmodel.model";

// Component nesting deeper than this (or more object visits) is refused: a reference cycle
// would recurse forever, and a DAG of components can expand exponentially.
constexpr int kMaxComponentDepth = 64;
constexpr std::size_t kMaxObjectVisits = 1U << 20U;
// Zip entries are inflated into memory only up to these declared sizes (zip bombs): one model
// part (~6 million vertices with their triangles as slicers write them), all model parts of a
// package together, and the package relationships.
constexpr std::uint64_t kMaxModelPartBytes = 1ULL << 30U;
constexpr std::uint64_t kMaxModelBytes = 2ULL << 30U;
constexpr std::uint64_t kMaxRelationshipBytes = 16ULL << 20U;

// ---------------------------------------------------------------------------------------
// XML names. pugixml does not resolve namespaces, so elements are matched by local name and
// the namespace their prefix is bound to (xmlns declarations on the element or an ancestor).

std::string_view local_name(std::string_view qualified)
{
    const auto colon = qualified.find(':');
    return colon == std::string_view::npos ? qualified : qualified.substr(colon + 1);
}

std::string_view prefix_of(std::string_view qualified)
{
    const auto colon = qualified.find(':');
    return colon == std::string_view::npos ? std::string_view() : qualified.substr(0, colon);
}

bool declares_namespaces(pugi::xml_node node)
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

// The namespace bound to \p prefix ("" for the default namespace) at \p node.
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

// The children of one element that are ns:local, resolving each distinct qualified name once
// (a <vertices> element has millions of <vertex> children); a child that declares namespaces
// itself is resolved on its own.
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

// The p:path attribute of an <item> or <component> (production extension), or null.
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

// An attribute value without the white space XML Schema collapses around numbers.
std::string_view trimmed(const char* value)
{
    std::string_view text(value);
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t' ||
                             text.front() == '\n' || text.front() == '\r'))
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

// ---------------------------------------------------------------------------------------
// Package parts.

// The zip entry name of OPC part \p target, relative to the part \p source_name (a zip entry
// name; "" for the package root).
std::string part_entry_name(std::string_view target, std::string_view source_name)
{
    if (target.starts_with('/'))
    {
        return std::string(target.substr(1));
    }
    const auto slash = source_name.rfind('/');
    std::string name(slash == std::string_view::npos ? std::string_view()
                                                     : source_name.substr(0, slash + 1));
    name += target;
    return name;
}

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

std::string describe(const ModelPart& part, std::uint32_t id)
{
    return "object " + std::to_string(id) + " in " + part.name;
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

std::unique_ptr<ModelPart> parse_model_part(const fs::path& path, std::string name,
                                            std::string text)
{
    auto part = std::make_unique<ModelPart>();
    part->name = std::move(name);
    part->text = std::move(text);
    part->buffer = part->text;
    const auto result =
        part->document.load_buffer_inplace(part->buffer.data(), part->buffer.size(),
                                           pugi::parse_default, pugi::encoding_utf8);
    if (!result)
    {
        fail_io(path, "the model part " + part->name + " is not well-formed XML: " +
                          result.description() + " at byte " + std::to_string(result.offset));
    }
    part->model = part->document.document_element();
    if (!is_element(part->model, kCoreNamespace, "model"))
    {
        fail_io(path, "the model part " + part->name + " has no 3MF <model> root element");
    }
    ChildFilter is_resources(part->model, kCoreNamespace, "resources");
    for (const auto resources : part->model.children())
    {
        if (!is_resources(resources))
        {
            continue;
        }
        ChildFilter is_object(resources, kCoreNamespace, "object");
        for (const auto object : resources.children())
        {
            if (!is_object(object))
            {
                continue;
            }
            std::uint32_t id = 0;
            if (!parse_id(object.attribute("id").value(), id))
            {
                fail_io(path, "an object in " + part->name + " has a bad id " +
                                  quoted(object.attribute("id").value()));
            }
            if (!part->objects.emplace(id, object).second)
            {
                fail_io(path, describe(*part, id) + " is defined twice");
            }
            part->object_order.push_back(id);
        }
    }
    return part;
}

// The zip archive and its model parts, each read and parsed on first use.
class Package
{
public:
    Package(const fs::path& path, const std::string& bytes) : path_(path), zip_(path, bytes) {}

    /// The root model part: the target of the 3D model relationship in _rels/.rels.
    ModelPart& root()
    {
        std::string name;
        if (const auto rels = zip_.find("_rels/.rels"))
        {
            const std::string text = zip_.read(*rels, kMaxRelationshipBytes);
            pugi::xml_document document;
            const auto result = document.load_buffer(text.data(), text.size(),
                                                     pugi::parse_default, pugi::encoding_utf8);
            if (!result)
            {
                fail_io(path_, std::string("_rels/.rels is not well-formed XML: ") +
                                   result.description() + " at byte " +
                                   std::to_string(result.offset));
            }
            for (const auto relationship : document.document_element().children())
            {
                if (local_name(relationship.name()) == "Relationship" &&
                    trimmed(relationship.attribute("Type").value()) == kModelRelationship)
                {
                    name = part_entry_name(trimmed(relationship.attribute("Target").value()), "");
                    break;
                }
            }
        }
        if (name.empty())
        {
            if (!zip_.find(std::string(kDefaultModelPart)))
            {
                fail_io(path_, "not a valid 3MF package: _rels/.rels names no 3D model part");
            }
            name = kDefaultModelPart;
        }
        return part(name, "_rels/.rels");
    }

    /// Model part \p name (a zip entry name, any ASCII case), which \p referrer refers to.
    ModelPart& part(const std::string& name, const std::string& referrer)
    {
        const auto index = zip_.find(name);
        if (!index)
        {
            fail_io(path_, referrer + " refers to the model part /" + name +
                               ", which is not in the package");
        }
        const std::string entry = zip_.name(*index);
        for (const auto& part : parts_)
        {
            if (part->name == entry)
            {
                return *part;
            }
        }
        const std::uint64_t size = zip_.size(*index);
        if (size <= kMaxModelPartBytes && size > kMaxModelBytes - model_bytes_)
        {
            fail_io(path_, "the model parts declare more than " +
                               std::to_string(kMaxModelBytes) + " uncompressed bytes together");
        }
        model_bytes_ += size;
        parts_.push_back(parse_model_part(path_, entry, zip_.read(*index, kMaxModelPartBytes)));
        return *parts_.back();
    }

    [[nodiscard]] const std::vector<std::unique_ptr<ModelPart>>& parts() const { return parts_; }

private:
    const fs::path& path_;
    ZipArchive zip_;
    std::vector<std::unique_ptr<ModelPart>> parts_;
    std::uint64_t model_bytes_ = 0;
};

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
            fail_io(path, "the transform of " + what + " is not 12 numbers: " +
                              quoted(attribute.value()));
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

// Calls f(i, <vertex>) for vertex i of the <mesh> \p mesh, in file order.
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

constexpr std::array<const char*, 3> kAxes = {"x", "y", "z"};

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

// ---------------------------------------------------------------------------------------
// Reading.

class Reader
{
public:
    Reader(const fs::path& path, Package& package, ThreeMfLayout& layout)
        : path_(path), package_(package), layout_(layout)
    {
    }

    TriangleMesh run()
    {
        // Build items first (their transforms), then mesh objects no build item reaches.
        ModelPart& root = package_.root();
        ChildFilter is_build(root.model, kCoreNamespace, "build");
        std::size_t count = 0;
        for (const auto build : root.model.children())
        {
            if (!is_build(build))
            {
                continue;
            }
            ChildFilter is_item(build, kCoreNamespace, "item");
            for (const auto item : build.children())
            {
                if (!is_item(item))
                {
                    continue;
                }
                const std::string what = "build item " + std::to_string(count++);
                std::uint32_t id = 0;
                if (!parse_id(item.attribute("objectid").value(), id))
                {
                    fail_io(path_, what + " has a bad objectid " +
                                       quoted(item.attribute("objectid").value()));
                }
                visit(referenced_part(root, item, what), id, parse_transform(path_, item, what), 0,
                      "the build");
            }
        }
        // Parts are appended while objects are visited; indices stay valid.
        for (std::size_t p = 0; p < package_.parts().size(); ++p)
        {
            const ModelPart& part = *package_.parts()[p];
            for (const std::uint32_t id : part.object_order)
            {
                const auto mesh = first_child(part.objects.at(id), "mesh");
                if (mesh && slot_.count({&part, id}) == 0)
                {
                    add_mesh(part, id, mesh, Eigen::Matrix4d::Identity());
                }
            }
        }
        return weld();
    }

private:
    // The part an <item> or <component> refers to: its p:path, else the part it is in.
    const ModelPart& referenced_part(const ModelPart& part, pugi::xml_node node,
                                     const std::string& what)
    {
        const auto attribute = production_path(node);
        if (!attribute)
        {
            return part;
        }
        return package_.part(part_entry_name(trimmed(attribute.value()), part.name),
                             what + " in " + part.name);
    }

    void visit(const ModelPart& part, std::uint32_t id, const Eigen::Matrix4d& to_world, int depth,
               const std::string& referrer)
    {
        const std::string object_name = describe(part, id);
        if (depth > kMaxComponentDepth || ++visits_ > kMaxObjectVisits)
        {
            fail_io(path_, "the components of " + object_name +
                               " nest too deeply (a reference cycle?)");
        }
        if (!to_world.allFinite())
        {
            fail_io(path_, object_name + " has a non-finite transform");
        }
        const auto found = part.objects.find(id);
        if (found == part.objects.end())
        {
            fail_io(path_, referrer + " refers to " + object_name + ", which does not exist");
        }
        if (const auto mesh = first_child(found->second, "mesh"); mesh)
        {
            add_mesh(part, id, mesh, to_world);
            return;
        }
        const auto components = first_child(found->second, "components");
        if (!components)
        {
            fail_io(path_, referrer + " refers to " + object_name +
                               ", which is neither a mesh nor a components object");
        }
        ChildFilter is_component(components, kCoreNamespace, "component");
        std::size_t count = 0;
        for (const auto component : components.children())
        {
            if (!is_component(component))
            {
                continue;
            }
            const std::string what = "component " + std::to_string(count++) + " of " + object_name;
            std::uint32_t child = 0;
            if (!parse_id(component.attribute("objectid").value(), child))
            {
                fail_io(path_, what + " has a bad objectid " +
                                   quoted(component.attribute("objectid").value()));
            }
            const Eigen::Matrix4d transform = parse_transform(path_, component, what);
            visit(referenced_part(part, component, what), child, to_world * transform, depth + 1,
                  what);
        }
    }

    void add_mesh(const ModelPart& part, std::uint32_t id, pugi::xml_node mesh,
                  const Eigen::Matrix4d& to_world)
    {
        if (const auto found = slot_.find({&part, id}); found != slot_.end())
        {
            // Another instance: one set of vertices, one displacement (see glTF instancing);
            // under another transform its geometry is kept aside for registration.
            const std::size_t s = found->second;
            if (layout_.objects[s].to_world != to_world &&
                std::abs(to_world.topLeftCorner<3, 3>().determinant()) != 0.0)
            {
                const Eigen::Matrix4d map = to_world * layout_.objects[s].to_world.inverse();
                const std::size_t first = instance_xyz_.size() / 3;
                for (std::size_t e = base_[s]; e < base_[s] + layout_.objects[s].welded.size(); ++e)
                {
                    const Eigen::Vector4d q =
                        map * Eigen::Vector4d(world_[3 * e], world_[3 * e + 1], world_[3 * e + 2], 1.0);
                    instance_xyz_.insert(instance_xyz_.end(), {q.x(), q.y(), q.z()});
                }
                for (std::size_t k = corner_range_[s].first; k < corner_range_[s].second; ++k)
                {
                    instance_corners_.push_back(first + corners_[k] - base_[s]);
                }
            }
            return;
        }
        if (std::abs(to_world.topLeftCorner<3, 3>().determinant()) == 0.0)
        {
            return;  // a singular transform: nothing visible to mark
        }
        const std::string object_name = describe(part, id);
        slot_[{&part, id}] = layout_.objects.size();
        ThreeMfObject object;
        object.part = part.name;
        object.resource_id = id;
        object.to_world = to_world;
        const std::size_t base = group_.size();
        base_.push_back(base);
        const auto group = group_of(to_world);
        for_each_vertex(mesh,
                        [&](std::size_t i, pugi::xml_node vertex)
                        {
                            Eigen::Vector4d local(0.0, 0.0, 0.0, 1.0);
                            for (int d = 0; d < 3; ++d)
                            {
                                local[d] = parse_coordinate(path_, vertex, d, i, object_name);
                            }
                            if (!local.allFinite())
                            {
                                fail_mesh(path_, "vertex " + std::to_string(i) + " of " +
                                                     object_name +
                                                     " has a non-finite coordinate");
                            }
                            const Eigen::Vector4d w = to_world * local;
                            world_.insert(world_.end(), {w.x(), w.y(), w.z()});
                            group_.push_back(group);
                        });
        const std::size_t vertex_count = group_.size() - base;
        object.welded.resize(vertex_count);
        layout_.objects.push_back(std::move(object));

        const auto triangles = first_child(mesh, "triangles");
        ChildFilter is_triangle(triangles, kCoreNamespace, "triangle");
        corner_range_.emplace_back(corners_.size(), corners_.size());
        std::size_t t = 0;
        for (const auto triangle : triangles.children())
        {
            if (!is_triangle(triangle))
            {
                continue;
            }
            for (const char* corner : {"v1", "v2", "v3"})
            {
                const char* value = triangle.attribute(corner).value();
                std::int64_t index = 0;
                if (!parse_integer(trimmed(value), index))
                {
                    fail_io(path_, "triangle " + std::to_string(t) + " of " + object_name +
                                       " has a bad " + corner + " index " + quoted(value));
                }
                if (index < 0 || static_cast<std::uint64_t>(index) >= vertex_count)
                {
                    fail_mesh(path_, "triangle " + std::to_string(t) + " of " + object_name +
                                         " uses vertex index " + std::to_string(index) + " " +
                                         index_range(vertex_count));
                }
                corners_.push_back(base + static_cast<std::size_t>(index));
            }
            ++t;
        }
        corner_range_.back().second = corners_.size();
    }

    std::int32_t group_of(const Eigen::Matrix4d& to_world)
    {
        for (std::size_t g = 0; g < groups_.size(); ++g)
        {
            if (groups_[g] == to_world)
            {
                return static_cast<std::int32_t>(g);
            }
        }
        groups_.push_back(to_world);
        return static_cast<std::int32_t>(groups_.size() - 1);
    }

    TriangleMesh weld()
    {
        if (group_.size() > kMaxVertices)
        {
            fail_io(path_, "the model has more than " + std::to_string(kMaxVertices) + " vertices");
        }
        std::vector<double> xyz;
        const auto welded =
            weld_world_positions(world_, group_, groups_.size(), kCrossTransformWeldRel, xyz);
        for (std::size_t s = 0; s < layout_.objects.size(); ++s)
        {
            auto& object = layout_.objects[s];
            std::copy(welded.begin() + static_cast<std::ptrdiff_t>(base_[s]),
                      welded.begin() + static_cast<std::ptrdiff_t>(base_[s] + object.welded.size()),
                      object.welded.begin());
        }
        if (!instance_xyz_.empty())
        {
            layout_.instances = make_mesh(instance_xyz_, instance_corners_);
        }
        TriangleBuffer triangles;
        triangles.reserve(corners_.size() / 3);
        for (std::size_t t = 0; t + 2 < corners_.size(); t += 3)
        {
            triangles.push(welded[corners_[t]], welded[corners_[t + 1]], welded[corners_[t + 2]]);
        }
        return make_mesh(xyz, triangles);
    }

    const fs::path& path_;
    Package& package_;
    ThreeMfLayout& layout_;
    std::size_t visits_ = 0;
    std::map<std::pair<const ModelPart*, std::uint32_t>, std::size_t> slot_;
    std::vector<std::size_t> base_;
    std::vector<Eigen::Matrix4d> groups_;
    std::vector<double> world_;
    std::vector<std::int32_t> group_;
    std::vector<std::size_t> corners_;
    std::vector<std::pair<std::size_t, std::size_t>> corner_range_;  // per slot, into corners_
    std::vector<double> instance_xyz_;  // other instances, world frame, 3 per point
    std::vector<std::size_t> instance_corners_;
};

// ---------------------------------------------------------------------------------------
// Writing.

// A replacement of text[offset, end) by text.
struct Edit
{
    std::size_t offset = 0;
    std::size_t end = 0;
    std::string text;
};

// [offset, end) of the raw value of \p attribute in part.text: where pugixml's in-place value
// starts, up to the closing quote (an attribute value never holds its own quote character).
std::pair<std::size_t, std::size_t> value_span(const fs::path& path, const ModelPart& part,
                                               pugi::xml_attribute attribute)
{
    const char* value = attribute.value();
    const char* begin = part.buffer.data();
    if (value <= begin || value > begin + part.buffer.size())
    {
        fail_io(path, "cannot locate a coordinate in " + part.name);  // not in the buffer
    }
    const auto offset = static_cast<std::size_t>(value - begin);
    const char quote = part.text[offset - 1];
    const auto end = (quote == '"' || quote == '\'') ? part.text.find(quote, offset)
                                                     : std::string::npos;
    if (end == std::string::npos)
    {
        fail_io(path, "cannot locate a coordinate in " + part.name);
    }
    return {offset, end};
}

// The text of \p part with the moved vertices of \p objects rewritten ("" when none moved).
std::string moved_part_text(const fs::path& path, const ModelPart& part,
                            const std::vector<const ThreeMfObject*>& objects,
                            const Positions& original, const Positions& positions)
{
    std::vector<Edit> edits;
    for (const auto* object : objects)
    {
        const std::string object_name = describe(part, object->resource_id);
        const auto found = part.objects.find(object->resource_id);
        const auto mesh =
            found == part.objects.end() ? pugi::xml_node() : first_child(found->second, "mesh");
        if (!mesh)
        {
            fail_io(path, "the source package no longer has " + object_name);
        }
        const Eigen::Matrix4d to_local = object->to_world.inverse();
        for_each_vertex(
            mesh,
            [&](std::size_t i, pugi::xml_node vertex)
            {
                if (i >= object->welded.size())
                {
                    fail_io(path, "the source package has changed: " + object_name +
                                      " has more vertices");
                }
                const auto w = object->welded[i];
                if (std::memcmp(original.row(w).data(), positions.row(w).data(),
                                3 * sizeof(double)) == 0)
                {
                    return;
                }
                const Eigen::Vector4d local =
                    to_local *
                    Eigen::Vector4d(positions(w, 0), positions(w, 1), positions(w, 2), 1.0);
                for (int d = 0; d < 3; ++d)
                {
                    const double before = parse_coordinate(path, vertex, d, i, object_name);
                    if (std::memcmp(&before, &local[d], sizeof(double)) == 0)
                    {
                        continue;  // this coordinate keeps its text
                    }
                    const auto [offset, end] = value_span(
                        path, part, vertex.attribute(kAxes[static_cast<std::size_t>(d)]));
                    const std::string_view token(part.text.data() + offset, end - offset);
                    // Float digits when the original token had float precision, else double
                    // (see append_like_token); either must be a finite number.
                    const bool is_float = significant_digits(token) <= 9;
                    if (!std::isfinite(local[d]) ||
                        (is_float && !std::isfinite(static_cast<float>(local[d]))))
                    {
                        fail_io(path, "vertex " + std::to_string(i) + " of " + object_name +
                                          " does not fit a " +
                                          (is_float ? "float32" : "float64") + " coordinate");
                    }
                    Edit edit{offset, end, {}};
                    append_like_token(edit.text, token, local[d]);
                    edits.push_back(std::move(edit));
                }
            });
    }
    if (edits.empty())
    {
        return {};
    }
    std::sort(edits.begin(), edits.end(),
              [](const Edit& a, const Edit& b) { return a.offset < b.offset; });
    std::string text;
    text.reserve(part.text.size() + edits.size() * 4);
    std::size_t at = 0;
    for (const auto& edit : edits)
    {
        text.append(part.text, at, edit.offset - at);
        text += edit.text;
        at = edit.end;
    }
    text.append(part.text, at, std::string::npos);
    return text;
}

std::string moved_package(const fs::path& path, const FileLayout& layout, const Positions& original,
                          const Positions& positions)
{
    const auto& objects = std::get<ThreeMfLayout>(layout.positions);
    // The objects with a moved vertex, by model part (in the order parts were read).
    std::vector<std::pair<std::string, std::vector<const ThreeMfObject*>>> moved;
    for (const auto& object : objects.objects)
    {
        const bool is_moved = std::any_of(
            object.welded.begin(), object.welded.end(),
            [&](std::int32_t w)
            {
                return std::memcmp(original.row(w).data(), positions.row(w).data(),
                                   3 * sizeof(double)) != 0;
            });
        if (!is_moved)
        {
            continue;
        }
        auto at = std::find_if(moved.begin(), moved.end(),
                               [&](const auto& entry) { return entry.first == object.part; });
        if (at == moved.end())
        {
            moved.emplace_back(object.part, std::vector<const ThreeMfObject*>{});
            at = moved.end() - 1;
        }
        at->second.push_back(&object);
    }
    if (moved.empty())
    {
        return layout.bytes;  // unchanged positions: the package as it was, byte for byte
    }
    std::vector<std::pair<std::string, std::string>> replaced;
    {
        Package package(path, layout.bytes);
        for (const auto& [name, part_objects] : moved)
        {
            const ModelPart& part = package.part(name, "the source layout");
            std::string text = moved_part_text(path, part, part_objects, original, positions);
            if (!text.empty())
            {
                replaced.emplace_back(part.name, std::move(text));
            }
        }
    }
    if (replaced.empty())
    {
        return layout.bytes;
    }
    return replace_zip_entries(path, layout.bytes, replaced);
}

// ---------------------------------------------------------------------------------------
// The generic writer: hand-written XML (one object, one build item) in a new zip.

std::string new_package(const fs::path& path, const TriangleMesh& mesh)
{
    std::string model =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<model unit=\"millimeter\" xml:lang=\"en-US\" "
        "xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n"
        " <resources>\n"
        "  <object id=\"1\" type=\"model\">\n"
        "   <mesh>\n"
        "    <vertices>\n";
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        model += "     <vertex";
        for (int d = 0; d < 3; ++d)
        {
            const auto value = static_cast<float>(mesh.V(i, d));
            if (!std::isfinite(value))
            {
                fail_io(path, "vertex " + std::to_string(i) + " does not fit a float32 coordinate");
            }
            model += ' ';
            model += kAxes[static_cast<std::size_t>(d)];
            model += "=\"";
            append_shortest(model, value);
            model += '"';
        }
        model += "/>\n";
    }
    model += "    </vertices>\n    <triangles>\n";
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        model += "     <triangle v1=\"" + std::to_string(mesh.F(f, 0)) + "\" v2=\"" +
                 std::to_string(mesh.F(f, 1)) + "\" v3=\"" + std::to_string(mesh.F(f, 2)) +
                 "\"/>\n";
    }
    model +=
        "    </triangles>\n"
        "   </mesh>\n"
        "  </object>\n"
        " </resources>\n"
        " <build>\n"
        "  <item objectid=\"1\"/>\n"
        " </build>\n"
        "</model>\n";
    const std::string content_types =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<Types xmlns=\"http://schemas.openxmlformats.org/package/2006/content-types\">\n"
        " <Default Extension=\"rels\" "
        "ContentType=\"application/vnd.openxmlformats-package.relationships+xml\"/>\n"
        " <Default Extension=\"model\" "
        "ContentType=\"application/vnd.ms-package.3dmanufacturing-3dmodel+xml\"/>\n"
        "</Types>\n";
    const std::string relationships =
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
        "<Relationships xmlns=\"http://schemas.openxmlformats.org/package/2006/relationships\">\n"
        " <Relationship Target=\"/3D/3dmodel.model\" Id=\"rel0\" "
        "Type=\"http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel\"/>\n"
        "</Relationships>\n";
    return new_zip(path, {{"[Content_Types].xml", content_types},
                          {"_rels/.rels", relationships},
                          {"3D/3dmodel.model", model}});
}

// pugixml and libzip report failures as results; a std::bad_alloc or similar from a hostile
// package becomes one IoError naming the file.
template <typename F>
auto guarded(const fs::path& path, F&& body)
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

}  // namespace

TriangleMesh read_3mf(const fs::path& path, FileLayout& layout)
{
    return guarded(path,
                   [&]
                   {
                       Package package(path, layout.bytes);
                       auto& objects = layout.positions.emplace<ThreeMfLayout>();
                       Reader reader(path, package, objects);
                       return reader.run();
                   });
}

std::string preserved_3mf_bytes(const fs::path& path, const FileLayout& layout,
                                const Positions& original, const Positions& positions)
{
    return guarded(path, [&] { return moved_package(path, layout, original, positions); });
}

std::string three_mf_bytes(const fs::path& path, const TriangleMesh& mesh)
{
    return guarded(path, [&] { return new_package(path, mesh); });
}

}  // namespace meshmark::detail

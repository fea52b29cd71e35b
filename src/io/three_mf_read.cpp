// SPDX-License-Identifier: MIT
// The 3MF reader: every mesh object reached from the build is read in the build's world frame
// (build item and component transforms, components in other model parts through the
// production extension's p:path), objects no build item reaches in their own frame, and
// coincident world-space vertices welded like glTF parts. Further instances of an object under
// other transforms are kept aside, not marked.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string_view>
#include <utility>

#include <Eigen/LU>

#include "io/detail/formats.h"
#include "io/detail/numbers.h"
#include "io/detail/three_mf.h"
#include "io/detail/weld.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// Component nesting deeper than this (or more object visits) is refused: a reference cycle
// would recurse forever, and a DAG of components can expand exponentially.
constexpr int kMaxComponentDepth = 64;
constexpr std::size_t kMaxObjectVisits = 1U << 20U;

// The root model's unit (3MF core specification, "Model": micron, millimeter, centimeter, inch,
// foot, meter; millimeter when absent). Any other value gives no unit rather than a guess.
std::optional<LengthUnit> model_unit(pugi::xml_attribute unit)
{
    if (!unit)
    {
        return LengthUnit::Millimetre;
    }
    static const std::pair<std::string_view, LengthUnit> kNames[] = {
        {"micron", LengthUnit::Micrometre},
        {"millimeter", LengthUnit::Millimetre},
        {"centimeter", LengthUnit::Centimetre},
        {"inch", LengthUnit::Inch},
        {"foot", LengthUnit::Foot},
        {"meter", LengthUnit::Metre}};
    const std::string_view value = trimmed(unit.value());
    for (const auto& [name, length_unit] : kNames)
    {
        if (value == name)
        {
            return length_unit;
        }
    }
    return std::nullopt;
}

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
        layout_.unit = model_unit(root.model.attribute("unit"));
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
            fail_io(path_,
                    "the components of " + object_name + " nest too deeply (a reference cycle?)");
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
                        map *
                        Eigen::Vector4d(world_[3 * e], world_[3 * e + 1], world_[3 * e + 2], 1.0);
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
                                                     object_name + " has a non-finite coordinate");
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

}  // namespace meshmark::detail

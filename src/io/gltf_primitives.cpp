// SPDX-License-Identifier: MIT
// The primitives of the glTF scene: what each use of a set of positions adds (the first use
// places its elements; a later one adds triangles over them, another instance, or nothing),
// written once for both stores, and the store of plain POSITION accessors with their indices.
// The Draco store is in gltf_draco_primitive.cpp.
#include "io/detail/gltf_primitives.h"

#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "io/detail/gltf_json.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace
{

constexpr int kModePoints = 0;
constexpr int kModeTriangles = 4;

}  // namespace

void ScenePrimitives::add_mesh(int mesh, const Placement& place, int skin)
{
    const auto& primitives = file_.model.meshes[static_cast<std::size_t>(mesh)].primitives;
    for (std::size_t p = 0; p < primitives.size(); ++p)
    {
        const auto& prim = primitives[p];
        if (prim.mode != kModeTriangles && prim.mode != kModePoints)
        {
            continue;  // lines, strips and fans are carried through untouched
        }
        const int index = static_cast<int>(p);
        const std::string where =
            "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index);
        if (prim.extensions.count(kDracoExtension) != 0)
        {
            add_draco_primitive(prim, mesh, index, where, place, skin);
        }
        else
        {
            add_accessor_primitive(prim, where, place, skin);
        }
    }
}

ScenePrimitives::LaterUse ScenePrimitives::later_use(const Slot& slot, int skin,
                                                     const Eigen::Matrix4d& to_world,
                                                     std::size_t& instance_base)
{
    if (slot.skin >= 0 || skin >= 0)
    {
        // Skinned: the same skin shows the same vertices (the node's transform does not count);
        // a use under another skin is not marked and not kept aside.
        return slot.skin == skin ? LaterUse::SameElements : LaterUse::Nothing;
    }
    if (!same_matrix(slot.to_world, to_world))
    {
        // Another instance of the same positions under a different transform: its vertices
        // cannot take a second displacement, so only the first instance is watermarked; its
        // geometry is kept aside for registration (MeshFile::instances).
        instance_base = elements_.add_instance(slot.first, slot.count, slot.to_world, to_world);
        return LaterUse::Instance;
    }
    return LaterUse::SameElements;
}

std::vector<Eigen::Matrix4d> ScenePrimitives::place_first_use(const tinygltf::Primitive& prim,
                                                              const std::string& where,
                                                              const std::vector<double>& local,
                                                              const SkinSets& sets, int skin,
                                                              const Placement& place)
{
    const std::vector<double> shown =
        morphed(file_.accessors, pose_, place.node, prim, local, where);
    if (skin < 0)
    {
        elements_.append(local, place, elements_.group_of(place.to_world), shown);
        return {};
    }
    if (rest_globals_.empty())
    {
        std::vector<Eigen::Matrix4d> locals(file_.model.nodes.size());
        for (std::size_t n = 0; n < locals.size(); ++n)
        {
            locals[n] = local_matrix(file_.model.nodes[n]);
        }
        rest_globals_ = world_matrices(file_.model, locals);
    }
    return place_skinned(file_, rest_globals_, pose_, local, sets, skin, place, shown, elements_);
}

void ScenePrimitives::add_accessor_primitive(const tinygltf::Primitive& prim,
                                             const std::string& where, const Placement& place,
                                             int skin)
{
    // A skinned use: JOINTS_0 and WEIGHTS_0 under a node with a skin (glTF then places the
    // vertices by the joints and ignores the node's transform).
    if (skin >= 0 &&
        (prim.attributes.count("JOINTS_0") == 0 || prim.attributes.count("WEIGHTS_0") == 0))
    {
        skin = -1;
    }
    const auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end())
    {
        return;
    }
    const int a = it->second;
    if (a < 0 || static_cast<std::size_t>(a) >= file_.model.accessors.size())
    {
        fail_io(file_.path, where + " has a missing POSITION accessor");
    }
    if (const auto found = accessor_slots_.find(a); found != accessor_slots_.end())
    {
        const Slot& slot = found->second;
        std::size_t instance_base = 0;
        const LaterUse use = later_use(slot, skin, place.to_world, instance_base);
        if (use != LaterUse::Nothing && prim.mode == kModeTriangles)
        {
            // (each use has its own indices)
            if (use == LaterUse::Instance)
            {
                add_indexed_triangles(prim, where, instance_base, slot.count,
                                      elements_.instance_corners);
            }
            else
            {
                add_indexed_triangles(prim, where, slot.first, slot.count, elements_.corners);
            }
        }
        return;
    }
    const auto& acc = file_.model.accessors[static_cast<std::size_t>(a)];
    const auto component = component_of(acc.componentType);
    if (acc.type != TINYGLTF_TYPE_VEC3 || !component || *component == GltfComponent::UInt32)
    {
        fail_io(file_.path, "POSITION accessor " + std::to_string(a) +
                                " is not a VEC3 of float or 8/16-bit integers");
    }
    GltfPositionAccessor record;
    record.accessor = a;
    record.component = *component;
    record.is_normalized = acc.normalized;
    record.to_world = place.to_world;
    record.elements = file_.accessors.locate(a, 3, "POSITION");
    const std::vector<double> local = accessor_positions(record);
    Slot slot;
    slot.first = elements_.size();
    slot.count = record.elements.size();
    slot.to_world = place.to_world;
    slot.skin = skin;
    accessor_slots_.emplace(a, slot);
    starts_.accessors.push_back(slot.first);
    const SkinSets sets = skin >= 0 ? skin_sets(file_.accessors, prim) : SkinSets{};
    record.skinning = place_first_use(prim, where, local, sets, skin, place);
    record.skin = skin;
    asset_.accessors.push_back(std::move(record));
    if (prim.mode == kModeTriangles)
    {
        add_indexed_triangles(prim, where, slot.first, slot.count, elements_.corners);
    }
}

// The local positions of \p record's elements, decoded and de-normalized as a renderer would
// (checked finite).
std::vector<double> ScenePrimitives::accessor_positions(const GltfPositionAccessor& record) const
{
    std::vector<double> local(3 * record.elements.size(), 0.0);
    const auto type = scalar_of(record.component);
    const std::size_t size = component_size(record.component);
    for (std::size_t e = 0; e < record.elements.size(); ++e)
    {
        const auto& el = record.elements[e];
        for (std::size_t d = 0; d < 3 && el.buffer >= 0; ++d)
        {
            const char* p = asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() +
                            el.offset + d * size;
            local[3 * e + d] =
                dequantize(load_scalar(p, type, false), record.component, record.is_normalized);
        }
    }
    for (std::size_t k = 0; k < local.size(); ++k)
    {
        if (!std::isfinite(local[k]))
        {
            fail_mesh(file_.path, "POSITION accessor " + std::to_string(record.accessor) +
                                      " element " + std::to_string(k / 3) +
                                      " has a non-finite coordinate");
        }
    }
    return local;
}

void ScenePrimitives::add_indexed_triangles(const tinygltf::Primitive& prim,
                                            const std::string& where, std::size_t base,
                                            std::size_t count,
                                            std::vector<std::size_t>& corners) const
{
    if (prim.indices < 0)
    {
        if (count % 3 != 0)
        {
            fail_mesh(file_.path, where + " has " + std::to_string(count) +
                                      " non-indexed vertices, not a multiple of 3");
        }
        for (std::size_t e = 0; e < count; ++e)
        {
            corners.push_back(base + e);
        }
        return;
    }
    if (static_cast<std::size_t>(prim.indices) >= file_.model.accessors.size())
    {
        fail_io(file_.path, where + " has a missing indices accessor");
    }
    const auto& acc = file_.model.accessors[static_cast<std::size_t>(prim.indices)];
    const auto component = component_of(acc.componentType);
    if (acc.type != TINYGLTF_TYPE_SCALAR || !component ||
        (*component != GltfComponent::UInt8 && *component != GltfComponent::UInt16 &&
         *component != GltfComponent::UInt32))
    {
        fail_io(file_.path, where + " has indices that are not unsigned integer scalars");
    }
    const auto elements = file_.accessors.locate(prim.indices, 1, "indices");
    if (elements.size() % 3 != 0)
    {
        fail_mesh(file_.path, where + " has " + std::to_string(elements.size()) +
                                  " indices, not a multiple of 3");
    }
    const auto type = scalar_of(*component);
    for (const auto& el : elements)
    {
        const std::uint64_t i =
            el.buffer < 0
                ? 0
                : static_cast<std::uint64_t>(load_integer(
                      asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() + el.offset,
                      type, false));
        if (i >= count)
        {
            fail_mesh(file_.path,
                      where + " has index " + std::to_string(i) + " " + index_range(count));
        }
        corners.push_back(base + i);
    }
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// The Draco store of the glTF scene's primitives (KHR_draco_mesh_compression): the extension
// checked, its data decoded once per bufferView (once for every time when posing), its
// positions, joints and weights handed to what every first use does (gltf_primitives.cpp).
#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "io/detail/gltf_json.h"
#include "io/detail/gltf_primitives.h"
#include "io/detail/support.h"

namespace meshmark::detail
{

namespace
{

constexpr int kModeTriangles = 4;

// The Draco attribute ids of a skinned primitive's JOINTS_n and WEIGHTS_n, in pairs, set by set
// while both the primitive and its Draco extension have them.
std::vector<std::int32_t> draco_skin_ids(const tinygltf::Primitive& prim,
                                         const tinygltf::Value& draco)
{
    std::vector<std::int32_t> ids;
    const auto& attributes = draco.Get("attributes");
    for (int set = 0;; ++set)
    {
        const std::string joints = "JOINTS_" + std::to_string(set);
        const std::string weights = "WEIGHTS_" + std::to_string(set);
        if (prim.attributes.count(joints) == 0 || prim.attributes.count(weights) == 0 ||
            !attributes.Has(joints) || !attributes.Has(weights) ||
            !attributes.Get(joints).IsInt() || !attributes.Get(weights).IsInt())
        {
            return ids;
        }
        ids.push_back(attributes.Get(joints).Get<int>());
        ids.push_back(attributes.Get(weights).Get<int>());
    }
}

// Attributes or morph targets of \p prim outside the Draco data (GltfDracoPrimitive).
bool has_foreign_attributes(const tinygltf::Primitive& prim, const tinygltf::Value& draco)
{
    const auto& draco_attributes = draco.Get("attributes").Keys();
    bool foreign = !prim.targets.empty();
    for (const auto& [name, accessor] : prim.attributes)
    {
        static_cast<void>(accessor);
        if (std::find(draco_attributes.begin(), draco_attributes.end(), name) ==
            draco_attributes.end())
        {
            foreign = true;
        }
    }
    return foreign;
}

}  // namespace

const DracoGeometry& ScenePrimitives::draco_geometry(int view_index, std::int32_t position_id,
                                                     const std::vector<std::int32_t>& skin_ids,
                                                     DracoGeometry& decoded)
{
    const auto& view = file_.model.bufferViews[static_cast<std::size_t>(view_index)];
    const auto decode = [&]
    {
        const auto& buffer = asset_.buffers[static_cast<std::size_t>(view.buffer)].bytes;
        return decode_draco(file_.path, buffer.substr(view.byteOffset, view.byteLength),
                            position_id, skin_ids);
    };
    if (!animation_time_)
    {
        decoded = decode();
        return decoded;
    }
    // (posing at many times, for_each_animation_pose: each view is decoded once)
    auto decoded_before = asset_.pose_draco.find(view_index);
    if (decoded_before == asset_.pose_draco.end() ||
        decoded_before->second.more.size() < skin_ids.size())
    {
        asset_.pose_draco.erase(view_index);
        decoded_before = asset_.pose_draco.emplace(view_index, decode()).first;
    }
    return decoded_before->second;
}

void ScenePrimitives::add_draco_primitive(const tinygltf::Primitive& prim, int mesh, int index,
                                          const std::string& where, const Placement& place,
                                          int skin)
{
    const auto& ext = prim.extensions.at(kDracoExtension);
    // tinygltf::Value::Get asserts an object: check the shape before each lookup.
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
    {
        fail_io(file_.path,
                where + " has a malformed " + std::string(kDracoExtension) + " extension");
    }
    const auto& view_value = ext.Get("bufferView");
    const auto& position_value = ext.Get("attributes").Get("POSITION");
    const auto position = prim.attributes.find("POSITION");
    if (!view_value.IsInt() || !position_value.IsInt() || position == prim.attributes.end() ||
        position->second < 0 ||
        static_cast<std::size_t>(position->second) >= file_.model.accessors.size())
    {
        fail_io(file_.path, where + " has a " + std::string(kDracoExtension) +
                                " extension without bufferView or POSITION attribute");
    }
    const int view_index = view_value.Get<int>();
    if (view_index < 0 || static_cast<std::size_t>(view_index) >= file_.model.bufferViews.size())
    {
        fail_io(file_.path,
                where + " refers to missing Draco bufferView " + std::to_string(view_index));
    }
    // Skinned when the joints and weights are in the same Draco data.
    const std::vector<std::int32_t> skin_ids =
        skin >= 0 ? draco_skin_ids(prim, ext) : std::vector<std::int32_t>{};
    if (skin_ids.empty())
    {
        skin = -1;
    }
    if (const auto found = draco_slots_.find(view_index); found != draco_slots_.end())
    {
        // The Draco data has one connectivity: a use of the same elements adds no triangles (they
        // are there), another instance the first use's.
        const Slot& slot = found->second;
        std::size_t instance_base = 0;
        if (later_use(slot, skin, place.to_world, instance_base) == LaterUse::Instance)
        {
            for (std::size_t k = slot.corners_begin; k < slot.corners_end; ++k)
            {
                elements_.instance_corners.push_back(instance_base + elements_.corners[k] -
                                                     slot.first);
            }
        }
        return;
    }
    const auto& view = file_.model.bufferViews[static_cast<std::size_t>(view_index)];
    if (!file_.accessors.is_view_in_buffer(view))
    {
        fail_io(file_.path, where + " has a Draco bufferView past the end of its buffer");
    }
    GltfDracoPrimitive record;
    record.mesh = mesh;
    record.primitive = index;
    record.buffer_view = view_index;
    record.position_accessor = position->second;
    record.position_attribute_id = position_value.Get<int>();
    record.to_world = place.to_world;
    record.has_foreign_attributes = has_foreign_attributes(prim, ext);
    DracoGeometry decoded;
    const DracoGeometry& geometry =
        draco_geometry(view_index, record.position_attribute_id, skin_ids, decoded);
    // The decoded values are stored values: with KHR_mesh_quantization, integers that the
    // accessor's `normalized` maps to [-1, 1] or [0, 1], as for uncompressed data.
    const auto& accessor = file_.model.accessors[static_cast<std::size_t>(position->second)];
    record.component = geometry.component;
    record.is_normalized = accessor.normalized && geometry.component != GltfComponent::Float32;
    std::vector<double> local(geometry.positions.size());
    for (std::size_t k = 0; k < local.size(); ++k)
    {
        local[k] = dequantize(geometry.positions[k], record.component, record.is_normalized);
    }
    Slot slot;
    slot.first = elements_.size();
    slot.count = geometry.point_count;
    slot.to_world = place.to_world;
    slot.skin = skin;
    starts_.draco.push_back(slot.first);
    SkinSets sets;
    for (std::size_t k = 0; k + 1 < skin_ids.size(); k += 2)
    {
        sets.joints.push_back(geometry.more[k]);
        sets.weights.push_back(geometry.more[k + 1]);
    }
    // (a primitive with morph targets is encoded keeping its points' order, sequentially,
    // and its targets stay plain accessors, element for element of the decoded points)
    record.skinning = place_first_use(prim, where, local, sets, skin, place);
    record.skin = skin;
    record.welded.resize(geometry.point_count);
    asset_.draco.push_back(std::move(record));
    slot.corners_begin = elements_.corners.size();
    if (prim.mode == kModeTriangles)
    {
        for (const auto c : geometry.triangles)
        {
            elements_.corners.push_back(slot.first + c);
        }
    }
    slot.corners_end = elements_.corners.size();
    draco_slots_.emplace(view_index, slot);
}

}  // namespace meshmark::detail

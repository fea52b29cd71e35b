// SPDX-License-Identifier: MIT
// Quantization planning of the preserving glTF writer: the new stored values of every
// POSITION record (plain accessor or Draco primitive), and what happens when a moved vertex
// pushes one past what its integer component type holds: the grid of every accessor shown
// through the same nodes is widened (a scale and shift undone by those nodes' transforms),
// or, when that cannot be done without moving something else, the accessor becomes float32.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <set>
#include <tuple>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "io/detail/gltf_writer.h"
#include "io/detail/numbers.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace
{

// The 3 stored values (\p stored) of element \p e moved to world position \p moved: taken back
// to the frame it was read in (through \p to_local, or a skinned element through its own
// blended joint matrix: affine, so the new world position maps back exactly through its
// inverse) and quantized as its accessor stores it. One way for plain and Draco records.
void store_moved(double* stored, std::size_t e, const Eigen::Ref<const Eigen::RowVector3d>& moved,
                 const Eigen::Matrix4d& to_local, const std::vector<Eigen::Matrix4d>& skinning,
                 GltfComponent component, bool is_normalized)
{
    const Eigen::Vector4d world(moved(0), moved(1), moved(2), 1.0);
    const Eigen::Vector4d local = skinning.empty() ? Eigen::Vector4d(to_local * world)
                                                   : Eigen::Vector4d(skinning[e].inverse() * world);
    for (std::size_t d = 0; d < 3; ++d)
    {
        stored[d] = quantize(local[static_cast<Eigen::Index>(d)], component, is_normalized);
    }
}

}  // namespace

GltfWriter::Plan GltfWriter::plan_accessor(std::size_t slot)
{
    const auto& record = asset_.accessors[slot];
    Plan plan;
    plan.record = slot;
    plan.accessor = record.accessor;
    plan.component = record.component;
    plan.is_normalized = record.is_normalized;
    const auto type = scalar_of(record.component);
    const std::size_t size = scalar_size(type);
    const std::size_t n = record.elements.size();
    plan.stored.assign(3 * n, 0.0);
    plan.rewrite.assign(n, 0);
    const Eigen::Matrix4d to_local = record.to_world.inverse();
    for (std::size_t e = 0; e < n; ++e)
    {
        const auto& el = record.elements[e];
        const std::int32_t w = record.welded[e];
        plan.has_implicit = plan.has_implicit || el.buffer < 0;
        if (is_changed(original_, positions_, w))
        {
            store_moved(&plan.stored[3 * e], e, positions_.row(w), to_local, record.skinning,
                        plan.component, plan.is_normalized);
            plan.rewrite[e] = 1;
        }
        else if (el.buffer >= 0)
        {
            const char* p = buffers_[static_cast<std::size_t>(el.buffer)].data() + el.offset;
            for (std::size_t d = 0; d < 3; ++d)
            {
                plan.stored[3 * e + d] = load_scalar(p + d * size, type, false);
            }
        }
    }
    return plan;
}

GltfWriter::Plan GltfWriter::plan_draco(std::size_t slot)
{
    const auto& record = asset_.draco[slot];
    Plan plan;
    plan.is_draco = true;
    plan.record = slot;
    plan.accessor = record.position_accessor;
    plan.component = record.component;
    plan.is_normalized = record.is_normalized;
    plan.rewrite.assign(record.welded.size(), 0);
    bool is_any_changed = false;
    for (const auto w : record.welded)
    {
        is_any_changed = is_any_changed || is_changed(original_, positions_, w);
    }
    if (!is_any_changed)
    {
        return plan;  // no stored values needed: its bytes stay as they are
    }
    // The decoded stored values; the moved points get new ones.
    plan.stored = decode_draco(path_, draco_bytes(record.buffer_view), record.position_attribute_id)
                      .positions;
    const Eigen::Matrix4d to_local = record.to_world.inverse();
    for (std::size_t i = 0; i < record.welded.size(); ++i)
    {
        const std::int32_t w = record.welded[i];
        if (!is_changed(original_, positions_, w))
        {
            continue;
        }
        store_moved(&plan.stored[3 * i], i, positions_.row(w), to_local, record.skinning,
                    plan.component, plan.is_normalized);
        plan.rewrite[i] = 1;
    }
    return plan;
}

bool GltfWriter::overflows(const Plan& plan) const
{
    const auto [lo, hi] = stored_range(plan.component, plan.is_normalized);
    for (std::size_t e = 0; e < plan.rewrite.size(); ++e)
    {
        if (plan.rewrite[e] == 0)
        {
            continue;
        }
        if (!plan.is_draco && asset_.accessors[plan.record].elements[e].buffer < 0)
        {
            return true;  // an implicit zero has no bytes to take the new value
        }
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double v = plan.stored[3 * e + d];
            if (!is_integer(plan.component))
            {
                if (!std::isfinite(static_cast<float>(v)))
                {
                    fail("cannot store coordinate " + std::to_string(v) + " of POSITION accessor " +
                         std::to_string(plan.accessor) + " as a float32");
                }
                continue;
            }
            const double stored = std::nearbyint(v);
            if (stored < lo || stored > hi)
            {
                return true;
            }
        }
    }
    return false;
}

// The plans whose positions one node transform dequantizes together with those of plan
// `first` (every POSITION accessor of every mesh that shares one with it), when their grid
// can be widened by changing only those nodes' transforms: the nodes (returned in `nodes`)
// have no children, camera, skin, extension or animation that the change would also move,
// the meshes have no morph targets (whose deltas would need the same scale), and every
// accessor is an integer type of the same kind with bytes for every element. Empty otherwise.
std::vector<std::size_t> GltfWriter::sharing_group(const std::vector<Plan>& plans,
                                                   std::size_t first,
                                                   std::vector<std::size_t>& nodes)
{
    nodes.clear();
    const auto& d = doc();
    std::map<std::int32_t, std::size_t> plan_of;
    for (std::size_t p = 0; p < plans.size(); ++p)
    {
        plan_of.emplace(plans[p].accessor, p);
    }
    const auto position_of = [](const GltfJson& primitive) -> std::int64_t
    {
        if (!primitive.is_object() || !primitive.contains("attributes") ||
            !primitive["attributes"].contains("POSITION") ||
            !primitive["attributes"]["POSITION"].is_number_integer())
        {
            return -1;
        }
        return primitive["attributes"]["POSITION"].get<std::int64_t>();
    };
    const GltfJson empty = GltfJson::array();
    const GltfJson& meshes = d.contains("meshes") ? d["meshes"] : empty;
    std::set<std::int64_t> accessors{plans[first].accessor};
    std::set<std::size_t> group_meshes;
    for (bool is_grown = true; is_grown;)
    {
        is_grown = false;
        for (std::size_t m = 0; m < meshes.size(); ++m)
        {
            if (group_meshes.count(m) != 0 || !meshes[m].contains("primitives"))
            {
                continue;
            }
            bool is_member = false;
            for (const auto& primitive : meshes[m]["primitives"])
            {
                is_member = is_member || accessors.count(position_of(primitive)) != 0;
            }
            if (is_member)
            {
                group_meshes.insert(m);
                for (const auto& primitive : meshes[m]["primitives"])
                {
                    if (primitive.contains("targets") && !primitive["targets"].empty())
                    {
                        return {};
                    }
                    accessors.insert(position_of(primitive));
                }
                is_grown = true;
            }
        }
    }
    std::vector<std::size_t> group;
    for (const auto a : accessors)
    {
        const auto found = plan_of.find(static_cast<std::int32_t>(a));
        if (a < 0 || found == plan_of.end())
        {
            return {};  // positions this file does not read (lines, another scene): untouchable
        }
        const Plan& plan = plans[found->second];
        if (plan.component != plans[first].component ||
            plan.is_normalized != plans[first].is_normalized || !is_integer(plan.component) ||
            plan.has_implicit || plan.as_float)
        {
            return {};
        }
        group.push_back(found->second);
    }
    const GltfJson& all_nodes = d.contains("nodes") ? d["nodes"] : empty;
    for (std::size_t n = 0; n < all_nodes.size(); ++n)
    {
        const GltfJson& node = all_nodes[n];
        if (!node.contains("mesh") || !node["mesh"].is_number_integer() ||
            group_meshes.count(node["mesh"].get<std::size_t>()) == 0)
        {
            continue;
        }
        for (const char* member : {"children", "camera", "skin", "extensions", "weights"})
        {
            if (node.contains(member) && !node[member].empty())
            {
                return {};
            }
        }
        nodes.push_back(n);
    }
    if (d.contains("animations"))
    {
        for (const auto& animation : d["animations"])
        {
            for (const auto& channel : animation.value("channels", empty))
            {
                const auto& target = channel.value("target", GltfJson::object());
                if (target.contains("node") &&
                    std::find(nodes.begin(), nodes.end(), target["node"].get<std::size_t>()) !=
                        nodes.end())
                {
                    return {};
                }
            }
        }
    }
    if (nodes.empty())
    {
        return {};
    }
    return group;
}

void GltfWriter::fit_range(std::vector<Plan>& plans, std::size_t overflowing)
{
    std::vector<std::size_t> nodes;
    const auto group = sharing_group(plans, overflowing, nodes);
    Plan& plan = plans[overflowing];
    if (group.empty())
    {
        // float32 holds any position: only this accessor (or Draco attribute) changes.
        plan.as_float = true;
        return;
    }
    // A Draco primitive with no moved point still has to take the new grid.
    for (const auto p : group)
    {
        if (plans[p].is_draco && plans[p].stored.empty())
        {
            const auto& record = asset_.draco[plans[p].record];
            plans[p].stored =
                decode_draco(path_, draco_bytes(record.buffer_view), record.position_attribute_id)
                    .positions;
        }
    }
    // The stored values of the whole group per axis, and the affine map s * v + t that puts
    // them in the type's range: a whole-number shift when the span fits (values that did not
    // move keep their exact place on the grid), else the largest s that fits, centred.
    const auto [lo, hi] = stored_range(plan.component, plan.is_normalized);
    std::array<double, 3> low{};
    std::array<double, 3> high{};
    low.fill(std::numeric_limits<double>::infinity());
    high.fill(-std::numeric_limits<double>::infinity());
    for (const auto p : group)
    {
        for (std::size_t k = 0; k < plans[p].stored.size(); ++k)
        {
            low[k % 3] = std::min(low[k % 3], plans[p].stored[k]);
            high[k % 3] = std::max(high[k % 3], plans[p].stored[k]);
        }
    }
    double scale = 1.0;
    std::array<double, 3> shift{};
    bool is_span_fitting = true;
    for (std::size_t d = 0; d < 3; ++d)
    {
        is_span_fitting = is_span_fitting && high[d] - low[d] <= hi - lo - 1.0;
    }
    for (std::size_t d = 0; d < 3; ++d)
    {
        if (is_span_fitting)
        {
            shift[d] = std::nearbyint(low[d]) < lo    ? lo - std::floor(low[d])
                       : std::nearbyint(high[d]) > hi ? hi - std::ceil(high[d])
                                                      : 0.0;
        }
        else
        {
            scale = std::min(scale, (hi - lo - 2.0) / (high[d] - low[d]));
        }
    }
    if (!is_span_fitting)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            shift[d] = 0.5 * (lo + hi) - scale * 0.5 * (low[d] + high[d]);
        }
    }
    for (const auto p : group)
    {
        for (std::size_t k = 0; k < plans[p].stored.size(); ++k)
        {
            plans[p].stored[k] = scale * plans[p].stored[k] + shift[k % 3];
        }
        std::fill(plans[p].rewrite.begin(), plans[p].rewrite.end(), 1);
    }
    // The same map in dequantized units, undone by every node that shows these meshes.
    const double unit = quantize(1.0, plan.component, plan.is_normalized);
    transform_nodes(nodes, scale, {shift[0] / unit, shift[1] / unit, shift[2] / unit});
}

// Each node's local transform T becomes T * A^-1 with A(x) = scale * x + shift, the map just
// applied to the stored positions, so that what the nodes show does not move.
void GltfWriter::transform_nodes(const std::vector<std::size_t>& nodes, double scale,
                                 const std::array<double, 3>& shift)
{
    const Eigen::Vector3d t(shift[0], shift[1], shift[2]);
    for (const auto n : nodes)
    {
        auto& node = doc()["nodes"][n];
        if (node.contains("matrix"))
        {
            Eigen::Matrix4d m;
            for (int k = 0; k < 16; ++k)
            {
                m(k % 4, k / 4) = node["matrix"][static_cast<std::size_t>(k)].get<double>();
            }
            Eigen::Matrix4d inverse = Eigen::Matrix4d::Identity();
            inverse.topLeftCorner<3, 3>() /= scale;
            inverse.topRightCorner<3, 1>() = -t / scale;
            const Eigen::Matrix4d updated = m * inverse;
            for (int k = 0; k < 16; ++k)
            {
                node["matrix"][static_cast<std::size_t>(k)] = updated(k % 4, k / 4);
            }
        }
        else
        {
            // T R S A^-1 = T' R S' with S' = S / scale, T' = T + R S (-t / scale).
            Eigen::Vector3d translation = Eigen::Vector3d::Zero();
            Eigen::Vector3d factors = Eigen::Vector3d::Ones();
            Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
            if (node.contains("translation"))
            {
                for (int d = 0; d < 3; ++d)
                {
                    translation[d] = node["translation"][static_cast<std::size_t>(d)].get<double>();
                }
            }
            if (node.contains("scale"))
            {
                for (int d = 0; d < 3; ++d)
                {
                    factors[d] = node["scale"][static_cast<std::size_t>(d)].get<double>();
                }
            }
            if (node.contains("rotation"))
            {
                const auto& q = node["rotation"];
                rotation = Eigen::Quaterniond(q[3].get<double>(), q[0].get<double>(),
                                              q[1].get<double>(), q[2].get<double>());
                if (rotation.norm() > 0.0)
                {
                    rotation.normalize();
                }
            }
            translation += rotation * factors.cwiseProduct(-t / scale);
            factors /= scale;
            node["translation"] = {translation[0], translation[1], translation[2]};
            if (scale != 1.0 || node.contains("scale"))
            {
                node["scale"] = {factors[0], factors[1], factors[2]};
            }
        }
    }
    is_json_changed_ = true;
}

// A POSITION accessor whose new values its integer type cannot hold, or that has elements
// without bytes, becomes a float32 accessor over a new bufferView appended to a buffer; its
// old bytes stay where they were (other accessors may share them), nothing else changes.
void GltfWriter::write_float_accessor(const Plan& plan)
{
    const auto& record = asset_.accessors[plan.record];
    const std::size_t n = record.elements.size();
    std::string bytes(12 * n, '\0');
    std::array<double, 3> lo{};
    std::array<double, 3> hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    // New values are unclamped stored values (dequantize clamps a normalized -128 or -32768
    // to -1, which would also clamp a new value beyond the type); unmoved ones read as stored.
    const double unit = quantize(1.0, plan.component, plan.is_normalized);
    for (std::size_t k = 0; k < 3 * n; ++k)
    {
        const auto value =
            static_cast<float>(plan.rewrite[k / 3] != 0 ? plan.stored[k] / unit
                                                        : dequantize(plan.stored[k], plan.component,
                                                                     plan.is_normalized));
        store_float(bytes.data() + 4 * k, value, false);
        lo[k % 3] = std::min(lo[k % 3], static_cast<double>(value));
        hi[k % 3] = std::max(hi[k % 3], static_cast<double>(value));
    }
    // The GLB's BIN chunk, else the first buffer that has bytes of its own (not a meshopt
    // fallback buffer, which only declares a size).
    auto& json_buffers = doc()["buffers"];
    std::optional<std::size_t> target;
    for (std::size_t b = 0; b < asset_.buffers.size() && !target; ++b)
    {
        if (asset_.buffers[b].source == GltfBufferSource::GlbBinChunk)
        {
            target = b;
        }
    }
    for (std::size_t b = 0; b < asset_.buffers.size() && !target; ++b)
    {
        const auto& extensions = json_buffers[b].value("extensions", GltfJson::object());
        const bool is_fallback = extensions.contains("EXT_meshopt_compression") ||
                                 extensions.contains("KHR_meshopt_compression");
        if (!is_fallback)
        {
            target = b;
        }
    }
    if (!target)
    {
        fail("cannot store POSITION accessor " + std::to_string(record.accessor) +
             " as float32: the asset has no buffer to add it to");
    }
    std::string& data = buffers_[*target];
    data.resize((data.size() + 3) / 4 * 4, '\0');
    const auto offset = data.size();
    data += bytes;
    json_buffers[*target]["byteLength"] = data.size();
    auto& views = doc()["bufferViews"];
    views.push_back({{"buffer", *target},
                     {"byteOffset", offset},
                     {"byteLength", bytes.size()},
                     {"target", kArrayBuffer}});
    auto& acc = doc()["accessors"][static_cast<std::size_t>(record.accessor)];
    acc["bufferView"] = views.size() - 1;
    acc.erase("byteOffset");
    acc.erase("sparse");
    acc.erase("normalized");
    acc["componentType"] = kFloat;
    GltfJson min = GltfJson::array();
    GltfJson max = GltfJson::array();
    for (std::size_t d = 0; d < 3; ++d)
    {
        min.push_back(float_number(lo[d]));
        max.push_back(float_number(hi[d]));
    }
    acc["min"] = min;
    acc["max"] = max;
    is_json_changed_ = true;
}

}  // namespace meshmark::detail

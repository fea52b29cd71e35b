// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB writers. The preserving writer patches position bytes in copies of the
// original buffers and edits only what positions determine in the JSON (POSITION min/max;
// for re-encoded Draco data, its bufferView, the views after it and the buffer length; for a
// re-encoded meshopt stream, its extension's byteLength, the streams and views after it and
// the buffer length): nlohmann::ordered_json keeps every other member, unknown ones included,
// in its order.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <set>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "io/detail/gltf.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr int kFloat = 5126;
constexpr int kUnsignedInt = 5125;
constexpr int kArrayBuffer = 34962;
constexpr int kElementArrayBuffer = 34963;
constexpr const char* kDracoExtension = "KHR_draco_mesh_compression";
constexpr std::array<const char*, 2> kMeshoptExtensions = {"EXT_meshopt_compression",
                                                           "KHR_meshopt_compression"};

bool is_changed(const Positions& a, const Positions& b, std::int32_t row)
{
    return std::memcmp(a.row(row).data(), b.row(row).data(), 3 * sizeof(double)) != 0;
}

bool is_integer(GltfComponent c)
{
    return c != GltfComponent::Float32;
}

// A float32 bound as the JSON number with the float's shortest digits ("0.1", not
// "0.10000000149011612"), so readers converting it to float get the exact value back.
Json float_number(double value)
{
    std::string text;
    append_shortest(text, static_cast<float>(value));
    double parsed = 0.0;
    static_cast<void>(parse_double(text, parsed));
    return Json(parsed);
}

std::string percent_encoded(const std::string& name)
{
    std::string out;
    for (const char ch : name)
    {
        const auto c = static_cast<unsigned char>(ch);
        if (std::isalnum(c) != 0 || c == '-' || c == '.' || c == '_' || c == '~')
        {
            out += ch;
        }
        else
        {
            constexpr std::string_view kHex = "0123456789ABCDEF";
            out += '%';
            out += kHex[c >> 4U];
            out += kHex[c & 0xfU];
        }
    }
    return out;
}

class Writer
{
public:
    Writer(const fs::path& path, const GltfAsset& asset, const Positions& original,
           const Positions& positions)
        : path_(path), asset_(asset), original_(original), positions_(positions)
    {
        for (const auto& b : asset.buffers)
        {
            buffers_.push_back(b.bytes);
        }
    }

    void run(bool is_glb);

private:
    // The new stored values of one POSITION record (a plain accessor or a Draco primitive),
    // 3 per element, before rounding; `rewrite` marks the elements whose bytes change.
    struct Plan
    {
        bool is_draco = false;
        std::size_t record = 0;  // index into asset_.accessors or asset_.draco
        std::int32_t accessor = 0;
        GltfComponent component = GltfComponent::Float32;
        bool is_normalized = false;
        std::vector<double> stored;
        std::vector<char> rewrite;
        bool has_implicit = false;  // elements without bytes (read as zero)
        bool as_float = false;      // rewritten as a float32 accessor
    };

    Json& doc();
    Plan plan_accessor(std::size_t slot);
    Plan plan_draco(std::size_t slot);
    std::string draco_bytes(std::int32_t view);
    [[nodiscard]] bool overflows(const Plan& plan) const;
    void fit_range(std::vector<Plan>& plans, std::size_t overflowing);
    [[nodiscard]] std::vector<std::size_t> sharing_group(const std::vector<Plan>& plans,
                                                         std::size_t first,
                                                         std::vector<std::size_t>& nodes);
    void transform_nodes(const std::vector<std::size_t>& nodes, double scale,
                         const std::array<double, 3>& shift);
    void write_accessor(const Plan& plan);
    void write_float_accessor(const Plan& plan);
    void update_bounds(const GltfPositionAccessor& record);
    void write_meshopt();
    void write_draco(const Plan& plan);
    void splice(Json& owner, std::size_t buffer, std::uint64_t offset, const std::string& bytes,
                const std::string& what);
    void set_bounds(std::int32_t accessor, const std::array<double, 3>& lo,
                    const std::array<double, 3>& hi, bool is_float);
    std::vector<std::pair<fs::path, std::string>> external_files();
    std::string json_text();
    [[noreturn]] void fail(const std::string& what) const { fail_io(path_, what); }

    const fs::path& path_;
    const GltfAsset& asset_;
    const Positions& original_;
    const Positions& positions_;
    std::vector<std::string> buffers_;
    std::optional<Json> doc_;
    bool is_json_changed_ = false;
};

Json& Writer::doc()
{
    if (!doc_)
    {
        try
        {
            // GLB JSON chunks are padded with spaces (some writers use NULs): parse without.
            const auto end = asset_.json.find_last_not_of(std::string(" \t\r\n\0", 5));
            doc_ = Json::parse(asset_.json.substr(0, end == std::string::npos ? 0 : end + 1));
        }
        catch (const Json::exception& e)
        {
            fail(std::string("cannot re-parse the glTF JSON: ") + e.what());
        }
    }
    return *doc_;
}

Writer::Plan Writer::plan_accessor(std::size_t slot)
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
            const Eigen::Vector4d local =
                to_local * Eigen::Vector4d(positions_(w, 0), positions_(w, 1), positions_(w, 2), 1.0);
            for (std::size_t d = 0; d < 3; ++d)
            {
                plan.stored[3 * e + d] = quantize(local[static_cast<Eigen::Index>(d)],
                                                  plan.component, plan.is_normalized);
            }
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

Writer::Plan Writer::plan_draco(std::size_t slot)
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
        const Eigen::Vector4d local =
            to_local * Eigen::Vector4d(positions_(w, 0), positions_(w, 1), positions_(w, 2), 1.0);
        for (std::size_t d = 0; d < 3; ++d)
        {
            plan.stored[3 * i + d] = quantize(local[static_cast<Eigen::Index>(d)], plan.component,
                                              plan.is_normalized);
        }
        plan.rewrite[i] = 1;
    }
    return plan;
}

std::string Writer::draco_bytes(std::int32_t view_index)
{
    const auto& view = doc()["bufferViews"][static_cast<std::size_t>(view_index)];
    const auto buffer = view["buffer"].get<std::size_t>();
    const auto offset = view.value("byteOffset", std::uint64_t{0});
    const auto length = view["byteLength"].get<std::uint64_t>();
    return buffers_[buffer].substr(offset, length);
}

bool Writer::overflows(const Plan& plan) const
{
    const auto [lo, hi] = stored_range(plan.component, plan.is_normalized);
    for (std::size_t e = 0; e < plan.rewrite.size(); ++e)
    {
        if (plan.rewrite[e] == 0)
        {
            continue;
        }
        if (!plan.is_draco &&
            asset_.accessors[plan.record].elements[e].buffer < 0)
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
std::vector<std::size_t> Writer::sharing_group(const std::vector<Plan>& plans, std::size_t first,
                                               std::vector<std::size_t>& nodes)
{
    nodes.clear();
    const auto& d = doc();
    std::map<std::int32_t, std::size_t> plan_of;
    for (std::size_t p = 0; p < plans.size(); ++p)
    {
        plan_of.emplace(plans[p].accessor, p);
    }
    const auto position_of = [](const Json& primitive) -> std::int64_t
    {
        if (!primitive.is_object() || !primitive.contains("attributes") ||
            !primitive["attributes"].contains("POSITION") ||
            !primitive["attributes"]["POSITION"].is_number_integer())
        {
            return -1;
        }
        return primitive["attributes"]["POSITION"].get<std::int64_t>();
    };
    const Json empty = Json::array();
    const Json& meshes = d.contains("meshes") ? d["meshes"] : empty;
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
    const Json& all_nodes = d.contains("nodes") ? d["nodes"] : empty;
    for (std::size_t n = 0; n < all_nodes.size(); ++n)
    {
        const Json& node = all_nodes[n];
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
                const auto& target = channel.value("target", Json::object());
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

void Writer::fit_range(std::vector<Plan>& plans, std::size_t overflowing)
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
void Writer::transform_nodes(const std::vector<std::size_t>& nodes, double scale,
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

void Writer::write_accessor(const Plan& plan)
{
    const auto& record = asset_.accessors[plan.record];
    const auto type = scalar_of(record.component);
    const std::size_t size = scalar_size(type);
    bool is_any_changed = false;
    for (std::size_t e = 0; e < record.elements.size(); ++e)
    {
        if (plan.rewrite[e] == 0)
        {
            continue;
        }
        const auto& el = record.elements[e];
        char* p = buffers_[static_cast<std::size_t>(el.buffer)].data() + el.offset;
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double value = plan.stored[3 * e + d];
            if (!store_scalar(p + d * size, type, false, value))
            {
                fail("internal error: coordinate " + std::to_string(value) +
                     " does not fit POSITION accessor " + std::to_string(record.accessor) +
                     "'s component type after its range was checked");
            }
        }
        is_any_changed = true;
    }
    if (is_any_changed)
    {
        update_bounds(record);
    }
}

// Bounds of the stored values after sparse substitution, in the component type.
void Writer::update_bounds(const GltfPositionAccessor& record)
{
    const auto type = scalar_of(record.component);
    const std::size_t size =
        record.component == GltfComponent::Float32 ? 4
        : (record.component == GltfComponent::Int16 || record.component == GltfComponent::UInt16)
            ? 2
            : 1;
    std::array<double, 3> lo{};
    std::array<double, 3> hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    for (const auto& el : record.elements)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            const double v =
                el.buffer < 0 ? 0.0
                              : load_scalar(buffers_[static_cast<std::size_t>(el.buffer)].data() +
                                                el.offset + d * size,
                                            type, false);
            lo[d] = std::min(lo[d], v);
            hi[d] = std::max(hi[d], v);
        }
    }
    set_bounds(record.accessor, lo, hi, type == ScalarType::Float32);
}

// A POSITION accessor whose new values its integer type cannot hold, or that has elements
// without bytes, becomes a float32 accessor over a new bufferView appended to a buffer; its
// old bytes stay where they were (other accessors may share them), nothing else changes.
void Writer::write_float_accessor(const Plan& plan)
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
        const auto value = static_cast<float>(
            plan.rewrite[k / 3] != 0 ? plan.stored[k] / unit
                                     : dequantize(plan.stored[k], plan.component, plan.is_normalized));
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
        const auto& extensions = json_buffers[b].value("extensions", Json::object());
        const bool is_fallback =
            extensions.contains("EXT_meshopt_compression") ||
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
    Json min = Json::array();
    Json max = Json::array();
    for (std::size_t d = 0; d < 3; ++d)
    {
        min.push_back(float_number(lo[d]));
        max.push_back(float_number(hi[d]));
    }
    acc["min"] = min;
    acc["max"] = max;
    is_json_changed_ = true;
}

void Writer::set_bounds(std::int32_t accessor, const std::array<double, 3>& lo,
                        const std::array<double, 3>& hi, bool is_float)
{
    auto& acc = doc()["accessors"][static_cast<std::size_t>(accessor)];
    for (const auto& [name, values] : {std::pair{"min", &lo}, std::pair{"max", &hi}})
    {
        if (!acc.contains(name) || !acc[name].is_array() || acc[name].size() != 3)
        {
            continue;  // an absent (or malformed) bound stays as it was
        }
        Json bound = Json::array();
        for (const double v : *values)
        {
            bound.push_back(is_float ? float_number(v) : Json(static_cast<std::int64_t>(v)));
        }
        bool is_same = true;
        for (std::size_t d = 0; d < 3; ++d)
        {
            is_same = is_same && acc[name][d].is_number() &&
                      acc[name][d].get<double>() == bound[d].get<double>();
        }
        if (!is_same)
        {
            acc[name] = std::move(bound);
            is_json_changed_ = true;
        }
    }
}

void Writer::write_draco(const Plan& plan)
{
    if (std::find(plan.rewrite.begin(), plan.rewrite.end(), 1) == plan.rewrite.end())
    {
        return;
    }
    const auto& record = asset_.draco[plan.record];
    const std::string old_bytes = draco_bytes(record.buffer_view);
    // Integer positions are rounded here, onto the grid the range check used; made float32,
    // they are dequantized (new values unclamped, as in write_float_accessor).
    std::vector<double> stored = plan.stored;
    const double unit = quantize(1.0, plan.component, plan.is_normalized);
    for (std::size_t k = 0; k < stored.size() && is_integer(plan.component); ++k)
    {
        stored[k] = !plan.as_float                 ? std::nearbyint(stored[k])
                    : plan.rewrite[k / 3] != 0 ? stored[k] / unit
                                               : dequantize(stored[k], plan.component, plan.is_normalized);
    }
    const std::string new_bytes = reencode_draco(path_, old_bytes, record.position_attribute_id,
                                                 stored, record.has_foreign_attributes,
                                                 plan.as_float);
    auto& view_json = doc()["bufferViews"][static_cast<std::size_t>(record.buffer_view)];
    splice(view_json, view_json["buffer"].get<std::size_t>(),
           view_json.value("byteOffset", std::uint64_t{0}), new_bytes,
           "Draco data of bufferView " + std::to_string(record.buffer_view));

    // Point count and position bounds as the new stream decodes.
    const auto decoded = decode_draco(path_, new_bytes, record.position_attribute_id);
    std::array<double, 3> lo{};
    std::array<double, 3> hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    for (std::size_t k = 0; k < decoded.positions.size(); ++k)
    {
        lo[k % 3] = std::min(lo[k % 3], decoded.positions[k]);
        hi[k % 3] = std::max(hi[k % 3], decoded.positions[k]);
    }
    const bool is_float = plan.as_float || !is_integer(plan.component);
    if (plan.as_float && is_integer(plan.component))
    {
        auto& acc = doc()["accessors"][static_cast<std::size_t>(record.position_accessor)];
        acc["componentType"] = kFloat;
        acc.erase("normalized");
        is_json_changed_ = true;
    }
    set_bounds(record.position_accessor, lo, hi, is_float);
    const auto& prim = doc()["meshes"][static_cast<std::size_t>(record.mesh)]["primitives"]
                            [static_cast<std::size_t>(record.primitive)];
    for (const auto& [name, accessor] : prim["extensions"][kDracoExtension]["attributes"].items())
    {
        static_cast<void>(accessor);
        if (prim["attributes"].contains(name))
        {
            auto& acc = doc()["accessors"][prim["attributes"][name].get<std::size_t>()];
            if (acc.value("count", std::uint64_t{0}) != decoded.point_count)
            {
                acc["count"] = decoded.point_count;
                is_json_changed_ = true;
            }
        }
    }
}

// The meshopt views whose decoded bytes (their range of the materialized fallback buffer, where
// write_accessor stored the new positions) changed are re-encoded with their mode, filter and
// stride, and the new streams replace the old ones in the compressed buffers. A fallback
// buffer with data (a uri or the BIN chunk) keeps its stored bytes except for the re-encoded
// views, which get the new decoded data: readers without meshopt support see the same
// positions as the others (and no unmarked copy is left behind). A fallback without data
// stays as it was: just a byteLength.
void Writer::write_meshopt()
{
    std::vector<std::pair<const GltfMeshoptView*, std::string>> encoded;
    for (const auto& record : asset_.meshopt)
    {
        const auto b = static_cast<std::size_t>(record.buffer);
        const auto first = static_cast<std::ptrdiff_t>(record.offset);
        const auto length = static_cast<std::ptrdiff_t>(record.count * record.stride);
        const auto& source = asset_.buffers[b];
        std::string& data = buffers_[b];
        if (std::equal(source.bytes.begin() + first, source.bytes.begin() + first + length,
                       data.begin() + first))
        {
            if (source.has_stored)
            {
                std::copy(source.stored.begin() + first, source.stored.begin() + first + length,
                          data.begin() + first);
            }
            continue;
        }
        if (!record.unsupported.empty())
        {
            fail("cannot store moved positions in bufferView " + std::to_string(record.view) +
                 ": " + record.unsupported);
        }
        std::string bytes = encode_meshopt(
            path_, record,
            data.substr(static_cast<std::size_t>(first), static_cast<std::size_t>(length)));
        // What every meshopt reader will see (the exponential filter rounds the mantissas).
        const std::string decoded = decode_meshopt(path_, record, bytes);
        std::copy(decoded.begin(), decoded.end(), data.begin() + first);
        if (record.filter != MeshoptFilter::None)
        {
            for (const auto& accessor : asset_.accessors)
            {
                const bool is_inside = std::any_of(
                    accessor.elements.begin(), accessor.elements.end(),
                    [&](const GltfElement& el)
                    {
                        return el.buffer == record.buffer && el.offset >= record.offset &&
                               el.offset < record.offset + record.count * record.stride;
                    });
                if (is_inside)
                {
                    update_bounds(accessor);
                }
            }
        }
        encoded.emplace_back(&record, std::move(bytes));
    }
    // Splices last: the fallback ranges above are those of the original buffers.
    for (const auto& [record, bytes] : encoded)
    {
        auto& ext = doc()["bufferViews"][static_cast<std::size_t>(record->view)]["extensions"]
                         [record->extension];
        splice(ext, ext["buffer"].get<std::size_t>(), ext.value("byteOffset", std::uint64_t{0}),
               bytes, "meshopt stream of bufferView " + std::to_string(record->view));
    }
}

// Replaces the bytes [offset, offset + owner's byteLength) of \p buffer with \p bytes, the new
// data of \p owner (a bufferView, or the meshopt extension object that points at compressed
// data), whose byteLength follows. Every later bufferView and meshopt stream in the buffer
// shifts by a multiple of 4, so that it keeps its alignment; the buffer's byteLength follows.
void Writer::splice(Json& owner, std::size_t buffer, std::uint64_t offset, const std::string& bytes,
                    const std::string& what)
{
    const auto old_length = owner["byteLength"].get<std::uint64_t>();
    const auto new_length = static_cast<std::int64_t>(bytes.size());
    const auto difference = new_length - static_cast<std::int64_t>(old_length);
    const std::int64_t shift =
        difference >= 0 ? (difference + 3) / 4 * 4 : -((-difference) / 4 * 4);
    const auto span = static_cast<std::uint64_t>(static_cast<std::int64_t>(old_length) + shift);
    const auto move = [&](Json& other, const std::string& name)
    {
        if (&other == &owner || other["buffer"].get<std::size_t>() != buffer)
        {
            return;
        }
        const auto o = other.value("byteOffset", std::uint64_t{0});
        if (o >= offset + old_length)
        {
            other["byteOffset"] = static_cast<std::uint64_t>(static_cast<std::int64_t>(o) + shift);
        }
        else if (o + other["byteLength"].get<std::uint64_t>() > offset)
        {
            fail(name + " overlaps the " + what + ", which changes size");
        }
    };
    auto& views = doc()["bufferViews"];
    for (std::size_t v = 0; v < views.size(); ++v)
    {
        move(views[v], "bufferView " + std::to_string(v));
        for (const char* name : kMeshoptExtensions)
        {
            if (views[v].contains("extensions") && views[v]["extensions"].contains(name) &&
                views[v]["extensions"][name].is_object())
            {
                move(views[v]["extensions"][name],
                     "the meshopt stream of bufferView " + std::to_string(v));
            }
        }
    }
    std::string& data = buffers_[buffer];
    std::string replaced = bytes;
    replaced.resize(span, '\0');
    data.replace(offset, old_length, replaced);
    owner["byteLength"] = bytes.size();
    doc()["buffers"][buffer]["byteLength"] = data.size();
    is_json_changed_ = true;
}

std::vector<std::pair<fs::path, std::string>> Writer::external_files()
{
    std::vector<std::size_t> external;
    for (std::size_t b = 0; b < asset_.buffers.size(); ++b)
    {
        if (asset_.buffers[b].source == GltfBufferSource::External)
        {
            external.push_back(b);
        }
    }
    std::vector<std::pair<fs::path, std::string>> files;
    if (external.empty())
    {
        return files;
    }
    // Names derived from the output; never one of the files the source asset reads.
    std::string stem = path_.stem().string();
    const auto name_of = [&](std::size_t k)
    { return external.size() == 1 ? stem + ".bin" : stem + "_" + std::to_string(k) + ".bin"; };
    const auto collides = [&]()
    {
        for (std::size_t k = 0; k < external.size(); ++k)
        {
            const fs::path candidate = path_.parent_path() / name_of(k);
            for (const auto& b : asset_.buffers)
            {
                if (b.source == GltfBufferSource::External && is_same_file(candidate, b.file))
                {
                    return true;
                }
            }
        }
        return false;
    };
    while (collides())
    {
        stem += "_wm";
    }
    for (std::size_t k = 0; k < external.size(); ++k)
    {
        const std::string name = name_of(k);
        doc()["buffers"][external[k]]["uri"] = percent_encoded(name);
        files.emplace_back(path_.parent_path() / name, buffers_[external[k]]);
    }
    is_json_changed_ = true;
    return files;
}

std::string Writer::json_text()
{
    for (std::size_t b = 0; b < asset_.buffers.size(); ++b)
    {
        if (asset_.buffers[b].source == GltfBufferSource::DataUri &&
            buffers_[b] != asset_.buffers[b].bytes)
        {
            doc()["buffers"][b]["uri"] = asset_.buffers[b].uri_prefix + base64_encode(buffers_[b]);
            is_json_changed_ = true;
        }
    }
    if (!is_json_changed_)
    {
        return asset_.json;
    }
    // Indented like the source: pretty-printed sources get 2-space indentation back.
    const bool is_pretty = asset_.json.find('\n') != std::string::npos;
    try
    {
        return is_pretty ? doc().dump(2) : doc().dump();
    }
    catch (const Json::exception& e)
    {
        fail(std::string("cannot serialize the glTF JSON: ") + e.what());
    }
}

void Writer::run(bool is_glb)
{
    // New stored values of every POSITION record; a record that a moved vertex pushes past
    // what its integer type holds gets a wider grid (or float32) before anything is written.
    std::vector<Plan> plans;
    for (std::size_t slot = 0; slot < asset_.accessors.size(); ++slot)
    {
        plans.push_back(plan_accessor(slot));
    }
    for (std::size_t slot = 0; slot < asset_.draco.size(); ++slot)
    {
        plans.push_back(plan_draco(slot));
    }
    for (std::size_t p = 0; p < plans.size(); ++p)
    {
        if (overflows(plans[p]))
        {
            fit_range(plans, p);
        }
    }
    // Plain accessors first: their byte offsets are those of the original buffers, which
    // meshopt and Draco re-encoding may shift and float32 views appended to a buffer extend.
    // Positions in meshopt views are written into the decoded data, which write_meshopt then
    // compresses.
    for (const auto& plan : plans)
    {
        if (!plan.is_draco && !plan.as_float)
        {
            write_accessor(plan);
        }
    }
    write_meshopt();
    for (const auto& plan : plans)
    {
        if (plan.is_draco)
        {
            write_draco(plan);
        }
    }
    for (const auto& plan : plans)
    {
        if (plan.as_float && !plan.is_draco)
        {
            write_float_accessor(plan);
        }
    }
    const auto files = external_files();
    std::string main;
    if (is_glb)
    {
        std::string bin;
        const bool has_bin_buffer =
            !asset_.buffers.empty() && asset_.buffers[0].source == GltfBufferSource::GlbBinChunk;
        if (has_bin_buffer)
        {
            bin = buffers_[0];
            if (buffers_[0].size() == asset_.buffers[0].bytes.size())
            {
                bin += asset_.glb_bin_padding;
            }
        }
        else
        {
            bin = asset_.glb_bin_padding;
        }
        main =
            assemble_glb(path_, json_text(), asset_.glb_has_bin ? &bin : nullptr, asset_.glb_tail);
    }
    else
    {
        main = json_text();
    }

    // Buffers beside the output first, then the asset; on failure nothing new is left.
    std::vector<fs::path> written;
    try
    {
        for (const auto& [file, bytes] : files)
        {
            write_file_atomically(
                file, [&bytes = bytes](std::ostream& out)
                { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
            written.push_back(file);
        }
        write_file_atomically(
            path_, [&main](std::ostream& out)
            { out.write(main.data(), static_cast<std::streamsize>(main.size())); });
    }
    catch (...)
    {
        std::error_code ignored;
        for (const auto& file : written)
        {
            fs::remove(file, ignored);
        }
        throw;
    }
}

}  // namespace

void write_gltf_preserving(const fs::path& path, bool is_glb, const GltfAsset& asset,
                           const Positions& original, const Positions& positions)
{
    Writer writer(path, asset, original, positions);
    try
    {
        writer.run(is_glb);
    }
    catch (const Json::exception& e)
    {
        // The reader validated the asset; an unexpected JSON shape is still one clear error.
        fail_io(path, std::string("cannot update the glTF JSON: ") + e.what());
    }
}

std::string gltf_bytes(const TriangleMesh& mesh, bool is_glb)
{
    const auto n = static_cast<std::size_t>(mesh.V.rows());
    const auto f = static_cast<std::size_t>(mesh.F.rows());
    Json doc;
    doc["asset"] = {{"version", "2.0"}, {"generator", "meshmark"}};
    doc["scene"] = 0;
    if (n == 0)
    {
        doc["scenes"] = Json::array({Json::object({{"nodes", Json::array()}})});
        const std::string text = doc.dump();
        return is_glb ? assemble_glb("(generated)", text, nullptr, "") : text;
    }
    doc["scenes"] = Json::array({{{"nodes", {0}}}});
    doc["nodes"] = Json::array({{{"mesh", 0}}});

    // One buffer: float32 positions, then uint32 indices (both 4-byte aligned).
    std::string bin(12 * n + 12 * f, '\0');
    std::array<double, 3> lo{};
    std::array<double, 3> hi{};
    lo.fill(std::numeric_limits<double>::infinity());
    hi.fill(-std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; ++i)
    {
        for (std::size_t d = 0; d < 3; ++d)
        {
            const float v = static_cast<float>(
                mesh.V(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(d)));
            store_float(bin.data() + 12 * i + 4 * d, v, false);
            lo[d] = std::min(lo[d], static_cast<double>(v));
            hi[d] = std::max(hi[d], static_cast<double>(v));
        }
    }
    static_assert(sizeof(std::int32_t) == 4);
    std::memcpy(bin.data() + 12 * n, mesh.F.data(), 12 * f);  // little-endian host assumed

    Json min = Json::array();
    Json max = Json::array();
    for (std::size_t d = 0; d < 3; ++d)
    {
        min.push_back(float_number(lo[d]));
        max.push_back(float_number(hi[d]));
    }
    Json primitive = {{"attributes", {{"POSITION", 0}}}, {"mode", f > 0 ? 4 : 0}};
    doc["bufferViews"] = Json::array(
        {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 12 * n}, {"target", kArrayBuffer}}});
    doc["accessors"] = Json::array({{{"bufferView", 0},
                                     {"componentType", kFloat},
                                     {"count", n},
                                     {"type", "VEC3"},
                                     {"min", min},
                                     {"max", max}}});
    if (f > 0)
    {
        primitive["indices"] = 1;
        doc["bufferViews"].push_back({{"buffer", 0},
                                      {"byteOffset", 12 * n},
                                      {"byteLength", 12 * f},
                                      {"target", kElementArrayBuffer}});
        doc["accessors"].push_back({{"bufferView", 1},
                                    {"componentType", kUnsignedInt},
                                    {"count", 3 * f},
                                    {"type", "SCALAR"}});
    }
    doc["meshes"] = Json::array({{{"primitives", Json::array({primitive})}}});
    Json buffer = {{"byteLength", bin.size()}};
    if (!is_glb)
    {
        buffer["uri"] = "data:application/octet-stream;base64," + base64_encode(bin);
    }
    doc["buffers"] = Json::array({buffer});
    const std::string text = doc.dump();
    return is_glb ? assemble_glb("(generated)", text, &bin, "") : text;
}

}  // namespace meshmark::detail

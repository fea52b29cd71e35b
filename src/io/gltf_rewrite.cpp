// SPDX-License-Identifier: MIT
// Buffer rewriting of the preserving glTF writer: new stored values into plain accessors'
// bytes (with their min/max), meshopt streams re-encoded from the changed decoded data, Draco
// data re-encoded, and the splice that moves every later bufferView and stream of a buffer
// when a re-encoded stream changes size.
#include <algorithm>
#include <cmath>
#include <limits>

#include "io/detail/gltf_writer.h"
#include "io/detail/numbers.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

std::string GltfWriter::draco_bytes(std::int32_t view_index)
{
    const auto& view = doc()["bufferViews"][static_cast<std::size_t>(view_index)];
    const auto buffer = view["buffer"].get<std::size_t>();
    const auto offset = view.value("byteOffset", std::uint64_t{0});
    const auto length = view["byteLength"].get<std::uint64_t>();
    return buffers_[buffer].substr(offset, length);
}

void GltfWriter::write_accessor(const Plan& plan)
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
void GltfWriter::update_bounds(const GltfPositionAccessor& record)
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

void GltfWriter::set_bounds(std::int32_t accessor, const std::array<double, 3>& lo,
                            const std::array<double, 3>& hi, bool is_float)
{
    auto& acc = doc()["accessors"][static_cast<std::size_t>(accessor)];
    for (const auto& [name, values] : {std::pair{"min", &lo}, std::pair{"max", &hi}})
    {
        if (!acc.contains(name) || !acc[name].is_array() || acc[name].size() != 3)
        {
            continue;  // an absent (or malformed) bound stays as it was
        }
        GltfJson bound = GltfJson::array();
        for (const double v : *values)
        {
            bound.push_back(is_float ? float_number(v) : GltfJson(static_cast<std::int64_t>(v)));
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

void GltfWriter::write_draco(const Plan& plan)
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
        stored[k] = !plan.as_float ? std::nearbyint(stored[k])
                    : plan.rewrite[k / 3] != 0
                        ? stored[k] / unit
                        : dequantize(stored[k], plan.component, plan.is_normalized);
    }
    const std::string new_bytes =
        reencode_draco(path_, old_bytes, record.position_attribute_id, stored,
                       record.has_foreign_attributes, plan.as_float);
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
void GltfWriter::write_meshopt()
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
void GltfWriter::splice(GltfJson& owner, std::size_t buffer, std::uint64_t offset,
                        const std::string& bytes, const std::string& what)
{
    const auto old_length = owner["byteLength"].get<std::uint64_t>();
    const auto new_length = static_cast<std::int64_t>(bytes.size());
    const auto difference = new_length - static_cast<std::int64_t>(old_length);
    const std::int64_t shift =
        difference >= 0 ? (difference + 3) / 4 * 4 : -((-difference) / 4 * 4);
    const auto span = static_cast<std::uint64_t>(static_cast<std::int64_t>(old_length) + shift);
    const auto move = [&](GltfJson& other, const std::string& name)
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

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// KHR_draco_mesh_compression: decoding and re-encoding with libdraco. The re-encoder keeps
// every attribute with its unique id and the bitstream's quantization (position grid
// included when the new positions still fit in it) and its encoding method.
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>

#include <draco/attributes/attribute_octahedron_transform.h>
#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/encoder_buffer.h>

#include "io/detail/gltf.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// Byte 8 of a Draco header ("DRACO", major, minor, encoder type, encoder method).
constexpr std::size_t kMethodOffset = 8;

std::unique_ptr<draco::Mesh> decode(const fs::path& path, const std::string& bytes,
                                    bool skip_transforms)
{
    draco::DecoderBuffer buffer;
    buffer.Init(bytes.data(), bytes.size());
    draco::Decoder decoder;
    if (skip_transforms)
    {
        // Keeps the quantized values and, with them, each attribute's transform parameters.
        for (const auto type :
             {draco::GeometryAttribute::POSITION, draco::GeometryAttribute::NORMAL,
              draco::GeometryAttribute::COLOR, draco::GeometryAttribute::TEX_COORD,
              draco::GeometryAttribute::GENERIC})
        {
            decoder.SetSkipAttributeTransform(type);
        }
    }
    auto result = decoder.DecodeMeshFromBuffer(&buffer);
    if (!result.ok() || result.value() == nullptr)
    {
        fail_io(path, "cannot decode Draco-compressed primitive: " +
                          (result.ok() ? std::string("not a mesh")
                                       : std::string(result.status().error_msg())));
    }
    return std::move(result).value();
}

// The attribute of \p mesh with unique id \p id, or null.
draco::PointAttribute* find_attribute(draco::Mesh& mesh, std::int32_t id)
{
    for (std::int32_t a = 0; a < mesh.num_attributes(); ++a)
    {
        auto* attribute = mesh.attribute(a);
        if (attribute != nullptr && id >= 0 &&
            attribute->unique_id() == static_cast<std::uint32_t>(id))
        {
            return attribute;
        }
    }
    return nullptr;
}

draco::PointAttribute* attribute_by_id(const fs::path& path, draco::Mesh& mesh, std::int32_t id)
{
    auto* attribute = find_attribute(mesh, id);
    if (attribute == nullptr)
    {
        fail_io(path, "the Draco data has no attribute with the POSITION id " + std::to_string(id));
    }
    if (attribute->num_components() != 3)
    {
        fail_io(path,
                "Draco position attribute " + std::to_string(id) + " does not have 3 components");
    }
    return attribute;
}

int quantization_bits(const draco::PointAttribute& quantized)
{
    const auto* data = quantized.GetAttributeTransformData();
    if (data == nullptr)
    {
        return 0;
    }
    if (data->transform_type() == draco::ATTRIBUTE_QUANTIZATION_TRANSFORM)
    {
        draco::AttributeQuantizationTransform q;
        return q.InitFromAttribute(quantized) ? q.quantization_bits() : 0;
    }
    if (data->transform_type() == draco::ATTRIBUTE_OCTAHEDRON_TRANSFORM)
    {
        draco::AttributeOctahedronTransform q;
        return q.InitFromAttribute(quantized) ? q.quantization_bits() : 0;
    }
    return 0;
}

// The glTF component type of a position attribute's data type (KHR_mesh_quantization
// allows 8- and 16-bit integers besides float32).
GltfComponent component_of(const fs::path& path, const draco::PointAttribute& attribute)
{
    switch (attribute.data_type())
    {
        case draco::DT_FLOAT32:
            return GltfComponent::Float32;
        case draco::DT_INT8:
            return GltfComponent::Int8;
        case draco::DT_UINT8:
            return GltfComponent::UInt8;
        case draco::DT_INT16:
            return GltfComponent::Int16;
        case draco::DT_UINT16:
            return GltfComponent::UInt16;
        default:
            fail_io(path, "the Draco position attribute has data type " +
                              std::to_string(static_cast<int>(attribute.data_type())) +
                              ", which glTF does not allow for positions");
    }
}

// One stored value as a double, without the normalization that ConvertValue would apply to
// an attribute flagged as normalized (the glTF accessor, not the Draco flag, decides that).
template <typename T>
void load_values(const draco::PointAttribute& attribute, draco::AttributeValueIndex index,
                 double* out)
{
    std::array<T, 3> values{};
    attribute.GetValue(index, values.data());
    for (std::size_t d = 0; d < 3; ++d)
    {
        out[d] = static_cast<double>(values[d]);
    }
}

void load_stored(const draco::PointAttribute& attribute, GltfComponent component,
                 draco::AttributeValueIndex index, double* out)
{
    switch (component)
    {
        case GltfComponent::Int8:
            return load_values<std::int8_t>(attribute, index, out);
        case GltfComponent::UInt8:
            return load_values<std::uint8_t>(attribute, index, out);
        case GltfComponent::Int16:
            return load_values<std::int16_t>(attribute, index, out);
        case GltfComponent::UInt16:
            return load_values<std::uint16_t>(attribute, index, out);
        default:
            return load_values<float>(attribute, index, out);
    }
}

template <typename T>
void store_values(draco::PointAttribute& attribute, draco::AttributeValueIndex index,
                  const double* values)
{
    std::array<T, 3> typed{};
    for (std::size_t d = 0; d < 3; ++d)
    {
        typed[d] = static_cast<T>(values[d]);  // integers arrive rounded and in range
    }
    attribute.SetAttributeValue(index, typed.data());
}

void store_stored(draco::PointAttribute& attribute, GltfComponent component,
                  draco::AttributeValueIndex index, const double* values)
{
    switch (component)
    {
        case GltfComponent::Int8:
            return store_values<std::int8_t>(attribute, index, values);
        case GltfComponent::UInt8:
            return store_values<std::uint8_t>(attribute, index, values);
        case GltfComponent::Int16:
            return store_values<std::int16_t>(attribute, index, values);
        case GltfComponent::UInt16:
            return store_values<std::uint16_t>(attribute, index, values);
        default:
            return store_values<float>(attribute, index, values);
    }
}

}  // namespace

DracoGeometry decode_draco(const fs::path& path, const std::string& bytes, std::int32_t position_id,
                           std::span<const std::int32_t> more_ids)
{
    auto mesh = decode(path, bytes, false);
    auto* positions = attribute_by_id(path, *mesh, position_id);
    DracoGeometry geometry;
    geometry.point_count = mesh->num_points();
    geometry.component = component_of(path, *positions);
    geometry.positions.resize(3 * static_cast<std::size_t>(geometry.point_count));
    for (std::uint32_t i = 0; i < geometry.point_count; ++i)
    {
        double* p = geometry.positions.data() + 3 * static_cast<std::size_t>(i);
        load_stored(*positions, geometry.component, positions->mapped_index(draco::PointIndex(i)),
                    p);
        if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        {
            fail_mesh(path, "Draco point " + std::to_string(i) + " has no finite position");
        }
    }
    geometry.triangles.reserve(3 * static_cast<std::size_t>(mesh->num_faces()));
    for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
    {
        for (std::size_t c = 0; c < 3; ++c)
        {
            const auto p = mesh->face(f)[c].value();
            if (p >= geometry.point_count)
            {
                fail_mesh(path, "Draco face " + std::to_string(f.value()) + " has point " +
                                    std::to_string(p) + " " + index_range(geometry.point_count));
            }
            geometry.triangles.push_back(p);
        }
    }
    for (const std::int32_t id : more_ids)
    {
        const draco::PointAttribute* attribute = find_attribute(*mesh, id);
        if (attribute == nullptr || attribute->num_components() < 1 ||
            attribute->num_components() > 4)
        {
            fail_io(path, "the Draco data has no attribute " + std::to_string(id) +
                              " of 1 to 4 components");
        }
        std::vector<double>& values =
            geometry.more.emplace_back(4 * static_cast<std::size_t>(geometry.point_count), 0.0);
        for (std::uint32_t i = 0; i < geometry.point_count; ++i)
        {
            if (!attribute->ConvertValue<double>(
                    attribute->mapped_index(draco::PointIndex(i)),
                    static_cast<std::int8_t>(attribute->num_components()),
                    values.data() + 4 * static_cast<std::size_t>(i)))
            {
                fail_io(path, "Draco attribute " + std::to_string(id) +
                                  " has a value that cannot be read at point " + std::to_string(i));
            }
        }
    }
    const auto quantized = decode(path, bytes, true);
    geometry.quantization_bits = quantization_bits(*attribute_by_id(path, *quantized, position_id));
    return geometry;
}

// Replaces the integer position attribute \p index of \p mesh by a float32 one with the same
// unique id and point mapping (values filled in by the caller).
draco::PointAttribute* make_float_positions(draco::Mesh& mesh, std::int32_t index)
{
    const draco::PointAttribute& old = *mesh.attribute(index);
    draco::GeometryAttribute layout;
    layout.Init(draco::GeometryAttribute::POSITION, nullptr, 3, draco::DT_FLOAT32, false,
                3 * sizeof(float), 0);
    auto fresh = std::make_unique<draco::PointAttribute>(layout);
    fresh->Reset(old.size());
    if (old.is_mapping_identity())
    {
        fresh->SetIdentityMapping();
    }
    else
    {
        fresh->SetExplicitMapping(mesh.num_points());
        for (draco::PointIndex i(0); i < mesh.num_points(); ++i)
        {
            fresh->SetPointMapEntry(i, old.mapped_index(i));
        }
    }
    fresh->set_unique_id(old.unique_id());
    draco::PointAttribute* result = fresh.get();
    mesh.SetAttribute(index, std::move(fresh));
    return result;
}

std::string reencode_draco(const fs::path& path, const std::string& bytes, std::int32_t position_id,
                           const std::vector<double>& positions, bool keep_order, bool as_float)
{
    // The decoded mesh (values) and the same stream decoded without its transforms
    // (quantization parameters of every attribute).
    auto mesh = decode(path, bytes, false);
    const auto quantized = decode(path, bytes, true);
    auto* position = attribute_by_id(path, *mesh, position_id);
    std::int32_t position_index = 0;
    while (mesh->attribute(position_index) != position)
    {
        ++position_index;
    }
    if (as_float && position->data_type() != draco::DT_FLOAT32)
    {
        position = make_float_positions(*mesh, position_index);
    }
    const GltfComponent component = component_of(path, *position);
    if (positions.size() != 3 * static_cast<std::size_t>(mesh->num_points()))
    {
        fail_io(path, "internal error: Draco positions do not match the point count");
    }

    // New positions in the attribute's own data type (SetAttributeValue copies raw bytes):
    // one value per point; points sharing a value index share a vertex, and the caller gives
    // them identical positions, so writing per point is consistent.
    for (std::uint32_t i = 0; i < mesh->num_points(); ++i)
    {
        store_stored(*position, component, position->mapped_index(draco::PointIndex(i)),
                     positions.data() + 3 * static_cast<std::size_t>(i));
    }

    draco::ExpertEncoder encoder(*mesh);
    for (std::int32_t a = 0; a < mesh->num_attributes(); ++a)
    {
        const auto& source = *quantized->attribute(a);
        const int bits = quantization_bits(source);
        if (a == position_index && as_float && source.data_type() != draco::DT_FLOAT32)
        {
            // Integer positions made float32: 16 bits over their new extent, the precision of
            // the int16 values they replace (unquantized floats would triple the stream).
            encoder.SetAttributeQuantization(a, 16);
            continue;
        }
        if (bits <= 0)
        {
            continue;
        }
        draco::AttributeQuantizationTransform grid;
        const bool is_position = mesh->attribute(a) == position;
        if (is_position && source.GetAttributeTransformData() != nullptr &&
            source.GetAttributeTransformData()->transform_type() ==
                draco::ATTRIBUTE_QUANTIZATION_TRANSFORM &&
            grid.InitFromAttribute(source))
        {
            // The original grid, if every new position is on it: unchanged points then
            // decode to exactly their old values.
            bool fits = true;
            for (std::size_t k = 0; k < positions.size() && fits; ++k)
            {
                const auto value = static_cast<float>(positions[k]);
                const float lo = grid.min_value(static_cast<int>(k % 3));
                fits = value >= lo && value <= lo + grid.range();
            }
            if (fits)
            {
                encoder.SetAttributeExplicitQuantization(a, bits, 3, grid.min_values().data(),
                                                         grid.range());
                continue;
            }
        }
        encoder.SetAttributeQuantization(a, bits);
    }
    const auto method =
        bytes.size() > kMethodOffset ? static_cast<unsigned char>(bytes[kMethodOffset]) : 0U;
    encoder.SetEncodingMethod(keep_order || method == 0U ? draco::MESH_SEQUENTIAL_ENCODING
                                                         : draco::MESH_EDGEBREAKER_ENCODING);
    draco::EncoderBuffer out;
    const auto status = encoder.EncodeToBuffer(&out);
    if (!status.ok())
    {
        fail_io(path, "cannot re-encode a Draco primitive: " + std::string(status.error_msg()));
    }
    return std::string(out.data(), out.size());
}

}  // namespace meshmark::detail

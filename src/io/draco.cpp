// SPDX-License-Identifier: MIT
// KHR_draco_mesh_compression: decoding and re-encoding with libdraco. The re-encoder keeps
// every attribute with its unique id and the bitstream's quantization (position grid
// included when the new positions still fit in it) and its encoding method.
#include <cmath>
#include <memory>

#include <draco/attributes/attribute_octahedron_transform.h>
#include <draco/attributes/attribute_quantization_transform.h>
#include <draco/compression/decode.h>
#include <draco/compression/expert_encode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/core/encoder_buffer.h>

#include "io/detail/gltf.h"
#include "io/detail/support.h"

namespace meshmark::detail {
namespace {

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

draco::PointAttribute* attribute_by_id(const fs::path& path, draco::Mesh& mesh, std::int32_t id)
{
    for (std::int32_t a = 0; a < mesh.num_attributes(); ++a)
    {
        auto* attribute = mesh.attribute(a);
        if (attribute != nullptr && id >= 0 &&
            attribute->unique_id() == static_cast<std::uint32_t>(id))
        {
            if (attribute->num_components() != 3)
            {
                fail_io(path, "Draco position attribute " + std::to_string(id) +
                                  " does not have 3 components");
            }
            return attribute;
        }
    }
    fail_io(path, "the Draco data has no attribute with the POSITION id " + std::to_string(id));
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

}  // namespace

DracoGeometry decode_draco(const fs::path& path, const std::string& bytes, std::int32_t position_id)
{
    auto mesh = decode(path, bytes, false);
    auto* positions = attribute_by_id(path, *mesh, position_id);
    DracoGeometry geometry;
    geometry.point_count = mesh->num_points();
    geometry.positions.resize(3 * static_cast<std::size_t>(geometry.point_count));
    for (std::uint32_t i = 0; i < geometry.point_count; ++i)
    {
        float* p = geometry.positions.data() + 3 * static_cast<std::size_t>(i);
        if (!positions->ConvertValue<float>(positions->mapped_index(draco::PointIndex(i)), 3, p) ||
            !std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
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
    const auto quantized = decode(path, bytes, true);
    geometry.quantization_bits = quantization_bits(*attribute_by_id(path, *quantized, position_id));
    return geometry;
}

std::string reencode_draco(const fs::path& path, const std::string& bytes, std::int32_t position_id,
                           const std::vector<float>& positions, bool keep_order)
{
    // The decoded mesh (values) and the same stream decoded without its transforms
    // (quantization parameters of every attribute).
    auto mesh = decode(path, bytes, false);
    const auto quantized = decode(path, bytes, true);
    auto* position = attribute_by_id(path, *mesh, position_id);
    if (positions.size() != 3 * static_cast<std::size_t>(mesh->num_points()))
    {
        fail_io(path, "internal error: Draco positions do not match the point count");
    }

    // New positions: one value per point; points sharing a value index share a vertex, and
    // the caller gives them identical positions, so writing per point is consistent.
    for (std::uint32_t i = 0; i < mesh->num_points(); ++i)
    {
        position->SetAttributeValue(position->mapped_index(draco::PointIndex(i)),
                                    positions.data() + 3 * static_cast<std::size_t>(i));
    }

    draco::ExpertEncoder encoder(*mesh);
    for (std::int32_t a = 0; a < mesh->num_attributes(); ++a)
    {
        const auto& source = *quantized->attribute(a);
        const int bits = quantization_bits(source);
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
                const float lo = grid.min_value(static_cast<int>(k % 3));
                fits = positions[k] >= lo && positions[k] <= lo + grid.range();
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

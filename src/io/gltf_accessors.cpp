// SPDX-License-Identifier: MIT
// glTF accessor data: the component types, where each element of an accessor lies in the
// loaded buffers (byte strides, sparse substitution, implicit zeros), and the mapping of
// normalized integers (KHR_mesh_quantization) to the coordinates a renderer sees.
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "io/detail/gltf_reader.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{
namespace
{

// Elements of an accessor without any stored data (all implicit zeros).
constexpr std::uint64_t kMaxImplicitElements = 1U << 24U;

// n elements of element_size bytes, stride apart from offset, end within length.
bool fits(std::uint64_t offset, std::uint64_t stride, std::uint64_t n, std::uint64_t element_size,
          std::uint64_t length)
{
    if (n == 0)
    {
        return offset <= length;
    }
    return offset <= length && element_size <= length - offset &&
           n - 1 <= (length - offset - element_size) / stride;
}

}  // namespace

std::optional<GltfComponent> component_of(int type)
{
    switch (type)
    {
        case 5120:
        case 5121:
        case 5122:
        case 5123:
        case 5125:
        case 5126:
            return static_cast<GltfComponent>(type);
        default:
            return std::nullopt;
    }
}

std::size_t component_size(GltfComponent c)
{
    switch (c)
    {
        case GltfComponent::Int8:
        case GltfComponent::UInt8:
            return 1;
        case GltfComponent::Int16:
        case GltfComponent::UInt16:
            return 2;
        default:
            return 4;
    }
}

GltfAccessors::GltfAccessors(const std::filesystem::path& path, const tinygltf::Model& model,
                             const GltfAsset& asset)
    : path_(path), model_(model), asset_(asset)
{
    for (const auto& record : asset.meshopt)
    {
        if (!record.unsupported.empty() &&
            asset.buffers[static_cast<std::size_t>(record.buffer)].source ==
                GltfBufferSource::MeshoptFallback)
        {
            undecoded_[record.view] = record.unsupported;
        }
    }
}

bool GltfAccessors::is_view_in_buffer(const tinygltf::BufferView& view) const
{
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= asset_.buffers.size())
    {
        return false;
    }
    const std::uint64_t size = asset_.buffers[static_cast<std::size_t>(view.buffer)].bytes.size();
    return view.byteOffset <= size && view.byteLength <= size - view.byteOffset;
}

std::vector<double> GltfAccessors::values(int accessor, int components, const std::string& what,
                                          bool integers_only) const
{
    if (accessor < 0 || static_cast<std::size_t>(accessor) >= model_.accessors.size())
    {
        fail_io(path_, what + " accessor " + std::to_string(accessor) + " is missing");
    }
    const auto& acc = model_.accessors[static_cast<std::size_t>(accessor)];
    const auto [expected_type, type_name] = [&]() -> std::pair<int, const char*>
    {
        switch (components)
        {
            case 1:
                return {TINYGLTF_TYPE_SCALAR, "SCALAR"};
            case 3:
                return {TINYGLTF_TYPE_VEC3, "VEC3"};
            case 4:
                return {TINYGLTF_TYPE_VEC4, "VEC4"};
            default:
                return {TINYGLTF_TYPE_MAT4, "MAT4"};
        }
    }();
    if (acc.type != expected_type)
    {
        fail_io(path_, what + " accessor " + std::to_string(accessor) + " is not a " + type_name);
    }
    const auto component = component_of(acc.componentType);
    if (!component || (integers_only && (*component == GltfComponent::Float32 || acc.normalized)))
    {
        fail_io(path_, what + " accessor " + std::to_string(accessor) +
                           " has an unsupported component type");
    }
    const std::vector<GltfElement> elements = locate(accessor, components, what);
    const auto type = scalar_of(*component);
    const std::size_t size = component_size(*component);
    std::vector<double> values(elements.size() * static_cast<std::size_t>(components), 0.0);
    for (std::size_t e = 0; e < elements.size(); ++e)
    {
        const auto& el = elements[e];
        for (std::size_t d = 0; d < static_cast<std::size_t>(components) && el.buffer >= 0; ++d)
        {
            const char* p = asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() +
                            el.offset + d * size;
            const double v = dequantize(load_scalar(p, type, false), *component, acc.normalized);
            if (!std::isfinite(v))
            {
                fail_io(path_,
                        what + " accessor " + std::to_string(accessor) + " has a non-finite value");
            }
            values[e * static_cast<std::size_t>(components) + d] = v;
        }
    }
    return values;
}

std::vector<GltfElement> GltfAccessors::locate(int accessor_index, int components,
                                               const std::string& what) const
{
    const auto& acc = model_.accessors[static_cast<std::size_t>(accessor_index)];
    const auto component = component_of(acc.componentType);
    if (!component)
    {
        fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                           " has component type " + std::to_string(acc.componentType));
    }
    const std::size_t element_size =
        component_size(*component) * static_cast<std::size_t>(components);
    const std::uint64_t count = acc.count;
    if (count > kMaxVertices || (acc.bufferView < 0 && count > kMaxImplicitElements))
    {
        fail_io(path_, what + " accessor " + std::to_string(accessor_index) + " has " +
                           std::to_string(count) + " elements, more than supported");
    }
    std::vector<GltfElement> elements(static_cast<std::size_t>(count));
    // Byte range [offset, offset + size) of a bufferView, checked against its buffer.
    const auto view_range = [&](int view_index, std::uint64_t offset, std::uint64_t stride,
                                std::uint64_t n) -> std::pair<std::int32_t, std::uint64_t>
    {
        if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size())
        {
            fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                               " refers to missing bufferView " + std::to_string(view_index));
        }
        if (const auto it = undecoded_.find(view_index); it != undecoded_.end())
        {
            fail_io(path_, "cannot read " + what + " accessor " + std::to_string(accessor_index) +
                               ": " + it->second);
        }
        const auto& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
        if (!is_view_in_buffer(view) || !fits(offset, stride, n, element_size, view.byteLength))
        {
            fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                               " reaches past the end of bufferView " + std::to_string(view_index) +
                               " or its buffer");
        }
        return {view.buffer, view.byteOffset + offset};
    };
    if (acc.bufferView >= 0)
    {
        std::uint64_t stride = element_size;
        if (static_cast<std::size_t>(acc.bufferView) < model_.bufferViews.size())
        {
            const auto declared =
                model_.bufferViews[static_cast<std::size_t>(acc.bufferView)].byteStride;
            if (declared != 0)
            {
                if (declared < element_size)
                {
                    fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                                       " has a byteStride smaller than its element");
                }
                stride = declared;
            }
        }
        const auto [buffer, first] = view_range(acc.bufferView, acc.byteOffset, stride, count);
        for (std::uint64_t e = 0; e < count; ++e)
        {
            elements[e] = {buffer, first + e * stride};
        }
    }
    if (acc.sparse.isSparse)
    {
        const auto& sparse = acc.sparse;
        const auto n = static_cast<std::uint64_t>(std::max(sparse.count, 0));
        const auto index_type = component_of(sparse.indices.componentType);
        if (n > count || !index_type ||
            (*index_type != GltfComponent::UInt8 && *index_type != GltfComponent::UInt16 &&
             *index_type != GltfComponent::UInt32) ||
            sparse.indices.byteOffset < 0 || sparse.values.byteOffset < 0)
        {
            fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                               " has invalid sparse data");
        }
        const std::size_t index_size = component_size(*index_type);
        if (sparse.indices.bufferView < 0 ||
            static_cast<std::size_t>(sparse.indices.bufferView) >= model_.bufferViews.size())
        {
            fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                               " has invalid sparse indices");
        }
        if (const auto it = undecoded_.find(sparse.indices.bufferView); it != undecoded_.end())
        {
            fail_io(path_, "cannot read " + what + " accessor " + std::to_string(accessor_index) +
                               ": " + it->second);
        }
        const auto& index_view =
            model_.bufferViews[static_cast<std::size_t>(sparse.indices.bufferView)];
        const auto index_offset = static_cast<std::uint64_t>(sparse.indices.byteOffset);
        if (!is_view_in_buffer(index_view) ||
            !fits(index_offset, index_size, n, index_size, index_view.byteLength))
        {
            fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                               " has sparse indices past the end of their bufferView");
        }
        const char* index_bytes =
            asset_.buffers[static_cast<std::size_t>(index_view.buffer)].bytes.data() +
            index_view.byteOffset + index_offset;
        const auto [buffer, first] =
            view_range(sparse.values.bufferView,
                       static_cast<std::uint64_t>(sparse.values.byteOffset), element_size, n);
        for (std::uint64_t j = 0; j < n; ++j)
        {
            const auto target = static_cast<std::uint64_t>(
                load_integer(index_bytes + j * index_size, scalar_of(*index_type), false));
            if (target >= count)
            {
                fail_io(path_, what + " accessor " + std::to_string(accessor_index) +
                                   " has sparse index " + std::to_string(target) + " " +
                                   index_range(count));
            }
            elements[target] = {buffer, first + j * element_size};
        }
    }
    return elements;
}

double dequantize(double stored, GltfComponent component, bool is_normalized)
{
    if (!is_normalized)
    {
        return stored;
    }
    switch (component)
    {
        case GltfComponent::Int8:
            return std::max(stored / 127.0, -1.0);
        case GltfComponent::UInt8:
            return stored / 255.0;
        case GltfComponent::Int16:
            return std::max(stored / 32767.0, -1.0);
        case GltfComponent::UInt16:
            return stored / 65535.0;
        default:
            return stored;
    }
}

double quantize(double value, GltfComponent component, bool is_normalized)
{
    if (!is_normalized)
    {
        return value;
    }
    switch (component)
    {
        case GltfComponent::Int8:
            return value * 127.0;
        case GltfComponent::UInt8:
            return value * 255.0;
        case GltfComponent::Int16:
            return value * 32767.0;
        case GltfComponent::UInt16:
            return value * 65535.0;
        default:
            return value;
    }
}

std::pair<double, double> stored_range(GltfComponent component, bool is_normalized)
{
    switch (component)
    {
        case GltfComponent::Int8:
            return {is_normalized ? -127.0 : -128.0, 127.0};
        case GltfComponent::UInt8:
            return {0.0, 255.0};
        case GltfComponent::Int16:
            return {is_normalized ? -32767.0 : -32768.0, 32767.0};
        case GltfComponent::UInt16:
            return {0.0, 65535.0};
        default:
            return {-std::numeric_limits<double>::infinity(),
                    std::numeric_limits<double>::infinity()};
    }
}

}  // namespace meshmark::detail

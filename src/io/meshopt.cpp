// SPDX-License-Identifier: MIT
// EXT_meshopt_compression / KHR_meshopt_compression: decoding and re-encoding bufferView
// streams with libmeshoptimizer (Debian's libmeshoptimizer-dev). The library's decoders return
// an error code on malformed input but assert() on impossible sizes, so every size is checked
// here first.
#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include <meshoptimizer.h>

#include "io/detail/gltf.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

// Vertex codec version 1 (header 0xa1, better compression) came with meshoptimizer 0.23.
constexpr unsigned kMaxVertexVersion = MESHOPTIMIZER_VERSION >= 230 ? 1U : 0U;
constexpr unsigned kVertexHeader = 0xa0U;
constexpr unsigned kTrianglesHeader = 0xe0U;  // versions 0 and 1
constexpr unsigned kIndicesHeader = 0xd0U;    // version 1 (0xd1)
constexpr int kMaxExponentBits = 24;

std::string where(const GltfMeshoptView& view)
{
    return view.extension + " stream of bufferView " + std::to_string(view.view);
}

const char* mode_name(MeshoptMode mode)
{
    switch (mode)
    {
        case MeshoptMode::Triangles:
            return "TRIANGLES";
        case MeshoptMode::Indices:
            return "INDICES";
        default:
            return "ATTRIBUTES";
    }
}

// Sizes the library asserts on (and the extension requires): a violation is a malformed view.
void check_layout(const fs::path& path, const GltfMeshoptView& view)
{
    const auto s = view.stride;
    bool ok = false;
    switch (view.mode)
    {
        case MeshoptMode::Attributes:
            ok = s >= 4 && s <= 256 && s % 4 == 0;
            break;
        case MeshoptMode::Triangles:
            ok = (s == 2 || s == 4) && view.count % 3 == 0;
            break;
        case MeshoptMode::Indices:
            ok = s == 2 || s == 4;
            break;
    }
    switch (view.filter)
    {
        case MeshoptFilter::None:
            break;
        case MeshoptFilter::Octahedral:
            ok = ok && view.mode == MeshoptMode::Attributes && (s == 4 || s == 8);
            break;
        case MeshoptFilter::Quaternion:
            ok = ok && view.mode == MeshoptMode::Attributes && s == 8;
            break;
        case MeshoptFilter::Exponential:
            ok = ok && view.mode == MeshoptMode::Attributes;
            break;
    }
    if (!ok)
    {
        fail_io(path, "the " + where(view) + " has mode " + mode_name(view.mode) +
                          " with byteStride " + std::to_string(s) + " and count " +
                          std::to_string(view.count) +
                          ", which the extension does not allow with its filter");
    }
}

// Bit length of the magnitude of a signed 24-bit mantissa.
int mantissa_bits(std::uint32_t value)
{
    auto m = static_cast<std::int32_t>(value << 8U) >> 8;  // sign-extend bits 0..23
    if (m < 0)
    {
        m = -m;
    }
    return static_cast<int>(std::bit_width(static_cast<std::uint32_t>(m)));
}

// The K the exponential filter was encoded with: each element stores 2^e * m with one e for
// the whole element (meshoptimizer's default, and the only mode of the 0.18 encoder), chosen so
// that its largest |m| has K - 1 bits. Other encoder modes (one exponent per component) give
// the same K for their largest components. The most common value over the elements is taken:
// rounding can carry an element's largest mantissa to K bits.
int exponent_bits_of(const std::string& raw, std::uint64_t stride)
{
    std::array<std::uint64_t, kMaxExponentBits + 2> votes{};
    const std::size_t per_element = stride / 4;
    const std::size_t n = raw.size() / stride;
    for (std::size_t e = 0; e < n; ++e)
    {
        int largest = 0;
        for (std::size_t c = 0; c < per_element; ++c)
        {
            std::uint32_t v = 0;
            std::memcpy(&v, raw.data() + e * stride + 4 * c, 4);  // little-endian host assumed
            largest = std::max(largest, mantissa_bits(v));
        }
        if (largest > 0)
        {
            ++votes[static_cast<std::size_t>(std::min(largest + 1, kMaxExponentBits))];
        }
    }
    const auto best = std::max_element(votes.begin(), votes.end());
    return *best == 0 ? kMaxExponentBits : static_cast<int>(best - votes.begin());
}

}  // namespace

std::string meshopt_unsupported(const fs::path& path, const GltfMeshoptView& view,
                                unsigned char header)
{
    const unsigned kind = header & 0xf0U;
    const unsigned version = header & 0x0fU;
    const std::string library = "the meshoptimizer library meshmark is built with (" +
                                std::to_string(MESHOPTIMIZER_VERSION / 100) + "." +
                                std::to_string(MESHOPTIMIZER_VERSION % 100) + ")";
    switch (view.mode)
    {
        case MeshoptMode::Attributes:
            if (kind == kVertexHeader)
            {
                return version <= kMaxVertexVersion
                           ? std::string()
                           : "the " + where(view) + " uses vertex codec version " +
                                 std::to_string(version) + ", which " + library + " cannot decode";
            }
            break;
        case MeshoptMode::Triangles:
            if (kind == kTrianglesHeader)
            {
                return version <= 1
                           ? std::string()
                           : "the " + where(view) + " uses index codec version " +
                                 std::to_string(version) + ", which " + library + " cannot decode";
            }
            break;
        case MeshoptMode::Indices:
            if (kind == kIndicesHeader)
            {
                return version == 1
                           ? std::string()
                           : "the " + where(view) + " uses index sequence version " +
                                 std::to_string(version) + ", which " + library + " cannot decode";
            }
            break;
    }
    char hex[8];
    std::snprintf(hex, sizeof(hex), "0x%02x", static_cast<unsigned>(header));
    fail_io(path, "the " + where(view) + " is not a meshopt " + mode_name(view.mode) +
                      " stream (header byte " + hex + ")");
}

std::string decode_meshopt(const fs::path& path, const GltfMeshoptView& view,
                           const std::string& stream, int* exponent_bits)
{
    check_layout(path, view);
    if (stream.empty())
    {
        fail_io(path, "the " + where(view) + " is empty");
    }
    const auto* data = reinterpret_cast<const unsigned char*>(stream.data());
    const std::string why = meshopt_unsupported(path, view, data[0]);
    if (!why.empty())
    {
        fail_io(path, why);
    }
    std::string out(view.count * view.stride, '\0');
    int result = 0;
    switch (view.mode)
    {
        case MeshoptMode::Attributes:
            result = meshopt_decodeVertexBuffer(out.data(), view.count, view.stride, data,
                                                stream.size());
            break;
        case MeshoptMode::Triangles:
            result =
                meshopt_decodeIndexBuffer(out.data(), view.count, view.stride, data, stream.size());
            break;
        case MeshoptMode::Indices:
            result = meshopt_decodeIndexSequence(out.data(), view.count, view.stride, data,
                                                 stream.size());
            break;
    }
    if (result != 0)
    {
        fail_io(path, "the " + where(view) + " is corrupt or truncated (meshoptimizer error " +
                          std::to_string(result) + ")");
    }
    switch (view.filter)
    {
        case MeshoptFilter::None:
            break;
        case MeshoptFilter::Octahedral:
            meshopt_decodeFilterOct(out.data(), view.count, view.stride);
            break;
        case MeshoptFilter::Quaternion:
            meshopt_decodeFilterQuat(out.data(), view.count, view.stride);
            break;
        case MeshoptFilter::Exponential:
            if (exponent_bits != nullptr)
            {
                *exponent_bits = exponent_bits_of(out, view.stride);
            }
            meshopt_decodeFilterExp(out.data(), view.count, view.stride);
            break;
    }
    return out;
}

std::string encode_meshopt(const fs::path& path, const GltfMeshoptView& view,
                           const std::string& decoded)
{
    check_layout(path, view);
    if (view.mode != MeshoptMode::Attributes ||
        (view.filter != MeshoptFilter::None && view.filter != MeshoptFilter::Exponential))
    {
        // Positions are vertex attributes; the other filters hold unit vectors, never them.
        fail_io(path, "cannot re-encode the " + where(view) +
                          ": only ATTRIBUTES streams with "
                          "filter NONE or EXPONENTIAL are");
    }
    if (decoded.size() != view.count * view.stride)
    {
        fail_io(path, "cannot re-encode the " + where(view) + ": its data has the wrong size");
    }
    std::string filtered = decoded;
    if (view.filter == MeshoptFilter::Exponential)
    {
        std::vector<float> values(decoded.size() / 4);
        std::memcpy(values.data(), decoded.data(), decoded.size());
        const int bits = std::clamp(view.exponent_bits, 1, kMaxExponentBits);
        meshopt_encodeFilterExp(filtered.data(), view.count, view.stride, bits, values.data());
    }
    // Version 0: the format of EXT_meshopt_compression, which every decoder (and the
    // library's own, before 0.23) reads.
    meshopt_encodeVertexVersion(0);
    std::string out(meshopt_encodeVertexBufferBound(view.count, view.stride), '\0');
    const std::size_t size =
        meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(),
                                   filtered.data(), view.count, view.stride);
    if (size == 0)
    {
        fail_io(path, "cannot re-encode the " + where(view));
    }
    out.resize(size);
    return out;
}

}  // namespace meshmark::detail

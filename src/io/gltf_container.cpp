// SPDX-License-Identifier: MIT
// GLB chunk splitting and assembly, and base64 for data: URIs. Written by hand: tinygltf
// parses GLB but does not hand back the raw chunks (needed to keep the JSON text, the BIN
// padding and unknown chunks as they were) and does not export its base64 encoder.
#include <cstdint>
#include <cstring>

#include "io/detail/gltf.h"
#include "io/detail/support.h"

namespace meshmark::detail
{
namespace
{

namespace fs = std::filesystem;

constexpr std::uint32_t kGlbMagic = 0x46546C67U;  // "glTF"
constexpr std::uint32_t kGlbVersion = 2;
constexpr std::uint32_t kChunkJson = 0x4E4F534AU;  // "JSON"
constexpr std::uint32_t kChunkBin = 0x004E4942U;   // "BIN\0"
constexpr std::size_t kHeaderSize = 12;
constexpr std::size_t kChunkHeaderSize = 8;

std::uint32_t load_u32(const std::string& bytes, std::size_t offset)
{
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + offset);
    return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8U) |
           (static_cast<std::uint32_t>(p[2]) << 16U) | (static_cast<std::uint32_t>(p[3]) << 24U);
}

void append_u32(std::string& out, std::uint32_t value)
{
    for (unsigned shift = 0; shift < 32; shift += 8)
    {
        out.push_back(static_cast<char>((value >> shift) & 0xffU));
    }
}

void append_chunk(std::string& out, std::uint32_t type, const std::string& payload, char pad)
{
    const std::size_t padded = (payload.size() + 3) / 4 * 4;
    append_u32(out, static_cast<std::uint32_t>(padded));
    append_u32(out, type);
    out += payload;
    out.append(padded - payload.size(), pad);
}

}  // namespace

GlbChunks split_glb(const fs::path& path, const std::string& bytes)
{
    if (bytes.size() < kHeaderSize + kChunkHeaderSize || load_u32(bytes, 0) != kGlbMagic)
    {
        fail_io(path, "not a GLB file (no 'glTF' binary header)");
    }
    if (load_u32(bytes, 4) != kGlbVersion)
    {
        fail_io(path, "GLB version " + std::to_string(load_u32(bytes, 4)) +
                          " is not supported; expected 2" +
                          std::string(load_u32(bytes, 4) == 1
                                          ? " (a glTF 1.0 binary: convert the asset to glTF 2.0, "
                                            "e.g. with gltf-pipeline)"
                                          : ""));
    }
    if (load_u32(bytes, 8) != bytes.size())
    {
        fail_io(path, "the GLB header declares " + std::to_string(load_u32(bytes, 8)) +
                          " bytes but the file has " + std::to_string(bytes.size()));
    }
    GlbChunks chunks;
    std::size_t offset = kHeaderSize;
    bool is_first = true;
    while (offset < bytes.size())
    {
        if (bytes.size() - offset < kChunkHeaderSize)
        {
            fail_io(path, "truncated GLB chunk header at byte " + std::to_string(offset));
        }
        const std::uint32_t length = load_u32(bytes, offset);
        const std::uint32_t type = load_u32(bytes, offset + 4);
        if (length > bytes.size() - offset - kChunkHeaderSize)
        {
            fail_io(path, "the GLB chunk at byte " + std::to_string(offset) +
                              " reaches past the end of the file");
        }
        const std::size_t payload = offset + kChunkHeaderSize;
        if (is_first)
        {
            if (type != kChunkJson)
            {
                fail_io(path, "the first GLB chunk is not JSON");
            }
            chunks.json = bytes.substr(payload, length);
            is_first = false;
        }
        else if (type == kChunkBin && !chunks.has_bin && chunks.tail.empty())
        {
            chunks.has_bin = true;
            chunks.bin = bytes.substr(payload, length);
        }
        else
        {
            chunks.tail.append(bytes, offset, kChunkHeaderSize + length);
        }
        offset = payload + length;
    }
    return chunks;
}

std::string assemble_glb(const fs::path& path, const std::string& json, const std::string* bin,
                         const std::string& tail)
{
    std::string out;
    out.reserve(kHeaderSize + 2 * kChunkHeaderSize + json.size() + (bin ? bin->size() : 0) +
                tail.size() + 8);
    append_u32(out, kGlbMagic);
    append_u32(out, kGlbVersion);
    append_u32(out, 0);  // total length, set below
    append_chunk(out, kChunkJson, json, ' ');
    if (bin != nullptr)
    {
        append_chunk(out, kChunkBin, *bin, '\0');
    }
    out += tail;
    if (out.size() > 0xffffffffU)
    {
        fail_io(path, "the GLB would be larger than 4 GiB");
    }
    const auto total = static_cast<std::uint32_t>(out.size());
    for (unsigned k = 0; k < 4; ++k)
    {
        out[8 + k] = static_cast<char>((total >> (8 * k)) & 0xffU);
    }
    return out;
}

std::string base64_encode(const std::string& bytes)
{
    constexpr std::string_view kAlphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 3 <= bytes.size(); i += 3)
    {
        const std::uint32_t v =
            (static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) << 16U) |
            (static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 1])) << 8U) |
            static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 2]));
        out += kAlphabet[(v >> 18U) & 63U];
        out += kAlphabet[(v >> 12U) & 63U];
        out += kAlphabet[(v >> 6U) & 63U];
        out += kAlphabet[v & 63U];
    }
    const std::size_t rest = bytes.size() - i;
    if (rest > 0)
    {
        std::uint32_t v = static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i])) << 16U;
        if (rest == 2)
        {
            v |= static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[i + 1])) << 8U;
        }
        out += kAlphabet[(v >> 18U) & 63U];
        out += kAlphabet[(v >> 12U) & 63U];
        out += rest == 2 ? kAlphabet[(v >> 6U) & 63U] : '=';
        out += '=';
    }
    return out;
}

}  // namespace meshmark::detail

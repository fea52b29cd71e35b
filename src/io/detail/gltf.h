// SPDX-License-Identifier: MIT
// glTF 2.0 / GLB: what the preserving writer needs to know about where positions live.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/io/mesh_io.h"
#include "numbers.h"

namespace tinygltf
{
class Model;
}

namespace meshmark::detail
{

/// glTF accessor component types that a POSITION accessor may have (core: FLOAT;
/// KHR_mesh_quantization: the four integer types, normalized or not).
enum class GltfComponent : std::uint16_t
{
    Int8 = 5120,
    UInt8 = 5121,
    Int16 = 5122,
    UInt16 = 5123,
    UInt32 = 5125,
    Float32 = 5126,
};

/// The scalar type of the io number codecs that stores a component type.
[[nodiscard]] inline ScalarType scalar_of(GltfComponent c) noexcept
{
    switch (c)
    {
        case GltfComponent::Int8:
            return ScalarType::Int8;
        case GltfComponent::UInt8:
            return ScalarType::UInt8;
        case GltfComponent::Int16:
            return ScalarType::Int16;
        case GltfComponent::UInt16:
            return ScalarType::UInt16;
        case GltfComponent::UInt32:
            return ScalarType::UInt32;
        default:
            return ScalarType::Float32;
    }
}

/// Where a buffer came from, which decides how the writer stores it.
enum class GltfBufferSource : std::uint8_t
{
    GlbBinChunk,  ///< The BIN chunk of a GLB (buffer 0 without a uri).
    DataUri,      ///< A base64 data: URI inside the JSON.
    External,     ///< A file next to the .gltf (written anew beside the output).
    /// A meshopt fallback buffer without uri: nothing stored in the file, its bytes are the
    /// decoded meshopt views (zeros elsewhere). The writer leaves it as it is in the JSON.
    MeshoptFallback,
};

/// One buffer of the asset: its bytes as loaded and where they came from.
struct GltfBuffer
{
    GltfBufferSource source = GltfBufferSource::External;
    std::string bytes;           ///< Exactly byteLength bytes.
    std::string uri_prefix;      ///< DataUri: everything up to and including the ','.
    std::filesystem::path file;  ///< External: the file it was read from.
    /// A meshopt fallback buffer with data (a uri or the BIN chunk): its bytes as stored,
    /// while \c bytes holds the decoded meshopt views. Empty otherwise.
    std::string stored;
    bool has_stored = false;
};

/// Byte location of one accessor element; buffer < 0 means an implicit zero element (an
/// accessor without bufferView, or the base of a sparse accessor without one).
struct GltfElement
{
    std::int32_t buffer = -1;
    std::uint64_t offset = 0;
};

/// A POSITION accessor stored in buffers (non-Draco), with the world transform it was read
/// with (the first node instance that uses it) and the welded vertex of each element.
struct GltfPositionAccessor
{
    std::int32_t accessor = 0;
    GltfComponent component = GltfComponent::Float32;
    bool is_normalized = false;
    Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();
    std::vector<GltfElement> elements;  ///< Per element, after sparse substitution.
    std::vector<std::int32_t> welded;   ///< Per element: the vertex of MeshFile::mesh.
    /// The skin of a skinned use (a node with a skin, and JOINTS_0 / WEIGHTS_0), else -1.
    std::int32_t skin = -1;
    /// Skinned: per element, the matrix that places it where a viewer shows the scene's pose,
    /// sum_k w_k (joint k's world matrix x its inverse bind matrix); glTF ignores the node's
    /// own transform then, and so does to_world's role. Empty when not skinned.
    std::vector<Eigen::Matrix4d> skinning;
};

/// A primitive compressed with KHR_draco_mesh_compression.
struct GltfDracoPrimitive
{
    std::int32_t mesh = 0;
    std::int32_t primitive = 0;
    std::int32_t buffer_view = 0;
    std::int32_t position_accessor = 0;
    std::int32_t position_attribute_id = 0;  ///< Draco unique id of the position attribute.
    bool has_foreign_attributes = false;     ///< Attributes or targets outside the Draco data.
    /// How the decoded position values are stored (the Draco attribute's data type; with
    /// KHR_mesh_quantization an integer type) and whether the accessor normalizes them.
    GltfComponent component = GltfComponent::Float32;
    bool is_normalized = false;
    Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();
    std::vector<std::int32_t> welded;  ///< Per Draco point: the vertex of MeshFile::mesh.
    /// Skinned (JOINTS_n / WEIGHTS_n in the Draco data): as GltfPositionAccessor::skin and
    /// ::skinning, per Draco point.
    std::int32_t skin = -1;
    std::vector<Eigen::Matrix4d> skinning;
};

/// EXT_meshopt_compression / KHR_meshopt_compression: the modes and filters of a stream.
enum class MeshoptMode : std::uint8_t
{
    Attributes,
    Triangles,
    Indices,
};
enum class MeshoptFilter : std::uint8_t
{
    None,
    Octahedral,
    Quaternion,
    Exponential,
};

/// A bufferView compressed with EXT_meshopt_compression or KHR_meshopt_compression. Its
/// decoded bytes are the view's range of its (fallback) buffer in GltfAsset::buffers.
struct GltfMeshoptView
{
    std::int32_t view = 0;
    std::string extension;  ///< "EXT_meshopt_compression" or "KHR_meshopt_compression".
    MeshoptMode mode = MeshoptMode::Attributes;
    MeshoptFilter filter = MeshoptFilter::None;
    std::uint64_t stride = 0;
    std::uint64_t count = 0;
    std::int32_t buffer = 0;   ///< The bufferView's (fallback) buffer.
    std::uint64_t offset = 0;  ///< The bufferView's byteOffset in it.
    /// The compressed stream as read (the writer takes its current place from the JSON).
    std::int32_t source_buffer = 0;
    std::uint64_t source_offset = 0;
    std::uint64_t source_length = 0;
    int exponent_bits = 0;  ///< EXPONENTIAL: mantissa bits the stream was encoded with.
    /// Why the stream was not decoded (a codec version, mode or filter this build of
    /// meshoptimizer does not know); empty when it was. An undecoded view keeps the
    /// fallback's bytes (zeros without fallback data), and geometry in it is refused.
    std::string unsupported;
};

/// A decoded Draco primitive: positions (3 per point) as stored in the attribute's data type
/// (float32 values, or the integers of a KHR_mesh_quantization attribute, not normalized),
/// triangles, and the position quantization of the bitstream (0 when not quantized).
struct DracoGeometry
{
    std::vector<double> positions;
    std::vector<std::uint32_t> triangles;
    std::uint32_t point_count = 0;
    int quantization_bits = 0;
    GltfComponent component = GltfComponent::Float32;
    /// The attributes asked for besides the positions (decode_draco's \p more_ids), in that
    /// order: 4 values per point (fewer components padded with 0), converted as the attribute
    /// declares (a normalized integer to [0, 1]).
    std::vector<std::vector<double>> more;
};

/// Everything the preserving glTF/GLB writer needs.
struct GltfAsset
{
    bool is_glb = false;
    std::string json;                 ///< The JSON text exactly as read.
    std::filesystem::path folder;     ///< The source's folder, which relative URIs resolve against.
    std::vector<GltfBuffer> buffers;  ///< Indexed like the JSON "buffers".
    std::string glb_tail;             ///< GLB: chunks after the BIN chunk, verbatim.
    bool glb_has_bin = false;         ///< GLB: the file has a BIN chunk.
    /// GLB: bytes of the BIN chunk after buffer 0 (the whole chunk when no buffer uses it).
    std::string glb_bin_padding;
    std::vector<GltfPositionAccessor> accessors;
    std::vector<GltfDracoPrimitive> draco;
    std::vector<GltfMeshoptView> meshopt;
    /// The geometry of every instance but the first of instanced meshes, in the world frame
    /// (not watermarked; see MeshFile::instances).
    TriangleMesh instances;
    /// read_gltf: tinygltf's parse of the file, kept when it has animations (or a stored blend
    /// of morph targets) so that its poses are walked without parsing it again
    /// (visit_gltf_poses); without its buffers' bytes, which `buffers` holds. Null otherwise.
    std::shared_ptr<const tinygltf::Model> model;
    /// The pose of the animation at the time read_scene was asked for (for_each_animation_pose).
    ShownPose pose;
    /// The animations that animate a node (see MeshFile::animations).
    std::vector<AnimationSpan> animations;
    /// for_each_animation_pose: the welded vertex of every element and the welded stored
    /// positions, from the first time's walk; the others reuse them (the stored positions do
    /// not depend on the time).
    std::vector<std::int32_t> pose_welded;
    std::vector<double> pose_rest;
    /// for_each_animation_pose: each Draco bufferView decoded at the first time, by view.
    std::map<int, DracoGeometry> pose_draco;
};

/// A stored POSITION component as the coordinate a renderer sees (normalized integers
/// mapped to [-1, 1] or [0, 1] as the glTF spec says).
[[nodiscard]] double dequantize(double stored, GltfComponent component, bool is_normalized);
/// Inverse of dequantize: the stored value of a coordinate, before rounding.
[[nodiscard]] double quantize(double value, GltfComponent component, bool is_normalized);
/// The stored values an integer component type can hold and read back as written: [0, 2^b - 1]
/// unsigned, [-(2^(b-1) - 1), 2^(b-1) - 1] signed normalized (its most negative value reads as
/// the next one), the full range signed otherwise; infinite bounds for Float32.
[[nodiscard]] std::pair<double, double> stored_range(GltfComponent component, bool is_normalized);

/// A URI with its %XX escapes decoded (the file name of a relative URI).
[[nodiscard]] std::string percent_decoded(const std::string& uri);

/// Read a .gltf or .glb (already in \p bytes) into its welded world-frame mesh.
[[nodiscard]] TriangleMesh read_gltf(const std::filesystem::path& path, const std::string& bytes,
                                     bool is_glb, GltfAsset& asset);

/// \brief The scene of \p read (as read_gltf left it, its model kept) posed by animation
/// \p animation at each of \p times (for_each_animation_pose): nothing is read or parsed again;
/// each call walks the scene afresh over a copy of its loaded buffers. \p path names the file.
void visit_gltf_poses(const std::filesystem::path& path, const GltfAsset& read,
                      std::span<const double> times, const std::function<void(ShownPose&&)>& visit,
                      std::size_t animation);

/// \brief Write \p asset with welded positions \p original replaced by \p positions to
/// \p path (a .gltf or .glb; external buffers are written beside it), atomically;
/// \p link_folder: see relinked.
void write_gltf_preserving(const std::filesystem::path& path, bool is_glb, const GltfAsset& asset,
                           const Positions& original, const Positions& positions,
                           const std::filesystem::path& link_folder = {});

/// \brief The bytes write_gltf_preserving writes to a path in the source's folder (image URIs
/// as written), as one file; \p path names it in errors.
/// \throws IoError naming \p path when the asset has external buffers.
[[nodiscard]] std::string preserved_gltf_bytes(const std::filesystem::path& path, bool is_glb,
                                               const GltfAsset& asset, const Positions& original,
                                               const Positions& positions);

/// The bytes of a minimal glTF asset (.glb when \p is_glb, else a .gltf with a data: URI).
[[nodiscard]] std::string gltf_bytes(const TriangleMesh& mesh, bool is_glb);

// Container helpers (gltf_container.cpp).

/// The chunks of a GLB file; throws IoError naming \p path when the container is malformed.
struct GlbChunks
{
    std::string json;
    bool has_bin = false;
    std::string bin;  ///< The whole BIN chunk payload (buffer 0 plus padding).
    std::string tail;
};
[[nodiscard]] GlbChunks split_glb(const std::filesystem::path& path, const std::string& bytes);
/// A GLB file from its JSON text and BIN payload (each padded to 4 bytes) and extra chunks.
[[nodiscard]] std::string assemble_glb(const std::filesystem::path& path, const std::string& json,
                                       const std::string* bin, const std::string& tail);
[[nodiscard]] std::string base64_encode(const std::string& bytes);

// Draco (draco.cpp).

[[nodiscard]] DracoGeometry decode_draco(const std::filesystem::path& path,
                                         const std::string& bytes, std::int32_t position_id,
                                         std::span<const std::int32_t> more_ids = {});
/// \brief Re-encode \p bytes with the positions of every point replaced by \p positions
/// (3 per point, stored values in the attribute's data type: integers for integer types),
/// keeping every attribute, its unique id and its quantization.
/// \param keep_order  Use the sequential method, which keeps the point order.
/// \param as_float  Store integer positions as a float32 attribute (same unique id; 16-bit
/// quantization), \p positions then being dequantized values.
[[nodiscard]] std::string reencode_draco(const std::filesystem::path& path,
                                         const std::string& bytes, std::int32_t position_id,
                                         const std::vector<double>& positions, bool keep_order,
                                         bool as_float = false);

// meshopt (meshopt.cpp).

/// Why this build cannot decode a stream with \p header (its first byte) in \p view's mode,
/// or empty when it can; a header of no known codec is a malformed stream (IoError).
[[nodiscard]] std::string meshopt_unsupported(const std::filesystem::path& path,
                                              const GltfMeshoptView& view, unsigned char header);
/// \brief Decode \p stream into view.count * view.stride bytes (filter applied).
/// \param exponent_bits  If not null and the filter is EXPONENTIAL: the mantissa bits the
///     stream was encoded with (the most common over its elements).
[[nodiscard]] std::string decode_meshopt(const std::filesystem::path& path,
                                         const GltfMeshoptView& view, const std::string& stream,
                                         int* exponent_bits = nullptr);
/// Encode \p decoded (view.count * view.stride bytes) with \p view's mode and filter
/// (vertex codec version 0, which every decoder reads).
[[nodiscard]] std::string encode_meshopt(const std::filesystem::path& path,
                                         const GltfMeshoptView& view, const std::string& decoded);

}  // namespace meshmark::detail

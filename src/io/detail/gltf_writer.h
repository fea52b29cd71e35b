// SPDX-License-Identifier: MIT
// The preserving glTF/GLB writer (write_gltf_preserving, preserved_gltf_bytes). Its members
// are defined by job: gltf_write.cpp runs the steps and writes the files (or returns them as
// one file), gltf_quantization.cpp plans the new stored values of each POSITION record and
// fits them to their component type, gltf_vertices_apart.cpp keeps vertices the reader told
// apart from landing on the same float32 values, and gltf_rewrite.cpp rewrites the buffers (plain
// accessors, meshopt streams, Draco data) and the JSON that follows them.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "gltf.h"
#include "gltf_json.h"

namespace meshmark::detail
{

// glTF codes the writers store: componentType and bufferView target.
inline constexpr int kFloat = 5126;
inline constexpr int kUnsignedInt = 5125;
inline constexpr int kArrayBuffer = 34962;
inline constexpr int kElementArrayBuffer = 34963;

/// \brief Copies of the asset's buffers and JSON with welded positions \p original replaced
/// by \p positions; run() writes them, one_file() returns them as one file's bytes. The JSON is
/// parsed on first use and serialized again only when something in it changed.
class GltfWriter
{
public:
    /// \p link_folder: where the output will be read from, when not \p path's folder (see
    /// relinked).
    GltfWriter(const std::filesystem::path& path, const GltfAsset& asset, const Positions& original,
               const Positions& positions, std::filesystem::path link_folder = {});

    /// Rewrite everything and write the asset (and any external buffers beside it, and the
    /// images an output in another folder would miss).
    void run(bool is_glb);

    /// \brief Rewrite everything and return the asset as one file (.glb or .gltf), as run()
    /// writes it into the source's folder (image URIs as written, nothing copied).
    /// \throws IoError when the asset has external buffers (which cannot be one file).
    [[nodiscard]] std::string one_file(bool is_glb);

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

    // gltf_write.cpp
    void rewrite();
    std::string main_file(bool is_glb);
    GltfJson& doc();
    std::vector<std::pair<std::filesystem::path, std::string>> external_files();
    std::vector<std::pair<std::filesystem::path, std::filesystem::path>> image_copies();
    std::string json_text();
    [[noreturn]] void fail(const std::string& what) const;

    // gltf_quantization.cpp
    Plan plan_accessor(std::size_t slot);
    Plan plan_draco(std::size_t slot);
    [[nodiscard]] bool overflows(const Plan& plan) const;
    void fit_range(std::vector<Plan>& plans, std::size_t overflowing);
    [[nodiscard]] std::vector<std::size_t> sharing_group(const std::vector<Plan>& plans,
                                                         std::size_t first,
                                                         std::vector<std::size_t>& nodes);
    void transform_nodes(const std::vector<std::size_t>& nodes, double scale,
                         const std::array<double, 3>& shift);
    void write_float_accessor(const Plan& plan);

    // gltf_vertices_apart.cpp
    void keep_vertices_apart(std::vector<Plan>& plans) const;

    // gltf_rewrite.cpp
    std::string draco_bytes(std::int32_t view);
    void write_accessor(const Plan& plan);
    void update_bounds(const GltfPositionAccessor& record);
    void write_meshopt();
    void write_draco(const Plan& plan);
    void splice(GltfJson& owner, std::size_t buffer, std::uint64_t offset, const std::string& bytes,
                const std::string& what);
    void set_bounds(std::int32_t accessor, const std::array<double, 3>& lo,
                    const std::array<double, 3>& hi, bool is_float);

    const std::filesystem::path& path_;
    const GltfAsset& asset_;
    const Positions& original_;
    const Positions& positions_;
    std::filesystem::path link_folder_;
    std::vector<std::string> buffers_;
    std::optional<GltfJson> doc_;
    bool is_json_changed_ = false;
};

/// Whether row \p row of \p a and \p b differ in any bit.
[[nodiscard]] inline bool is_changed(const Positions& a, const Positions& b, std::int32_t row)
{
    return std::memcmp(a.row(row).data(), b.row(row).data(), 3 * sizeof(double)) != 0;
}

/// Whether \p c is one of the integer types of KHR_mesh_quantization.
[[nodiscard]] inline bool is_integer(GltfComponent c)
{
    return c != GltfComponent::Float32;
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// The pieces of the glTF reader (read_gltf in gltf_read.cpp): where accessor elements lie
// (gltf_accessors.cpp), the meshopt-compressed bufferViews (gltf_meshopt_views.cpp), the
// animations (gltf_animation.cpp; whether one moves only the whole asset: gltf_whole_motion.cpp)
// and the scene reader that turns the loaded model into one welded mesh (read_scene in
// gltf_scene.cpp; its steps in gltf_scene.h, docs/algorithms/gltf.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <tiny_gltf.h>

#include "gltf.h"

namespace meshmark::detail
{

/// The component type of glTF code \p type, or nullopt for a code glTF does not define.
[[nodiscard]] std::optional<GltfComponent> component_of(int type);
/// Bytes of one component.
[[nodiscard]] std::size_t component_size(GltfComponent c);

/// \brief Where the elements of an asset's accessors lie in its loaded buffers.
/// \details Checks every range against its bufferView and buffer (no overflow on hostile
/// sizes) and refuses views that are meshopt streams this build could not decode and that have
/// no fallback data. Errors name the file.
class GltfAccessors
{
public:
    GltfAccessors(const std::filesystem::path& path, const tinygltf::Model& model,
                  const GltfAsset& asset);

    /// \brief The byte location of each element of accessor \p accessor (of \p components
    /// components), after sparse substitution; \p what names it in errors ("POSITION").
    [[nodiscard]] std::vector<GltfElement> locate(int accessor, int components,
                                                  const std::string& what) const;

    /// \brief The values of accessor \p accessor of \p components components (1: SCALAR, 3:
    /// VEC3, 4: VEC4, 16: MAT4, checked), de-normalized as a renderer would, \p components per
    /// element; \p integers_only refuses float and normalized components (joint indices).
    /// Errors name the file and \p what.
    [[nodiscard]] std::vector<double> values(int accessor, int components, const std::string& what,
                                             bool integers_only) const;

    /// The view's byte range lies inside its (loaded) buffer.
    [[nodiscard]] bool is_view_in_buffer(const tinygltf::BufferView& view) const;

private:
    const std::filesystem::path& path_;
    const tinygltf::Model& model_;
    const GltfAsset& asset_;
    std::map<int, std::string> undecoded_;  // undecoded meshopt views without fallback data: why
};

/// The bufferViews compressed with meshopt, as the JSON \p json declares them (checked, not
/// decoded).
[[nodiscard]] std::vector<GltfMeshoptView> meshopt_views(const std::filesystem::path& path,
                                                         const std::string& json);

/// \brief Decode every view of asset.meshopt that this build supports into its range of its
/// (fallback) buffer, so that everything downstream reads the decoded bytes like any other
/// buffer data; the others get their reason in GltfMeshoptView::unsupported.
void decode_meshopt_views(const std::filesystem::path& path, const tinygltf::Model& model,
                          GltfAsset& asset);

/// A node's local matrix: its `matrix`, else its translation, rotation and scale composed.
[[nodiscard]] Eigen::Matrix4d local_matrix(const tinygltf::Node& node);

/// \brief The local matrix of every node of \p model at time \p t of animation \p animation:
/// the translations, rotations and scales its channels give there (before a channel's first key
/// its first value, after the last its last) over the node's own; the nodes it does not
/// animate, and every node when there is no such animation, keep local_matrix().
[[nodiscard]] std::vector<Eigen::Matrix4d> animated_local_matrices(const tinygltf::Model& model,
                                                                   const GltfAccessors& accessors,
                                                                   std::size_t animation, double t);

/// \brief Every node's morph target weights as stored (its `weights`, else its mesh's, else
/// zeros; one per target of its mesh), empty for the nodes without a mesh with targets.
[[nodiscard]] std::vector<std::vector<double>> default_morph_weights(const tinygltf::Model& model);

/// \brief Every node's morph target weights at time \p t of animation \p animation: those its
/// weights channels give there over default_morph_weights(); the defaults for an index past the
/// file's animations.
[[nodiscard]] std::vector<std::vector<double>> animated_morph_weights(
    const tinygltf::Model& model, const GltfAccessors& accessors, std::size_t animation, double t);

/// Animation \p animation has a channel that animates the morph weights of a mesh with targets.
[[nodiscard]] bool has_weights_channel(const tinygltf::Model& model, std::size_t animation);

/// \brief The span of animation \p animation (its channels that move a node or set morph
/// weights), or nothing when
/// it has none or a key time is not finite.
[[nodiscard]] std::optional<AnimationSpan> animation_span(const tinygltf::Model& model,
                                                          const GltfAccessors& accessors,
                                                          std::size_t animation);

/// \brief The nodes every mesh node of the scene under \p roots lies under (from the root down,
/// a mesh node itself when there is one), for moves_only_as_a_whole; nothing when that cannot be
/// told (a skinned mesh, which follows its joints and may be stored in another pose than the
/// skin's rest; a node reached twice).
[[nodiscard]] std::optional<std::vector<int>> shared_mesh_path(const tinygltf::Model& model,
                                                               std::span<const int> roots);

/// \brief Whether animation \p animation only turns, moves or uniformly scales everything under
/// the shared mesh path \p common (AnimationSpan::moves_only_as_a_whole): each node it animates
/// is on it, the nodes down to the deepest of them have similarities as local matrices, and
/// every scale it keys is uniform.
[[nodiscard]] bool moves_only_as_a_whole(const tinygltf::Model& model,
                                         const GltfAccessors& accessors, std::size_t animation,
                                         std::span<const int> common);

/// \brief Walk the scene graph of \p model (buffers and meshopt views already in \p asset)
/// and return its welded world-frame mesh; fills the accessors, Draco primitives and other
/// instances of \p asset and the spans of its animations. Given \p animation_time, only the
/// pose of animation \p animation at that time (GltfAsset::pose; the mesh returned is empty),
/// the welding kept in the asset for the next time.
[[nodiscard]] TriangleMesh read_scene(const std::filesystem::path& path,
                                      const tinygltf::Model& model, GltfAsset& asset,
                                      std::optional<double> animation_time = std::nullopt,
                                      std::size_t animation = 0);

}  // namespace meshmark::detail

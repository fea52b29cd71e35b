// SPDX-License-Identifier: MIT
// The glTF scene reader as a list of steps: the roots, the animations and the shown pose, the
// walk down the node tree with each primitive read once per set of positions, whether each
// animation moves only the whole asset, and the welding into the one mesh that meshmark marks.
// Each step lives in its own file (detail/gltf_scene.h lists them).
#include "io/detail/gltf_scene.h"

#include <optional>
#include <vector>

#include "io/detail/gltf_pose.h"
#include "io/detail/gltf_primitives.h"
#include "io/detail/gltf_reader.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace
{

// Whether each animation only turns, moves or uniformly scales the whole asset
// (AnimationSpan::moves_only_as_a_whole); a scale key that cannot be read means it may bend it.
void mark_whole_asset_moves(const tinygltf::Model& model, const GltfAccessors& accessors,
                            const std::vector<int>& roots, std::vector<AnimationSpan>& spans)
{
    const auto common = spans.empty() ? std::nullopt : shared_mesh_path(model, roots);
    for (AnimationSpan& span : spans)
    {
        try
        {
            span.moves_only_as_a_whole =
                common && moves_only_as_a_whole(model, accessors, span.index, *common);
        }
        catch (const IoError&)
        {
        }
    }
}

}  // namespace

TriangleMesh read_scene(const std::filesystem::path& path, const tinygltf::Model& model,
                        GltfAsset& asset, std::optional<double> animation_time,
                        std::size_t animation)
{
    const GltfAccessors accessors(path, model, asset);
    const SceneFile file{path, model, accessors};
    const std::vector<int> roots = scene_roots(model);
    if (!animation_time)
    {
        add_animation_spans(model, accessors, asset.animations);
    }
    const ScenePose pose =
        animation_time ? scene_pose(model, accessors, animation, *animation_time) : ScenePose{};
    if (animation_time && pose.empty())
    {
        return TriangleMesh{};  // (only the pose was asked for, and at that time nothing moves)
    }
    SceneElements elements(!pose.empty());
    ScenePrimitives primitives(file, pose, animation_time, asset, elements);
    walk_scene(file, roots, pose.locals,
               [&](int mesh, const Placement& place, int skin)
               { primitives.add_mesh(mesh, place, skin); });
    mark_whole_asset_moves(model, accessors, roots, asset.animations);
    return weld_scene(path, elements, primitives.starts(), pose, animation_time, asset);
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// The primitives of the glTF scene (gltf_primitives.cpp: what every use of a set of positions
// adds, and the POSITION accessors; gltf_draco_primitive.cpp: the Draco-compressed ones).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <tiny_gltf.h>

#include "gltf.h"
#include "gltf_pose.h"
#include "gltf_scene.h"
#include "gltf_skin.h"

namespace meshmark::detail
{

/// \brief Reads the triangle and point primitives the walk shows into SceneElements and their
/// records into the asset (GltfAsset::accessors, GltfAsset::draco).
/// \details A set of positions (a POSITION accessor, or a Draco bufferView) is read once, at
/// its first use: its elements are placed in the world frame (by its skin, into the pose, its
/// morph targets blended there). A later use under another transform is another instance,
/// kept aside for registration (MeshFile::instances): its vertices cannot take a second
/// displacement. A later use by the same skin, or under the same transform, shows the same
/// elements; a use under another skin is neither marked nor kept aside.
class ScenePrimitives
{
public:
    /// \p pose: the shown pose (empty when none); \p animation_time: only the pose is read
    /// (each Draco view decoded once for every time, GltfAsset::pose_draco).
    ScenePrimitives(const SceneFile& file, const ScenePose& pose,
                    std::optional<double> animation_time, GltfAsset& asset, SceneElements& elements)
        : file_(file),
          pose_(pose),
          animation_time_(animation_time),
          asset_(asset),
          elements_(elements)
    {
    }

    /// Every triangle and point primitive of mesh \p mesh shown at \p place (by skin \p skin
    /// when >= 0); lines, strips and fans are carried through untouched.
    void add_mesh(int mesh, const Placement& place, int skin);

    /// Where each record's elements start.
    [[nodiscard]] const RecordStarts& starts() const { return starts_; }

private:
    // A set of positions read at its first use: its elements, the transform and skin it was
    // read with, and (Draco) its triangles' range of SceneElements::corners.
    struct Slot
    {
        std::size_t first = 0;
        std::size_t count = 0;
        Eigen::Matrix4d to_world = Eigen::Matrix4d::Identity();
        int skin = -1;
        std::size_t corners_begin = 0;
        std::size_t corners_end = 0;
    };
    // What a later use of a slot adds.
    enum class LaterUse
    {
        Nothing,       // another skin's use: neither marked nor kept aside
        SameElements,  // the same skin, or the same transform: its triangles over the slot's
                       // elements
        Instance,      // another transform: another instance, kept aside
    };

    void add_accessor_primitive(const tinygltf::Primitive& prim, const std::string& where,
                                const Placement& place, int skin);
    void add_draco_primitive(const tinygltf::Primitive& prim, int mesh, int index,
                             const std::string& where, const Placement& place, int skin);
    // What a later use of \p slot by \p skin under \p to_world adds (an instance's points added,
    // from \p instance_base on).
    LaterUse later_use(const Slot& slot, int skin, const Eigen::Matrix4d& to_world,
                       std::size_t& instance_base);
    // A first use's elements placed (by \p sets when \p skin >= 0); returns the skinning matrices.
    std::vector<Eigen::Matrix4d> place_first_use(const tinygltf::Primitive& prim,
                                                 const std::string& where,
                                                 const std::vector<double>& local,
                                                 const SkinSets& sets, int skin,
                                                 const Placement& place);
    // The local positions of a POSITION accessor's elements, as a renderer reads them.
    [[nodiscard]] std::vector<double> accessor_positions(const GltfPositionAccessor& record) const;
    // The Draco data of bufferView \p view_index decoded (when posing, once for every time: the
    // asset's cache), else into \p decoded.
    const DracoGeometry& draco_geometry(int view_index, std::int32_t position_id,
                                        const std::vector<std::int32_t>& skin_ids,
                                        DracoGeometry& decoded);
    // The triangles of \p prim's indices (or of its elements in order), over \p count elements
    // from \p base, appended to \p corners.
    void add_indexed_triangles(const tinygltf::Primitive& prim, const std::string& where,
                               std::size_t base, std::size_t count,
                               std::vector<std::size_t>& corners) const;

    SceneFile file_;
    const ScenePose& pose_;
    std::optional<double> animation_time_;
    GltfAsset& asset_;
    SceneElements& elements_;
    std::map<int, Slot> accessor_slots_;  // by POSITION accessor
    std::map<int, Slot> draco_slots_;     // by Draco bufferView
    RecordStarts starts_;
    std::vector<Eigen::Matrix4d>
        rest_globals_;  // every node's stored world matrix (skins; made once)
};

}  // namespace meshmark::detail

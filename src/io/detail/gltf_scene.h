// SPDX-License-Identifier: MIT
// The glTF scene reader's shared types and its two ends: the walk down the node tree
// (gltf_scene_walk.cpp) and the welding of what the primitives gathered into one mesh
// (gltf_scene_weld.cpp). read_scene (gltf_scene.cpp) lists the steps; the pose, the morph
// targets and the skins are in gltf_pose.h and gltf_skin.h, the primitives in gltf_primitives.h.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/LU>
#include <tiny_gltf.h>

#include "gltf.h"
#include "gltf_reader.h"

namespace meshmark::detail
{

/// What every step of the scene reader reads: the file (named in errors), its loaded model and
/// where its accessors' elements lie.
struct SceneFile
{
    const std::filesystem::path& path;
    const tinygltf::Model& model;
    const GltfAccessors& accessors;
};

/// Where a node shows its mesh: its world matrix as stored and in the shown pose (the same
/// when nothing is posed), and the node (-1 above the roots).
struct Placement
{
    Eigen::Matrix4d to_world;
    Eigen::Matrix4d posed;
    int node = -1;
};

/// Two matrices are the same to the bit (one transform group, one instance).
[[nodiscard]] inline bool same_matrix(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    return std::memcmp(a.data(), b.data(), sizeof(double) * 16) == 0;
}

/// A linear part whose determinant is below this fraction of its mean squared column norm to
/// the power 3/2 (a volume scale) collapses space: no inverse carries a displacement back.
inline constexpr double kCollapsedVolumeRel = 1e-9;

/// \brief The 3x3 linear part \p m keeps volume (kCollapsedVolumeRel), so a displacement made
/// after it can be mapped back. A template so each caller's Eigen expression is evaluated as
/// it always was (a block of a 4x4 or a 3x3).
template <class Matrix>
[[nodiscard]] bool keeps_volume(const Matrix& m)
{
    const double det = m.determinant();
    const double scale = m.squaredNorm() / 3.0;  // mean squared column norm
    return std::abs(det) > kCollapsedVolumeRel * std::pow(scale, 1.5);
}

/// \brief The scene's elements before welding, as the primitives add them: each element's
/// world position and transform group, the triangles over them, the other instances kept
/// aside and, when a pose is shown, each element's place in it and the way back.
struct SceneElements
{
    explicit SceneElements(bool posed) : is_posed(posed) {}

    bool is_posed = false;                ///< A pose is shown (posed_world and to_rest filled).
    std::vector<double> world;            ///< 3 per element.
    std::vector<std::int32_t> group;      ///< The transform group of each element.
    std::vector<Eigen::Matrix4d> groups;  ///< Distinct world transforms (and one per skinned use).
    std::vector<std::size_t> corners;     ///< Element ids, 3 per triangle.
    std::vector<double> instance_xyz;     ///< Other instances, world frame, 3 per point.
    std::vector<std::size_t> instance_corners;  ///< Their triangles, into instance_xyz.
    std::vector<double> posed_world;            ///< Each element in the shown pose, 3 per element.
    std::vector<Eigen::Matrix3d> to_rest;       ///< Each element: a displacement in the pose, back.

    /// Elements so far (the id of the next one).
    [[nodiscard]] std::size_t size() const { return group.size(); }
    /// The group of the world transform \p to_world, a new one for a matrix not seen yet.
    [[nodiscard]] std::int32_t group_of(const Eigen::Matrix4d& to_world);
    /// A new group of its own for \p to_world (a skinned use's elements).
    [[nodiscard]] std::int32_t new_group(const Eigen::Matrix4d& to_world);
    /// \brief The elements of \p local (3 per element) placed by \p place into \p in_group, and
    /// into the shown pose (as \p shown when not empty: the shape its morph targets blend) unless
    /// \p with_pose is false (the caller placed them there).
    void append(const std::vector<double>& local, const Placement& place, std::int32_t in_group,
                const std::vector<double>& shown = {}, bool with_pose = true);
    /// One element's place in the pose (\p posed of \p local) and the map back to \p rest's frame.
    void add_posed(const Eigen::Vector4d& local, const Eigen::Matrix4d& rest,
                   const Eigen::Matrix4d& posed);
    /// \brief The points of another instance of elements [first, first + count), first read under
    /// \p from, now under \p to; returns the index of its first point in instance_xyz.
    [[nodiscard]] std::size_t add_instance(std::size_t first, std::size_t count,
                                           const Eigen::Matrix4d& from, const Eigen::Matrix4d& to);
};

/// Where the elements of each record of the asset start among SceneElements (accessors[k] is
/// the first element of GltfAsset::accessors[k], draco[k] of GltfAsset::draco[k]).
struct RecordStarts
{
    std::vector<std::size_t> accessors;
    std::vector<std::size_t> draco;
};

/// The roots of the scene: the default scene's, else every scene's, else every node that is no
/// one's child.
[[nodiscard]] std::vector<int> scene_roots(const tinygltf::Model& model);

/// \brief Walk the node tree down from \p roots (checked: node and mesh indices, cycles, a
/// bound on visits, finite transforms), calling \p show_mesh for every node with a mesh whose
/// transform does not collapse it, with its placement (in \p posed_locals' pose when not empty)
/// and skin.
void walk_scene(const SceneFile& file, const std::vector<int>& roots,
                const std::vector<Eigen::Matrix4d>& posed_locals,
                const std::function<void(int mesh, const Placement& place, int skin)>& show_mesh);

struct ScenePose;

/// \brief Weld \p elements into the scene's mesh: hands each record of \p asset its welded
/// vertices, keeps the other instances; given \p animation_time, only the pose (kept in
/// GltfAsset::pose unless it is a similarity of the stored positions; the welding cached in
/// the asset for the next time) and an empty mesh.
[[nodiscard]] TriangleMesh weld_scene(const std::filesystem::path& path,
                                      const SceneElements& elements, const RecordStarts& starts,
                                      const ScenePose& pose, std::optional<double> animation_time,
                                      GltfAsset& asset);

}  // namespace meshmark::detail

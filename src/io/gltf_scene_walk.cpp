// SPDX-License-Identifier: MIT
// The glTF scene walk: the roots of the scene, and node transforms down the tree to every
// node that shows a mesh (checked against hostile files: indices, cycles, a bound on visits).
#include <cmath>
#include <string>
#include <vector>

#include "io/detail/gltf_scene.h"
#include "io/detail/support.h"

namespace meshmark::detail
{

namespace
{

// Node visits allowed while walking the scene graph (a DAG of shared children can otherwise
// explode exponentially in a hostile file); ~1M is far above any real scene's node count.
constexpr std::size_t kMaxNodeVisits = 1U << 20U;

struct Walk
{
    const SceneFile& file;
    const std::vector<Eigen::Matrix4d>& posed_locals;
    const std::function<void(int mesh, const Placement& place, int skin)>& show_mesh;
    std::vector<char> on_stack;
    std::size_t visits = 0;

    void visit(int node_index, const Placement& parent);
};

void Walk::visit(int node_index, const Placement& parent)
{
    const tinygltf::Model& model = file.model;
    if (node_index < 0 || static_cast<std::size_t>(node_index) >= model.nodes.size())
    {
        fail_io(file.path, "node index " + std::to_string(node_index) + " is out of range");
    }
    const auto n = static_cast<std::size_t>(node_index);
    if (on_stack[n] != 0)
    {
        fail_io(file.path, "node " + std::to_string(node_index) +
                               " is its own ancestor (a cycle in the node tree)");
    }
    if (++visits > kMaxNodeVisits)
    {
        fail_io(file.path,
                "the node graph expands to more than " + std::to_string(kMaxNodeVisits) + " nodes");
    }
    const auto& node = model.nodes[n];
    const Eigen::Matrix4d to_world = parent.to_world * local_matrix(node);
    const Placement place{
        to_world, posed_locals.empty() ? to_world : Eigen::Matrix4d(parent.posed * posed_locals[n]),
        node_index};
    if (!to_world.allFinite())
    {
        fail_io(file.path, "node " + std::to_string(node_index) + " has a non-finite transform");
    }
    if (node.mesh >= 0)
    {
        if (static_cast<std::size_t>(node.mesh) >= model.meshes.size())
        {
            fail_io(file.path, "node " + std::to_string(node_index) + " refers to missing mesh " +
                                   std::to_string(node.mesh));
        }
        // A singular transform (zero scale) hides the mesh: it has no world geometry to mark.
        if (std::abs(to_world.topLeftCorner<3, 3>().determinant()) > 0.0)
        {
            show_mesh(node.mesh, place, node.skin);
        }
    }
    on_stack[n] = 1;
    for (const int child : node.children)
    {
        visit(child, place);
    }
    on_stack[n] = 0;
}

}  // namespace

std::vector<int> scene_roots(const tinygltf::Model& model)
{
    std::vector<int> roots;
    const auto scene_count = static_cast<int>(model.scenes.size());
    if (model.defaultScene >= 0 && model.defaultScene < scene_count)
    {
        return model.scenes[static_cast<std::size_t>(model.defaultScene)].nodes;
    }
    if (scene_count > 0)
    {
        for (const auto& scene : model.scenes)
        {
            roots.insert(roots.end(), scene.nodes.begin(), scene.nodes.end());
        }
        return roots;
    }
    std::vector<char> is_child(model.nodes.size(), 0);
    for (const auto& node : model.nodes)
    {
        for (const int c : node.children)
        {
            if (c >= 0 && static_cast<std::size_t>(c) < is_child.size())
            {
                is_child[static_cast<std::size_t>(c)] = 1;
            }
        }
    }
    for (std::size_t n = 0; n < is_child.size(); ++n)
    {
        if (is_child[n] == 0)
        {
            roots.push_back(static_cast<int>(n));
        }
    }
    return roots;
}

void walk_scene(const SceneFile& file, const std::vector<int>& roots,
                const std::vector<Eigen::Matrix4d>& posed_locals,
                const std::function<void(int mesh, const Placement& place, int skin)>& show_mesh)
{
    Walk walk{file, posed_locals, show_mesh, std::vector<char>(file.model.nodes.size(), 0), 0};
    for (const int root : roots)
    {
        walk.visit(root, {Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity(), -1});
    }
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// Whether an animation only turns, moves or uniformly scales the whole glTF asset (a turntable,
// AnimationSpan::moves_only_as_a_whole): every node it animates lies on the path shared by every
// mesh node, with similarities as local matrices down to the deepest of them.
#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "io/detail/gltf_channels.h"
#include "io/detail/gltf_reader.h"

namespace meshmark::detail
{

namespace
{

// How far from uniform a scale may be and still count as one: float32 rounding (Blender writes
// a scale of 1.3 as 1.2999998, 1.29999995, 1.2999998), far below what a mark moves.
constexpr double kUniformScaleTolerance = 1e-6;

// A linear part that is a similarity: orthogonal columns of one length (a rotation or
// reflection times a uniform scale), to kUniformScaleTolerance of that length.
bool is_similarity(const Eigen::Matrix3d& L)
{
    const Eigen::Matrix3d gram = L.transpose() * L;
    const double c = gram.trace() / 3.0;
    return (gram - c * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <=
           2.0 * kUniformScaleTolerance * std::max(c, 1e-300);
}

// Every triple of \p xyz has one value three times (to kUniformScaleTolerance relative).
bool are_uniform(const std::vector<double>& xyz)
{
    for (std::size_t k = 0; k + 2 < xyz.size(); k += 3)
    {
        const double tolerance = kUniformScaleTolerance * std::abs(xyz[k]);
        if (std::abs(xyz[k + 1] - xyz[k]) > tolerance || std::abs(xyz[k + 2] - xyz[k]) > tolerance)
        {
            return false;
        }
    }
    return true;
}

}  // namespace

std::optional<std::vector<int>> shared_mesh_path(const tinygltf::Model& model,
                                                 std::span<const int> roots)
{
    const std::size_t count = model.nodes.size();
    const auto in_range = [count](int n) { return n >= 0 && static_cast<std::size_t>(n) < count; };
    // Each reached node's parent (-1 for a root), and the nodes with a mesh. A skinned mesh is
    // left to the poses themselves: it follows its joints, and its stored shape may be another
    // pose than the skin's rest (the reader then reads it through its node).
    std::vector<int> parent(count, -1);
    std::vector<char> reached(count, 0);
    std::vector<int> mesh_nodes;
    std::vector<int> stack;
    for (const int root : roots)
    {
        if (!in_range(root) || reached[static_cast<std::size_t>(root)] != 0)
        {
            return std::nullopt;
        }
        reached[static_cast<std::size_t>(root)] = 1;
        stack.push_back(root);
    }
    while (!stack.empty())
    {
        const int n = stack.back();
        stack.pop_back();
        const auto& node = model.nodes[static_cast<std::size_t>(n)];
        if (node.mesh >= 0)
        {
            if (node.skin >= 0)
            {
                return std::nullopt;
            }
            mesh_nodes.push_back(n);
        }
        for (const int c : node.children)
        {
            if (!in_range(c) || reached[static_cast<std::size_t>(c)] != 0)
            {
                return std::nullopt;  // (a node with two parents or a cycle: no single path to it)
            }
            reached[static_cast<std::size_t>(c)] = 1;
            parent[static_cast<std::size_t>(c)] = n;
            stack.push_back(c);
        }
    }
    // The path from the root down to each mesh node; what they all share.
    std::vector<int> common;
    bool first = true;
    for (const int p : mesh_nodes)
    {
        std::vector<int> path;
        for (int n = p; n >= 0; n = parent[static_cast<std::size_t>(n)])
        {
            path.push_back(n);
        }
        std::reverse(path.begin(), path.end());
        if (first)
        {
            common = std::move(path);
            first = false;
        }
        else
        {
            const auto end =
                std::mismatch(common.begin(), common.end(), path.begin(), path.end()).first;
            common.erase(end, common.end());
        }
    }
    return common;
}

bool moves_only_as_a_whole(const tinygltf::Model& model, const GltfAccessors& accessors,
                           std::size_t animation, std::span<const int> common)
{
    if (animation >= model.animations.size())
    {
        return false;
    }
    // Every animated node on the shared path; every scale uniform down to the deepest of them.
    const auto& a = model.animations[animation];
    std::ptrdiff_t deepest = -1;
    for (std::size_t k = 0; k < a.channels.size(); ++k)
    {
        const auto& channel = a.channels[k];
        if (channel_components(model, a, channel) == 0)
        {
            continue;
        }
        if (path_of(channel) == ChannelPath::Weights)
        {
            return false;  // (a blend of morph targets changes the shape)
        }
        const auto at = std::find(common.begin(), common.end(), channel.target_node);
        if (at == common.end())
        {
            return false;
        }
        deepest = std::max(deepest, at - common.begin());
        if (channel.target_path == "scale" &&
            !are_uniform(
                accessors.values(a.samplers[static_cast<std::size_t>(channel.sampler)].output, 3,
                                 "animation " + std::to_string(animation) + " channel " +
                                     std::to_string(k) + " output",
                                 false)))
        {
            return false;
        }
    }
    if (deepest < 0)
    {
        return false;
    }
    for (std::ptrdiff_t i = 0; i <= deepest; ++i)
    {
        const auto& node =
            model.nodes[static_cast<std::size_t>(common[static_cast<std::size_t>(i)])];
        if (!is_similarity(local_matrix(node).topLeftCorner<3, 3>()))
        {
            return false;
        }
    }
    return true;
}

}  // namespace meshmark::detail

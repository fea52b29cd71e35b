// SPDX-License-Identifier: MIT
// Nodes' local matrices: as stored (local_matrix), and as one animation gives them at one time,
// the translation, rotation and scale each of its channels gives its node (STEP; LINEAR,
// rotations as Blender interpolates them; CUBICSPLINE as the specification's Hermite form, where
// Blender instead fits its own automatic Bezier handles through the keys), composed the same way.
// Written here rather than taken from a library: tinygltf loads the samplers but does not
// evaluate them, and the few lines below are the specification's formulas. Morph target
// weights (shape keys) are sampled the same way, per node (animated_morph_weights): the pose a
// viewer shows blends the targets into the base positions the mark lives in. Whether an
// animation moves only the whole asset is gltf_whole_motion.cpp.
#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "io/detail/gltf_channels.h"
#include "io/detail/gltf_reader.h"

namespace meshmark::detail
{
namespace
{

struct Trs
{
    Eigen::Vector3d translation = Eigen::Vector3d::Zero();
    Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
    Eigen::Vector3d scale = Eigen::Vector3d::Ones();
};

Trs trs_of(const tinygltf::Node& node)
{
    Trs trs;
    if (node.translation.size() == 3)
    {
        trs.translation =
            Eigen::Vector3d(node.translation[0], node.translation[1], node.translation[2]);
    }
    if (node.rotation.size() == 4)
    {
        // glTF stores (x, y, z, w); Eigen's constructor takes (w, x, y, z).
        trs.rotation = Eigen::Quaterniond(node.rotation[3], node.rotation[0], node.rotation[1],
                                          node.rotation[2]);
    }
    if (node.scale.size() == 3)
    {
        trs.scale = Eigen::Vector3d(node.scale[0], node.scale[1], node.scale[2]);
    }
    return trs;
}

Eigen::Matrix4d matrix_of(Trs trs)
{
    if (trs.rotation.norm() > 0.0)
    {
        trs.rotation.normalize();
    }
    Eigen::Affine3d t = Eigen::Affine3d::Identity();
    t.translate(trs.translation);
    t.rotate(trs.rotation);
    t.scale(trs.scale);
    return t.matrix();
}

// The sampler's value at time t, `components` numbers (3: translation or scale, 4: rotation as
// x, y, z, w, or one weight per morph target, stored as scalars). Before the first key: its
// value; after the last: the last one's.
std::vector<double> sample(const GltfAccessors& accessors,
                           const tinygltf::AnimationSampler& sampler, ChannelPath path,
                           int components, double t, const std::string& what)
{
    const std::vector<double> times = accessors.values(sampler.input, 1, what + " input", false);
    const std::vector<double> output = accessors.values(
        sampler.output, path == ChannelPath::Weights ? 1 : components, what + " output", false);
    const bool is_cubic = sampler.interpolation == "CUBICSPLINE";
    const std::size_t per_key = (is_cubic ? 3U : 1U) * static_cast<std::size_t>(components);
    const auto c = static_cast<std::size_t>(components);
    if (times.empty() || output.size() < times.size() * per_key)
    {
        return {};  // a malformed sampler poses nothing
    }
    // A key's value (the middle of a cubic spline's in-tangent, value, out-tangent triple).
    const auto value = [&](std::size_t k, std::size_t part = 1)
    {
        const std::size_t at = k * per_key + (is_cubic ? part * c : 0);
        return std::vector<double>(output.begin() + static_cast<std::ptrdiff_t>(at),
                                   output.begin() + static_cast<std::ptrdiff_t>(at + c));
    };
    if (t <= times.front() || times.size() == 1)
    {
        return value(0);
    }
    if (t >= times.back())
    {
        return value(times.size() - 1);
    }
    const auto k =
        static_cast<std::size_t>(std::upper_bound(times.begin(), times.end(), t) - times.begin()) -
        1;
    const double span = times[k + 1] - times[k];
    const double s = span > 0.0 ? (t - times[k]) / span : 0.0;
    if (sampler.interpolation == "STEP")
    {
        return value(k);
    }
    std::vector<double> result(c);
    if (is_cubic)
    {
        const std::vector<double> v0 = value(k);
        const std::vector<double> b0 = value(k, 2);      // out-tangent of key k
        const std::vector<double> a1 = value(k + 1, 0);  // in-tangent of key k + 1
        const std::vector<double> v1 = value(k + 1);
        const double s2 = s * s;
        const double s3 = s2 * s;
        for (std::size_t d = 0; d < c; ++d)
        {
            result[d] = (2 * s3 - 3 * s2 + 1) * v0[d] + (s3 - 2 * s2 + s) * span * b0[d] +
                        (-2 * s3 + 3 * s2) * v1[d] + (s3 - s2) * span * a1[d];
        }
        return result;
    }
    const std::vector<double> v0 = value(k);
    const std::vector<double> v1 = value(k + 1);
    if (path == ChannelPath::Rotation)
    {
        const Eigen::Quaterniond q0(v0[3], v0[0], v0[1], v0[2]);
        const Eigen::Quaterniond q1(v1[3], v1[0], v1[1], v1[2]);
        // As Blender's importer: the next key turned into the same hemisphere, then the
        // components interpolated linearly and normalized (not the specification's slerp; a
        // full turn between keys differs by up to 2.8% of the diagonal on assimp's Collada
        // sample).
        const double sign = q0.coeffs().dot(q1.coeffs()) < 0.0 ? -1.0 : 1.0;
        Eigen::Quaterniond q;
        q.coeffs() = (1.0 - s) * q0.coeffs() + s * sign * q1.coeffs();
        return {q.x(), q.y(), q.z(), q.w()};
    }
    for (std::size_t d = 0; d < c; ++d)
    {
        result[d] = (1.0 - s) * v0[d] + s * v1[d];
    }
    return result;
}

// The morph targets of the mesh of \p node (0 without a mesh or one out of range): a morph
// weights channel or a node's `weights` gives one number per target of its first primitive
// (the specification requires every primitive to have the same number).
std::size_t morph_target_count(const tinygltf::Model& model, const tinygltf::Node& node)
{
    if (node.mesh < 0 || static_cast<std::size_t>(node.mesh) >= model.meshes.size())
    {
        return 0;
    }
    const auto& mesh = model.meshes[static_cast<std::size_t>(node.mesh)];
    return mesh.primitives.empty() ? 0 : mesh.primitives.front().targets.size();
}

}  // namespace

ChannelPath path_of(const tinygltf::AnimationChannel& channel)
{
    const auto& path = channel.target_path;
    return path == "translation" ? ChannelPath::Translation
           : path == "rotation"  ? ChannelPath::Rotation
           : path == "scale"     ? ChannelPath::Scale
           : path == "weights"   ? ChannelPath::Weights
                                 : ChannelPath::Other;
}

// The numbers a channel of \p a sets on its node (3: translation or scale, 4: rotation, one per
// morph target: weights), or 0 for a channel that is not read: an unknown path (a pointer
// extension's), a node given as a matrix and animated (the specification forbids it), weights
// of a node without morph targets, a target or sampler out of range.
int channel_components(const tinygltf::Model& model, const tinygltf::Animation& a,
                       const tinygltf::AnimationChannel& channel)
{
    if (channel.target_node < 0 ||
        static_cast<std::size_t>(channel.target_node) >= model.nodes.size() ||
        channel.sampler < 0 || static_cast<std::size_t>(channel.sampler) >= a.samplers.size())
    {
        return 0;
    }
    const auto& node = model.nodes[static_cast<std::size_t>(channel.target_node)];
    switch (path_of(channel))
    {
        case ChannelPath::Weights:
            return static_cast<int>(
                std::min<std::size_t>(morph_target_count(model, node), 1U << 16U));
        case ChannelPath::Rotation:
            return node.matrix.size() == 16 ? 0 : 4;
        case ChannelPath::Translation:
        case ChannelPath::Scale:
            return node.matrix.size() == 16 ? 0 : 3;
        case ChannelPath::Other:
            break;
    }
    return 0;
}

std::optional<AnimationSpan> animation_span(const tinygltf::Model& model,
                                            const GltfAccessors& accessors, std::size_t animation)
{
    if (animation >= model.animations.size())
    {
        return std::nullopt;
    }
    const auto& a = model.animations[animation];
    AnimationSpan span;
    span.name = a.name.empty() ? "animation " + std::to_string(animation) : a.name;
    bool any = false;
    for (std::size_t k = 0; k < a.channels.size(); ++k)
    {
        if (channel_components(model, a, a.channels[k]) == 0)
        {
            continue;
        }
        const std::vector<double> times = accessors.values(
            a.samplers[static_cast<std::size_t>(a.channels[k].sampler)].input, 1,
            "animation " + std::to_string(animation) + " channel " + std::to_string(k) + " input",
            false);
        if (times.empty())
        {
            continue;
        }
        const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
        if (!std::isfinite(*lo) || !std::isfinite(*hi))
        {
            return std::nullopt;
        }
        span.first_key = any ? std::min(span.first_key, *lo) : *lo;
        span.last_key = any ? std::max(span.last_key, *hi) : *hi;
        any = true;
    }
    if (!any)
    {
        return std::nullopt;
    }
    return span;
}

Eigen::Matrix4d local_matrix(const tinygltf::Node& node)
{
    if (node.matrix.size() == 16)
    {
        Eigen::Matrix4d m;
        for (int k = 0; k < 16; ++k)
        {
            m(k % 4, k / 4) = node.matrix[static_cast<std::size_t>(k)];  // column-major
        }
        return m;
    }
    return matrix_of(trs_of(node));
}

std::vector<Eigen::Matrix4d> animated_local_matrices(const tinygltf::Model& model,
                                                     const GltfAccessors& accessors,
                                                     std::size_t animation, double t)
{
    std::vector<Eigen::Matrix4d> locals(model.nodes.size());
    for (std::size_t n = 0; n < model.nodes.size(); ++n)
    {
        locals[n] = local_matrix(model.nodes[n]);
    }
    if (animation >= model.animations.size())
    {
        return locals;
    }
    const auto& a = model.animations[animation];
    std::vector<Trs> posed(model.nodes.size());
    std::vector<char> is_posed(model.nodes.size(), 0);
    for (std::size_t k = 0; k < a.channels.size(); ++k)
    {
        const auto& channel = a.channels[k];
        const ChannelPath path = path_of(channel);
        const int components = channel_components(model, a, channel);
        if (components == 0 || path == ChannelPath::Weights)
        {
            continue;
        }
        const auto n = static_cast<std::size_t>(channel.target_node);
        const std::vector<double> v = sample(
            accessors, a.samplers[static_cast<std::size_t>(channel.sampler)], path, components, t,
            "animation " + std::to_string(animation) + " channel " + std::to_string(k));
        if (v.empty())
        {
            continue;
        }
        if (is_posed[n] == 0)
        {
            posed[n] = trs_of(model.nodes[n]);
            is_posed[n] = 1;
        }
        if (path == ChannelPath::Rotation)
        {
            posed[n].rotation = Eigen::Quaterniond(v[3], v[0], v[1], v[2]);
        }
        else if (path == ChannelPath::Translation)
        {
            posed[n].translation = Eigen::Vector3d(v[0], v[1], v[2]);
        }
        else
        {
            posed[n].scale = Eigen::Vector3d(v[0], v[1], v[2]);
        }
    }
    for (std::size_t n = 0; n < model.nodes.size(); ++n)
    {
        if (is_posed[n] != 0)
        {
            locals[n] = matrix_of(posed[n]);
        }
    }
    return locals;
}

std::vector<std::vector<double>> default_morph_weights(const tinygltf::Model& model)
{
    std::vector<std::vector<double>> weights(model.nodes.size());
    for (std::size_t n = 0; n < model.nodes.size(); ++n)
    {
        const auto& node = model.nodes[n];
        const std::size_t count = morph_target_count(model, node);
        if (count == 0)
        {
            continue;
        }
        // The node's weights, else its mesh's, else zeros (the specification's defaults).
        const std::vector<double>& given =
            !node.weights.empty() ? node.weights
                                  : model.meshes[static_cast<std::size_t>(node.mesh)].weights;
        weights[n].assign(count, 0.0);
        std::copy_n(given.begin(), std::min(given.size(), count), weights[n].begin());
    }
    return weights;
}

std::vector<std::vector<double>> animated_morph_weights(const tinygltf::Model& model,
                                                        const GltfAccessors& accessors,
                                                        std::size_t animation, double t)
{
    std::vector<std::vector<double>> weights = default_morph_weights(model);
    if (animation >= model.animations.size())
    {
        return weights;
    }
    const auto& a = model.animations[animation];
    for (std::size_t k = 0; k < a.channels.size(); ++k)
    {
        const auto& channel = a.channels[k];
        const int components = channel_components(model, a, channel);
        if (components == 0 || path_of(channel) != ChannelPath::Weights)
        {
            continue;
        }
        std::vector<double> v =
            sample(accessors, a.samplers[static_cast<std::size_t>(channel.sampler)],
                   ChannelPath::Weights, components, t,
                   "animation " + std::to_string(animation) + " channel " + std::to_string(k));
        if (!v.empty())
        {
            weights[static_cast<std::size_t>(channel.target_node)] = std::move(v);
        }
    }
    return weights;
}

bool has_weights_channel(const tinygltf::Model& model, std::size_t animation)
{
    if (animation >= model.animations.size())
    {
        return false;
    }
    const auto& a = model.animations[animation];
    return std::any_of(a.channels.begin(), a.channels.end(),
                       [&](const tinygltf::AnimationChannel& channel) {
                           return path_of(channel) == ChannelPath::Weights &&
                                  channel_components(model, a, channel) > 0;
                       });
}

}  // namespace meshmark::detail

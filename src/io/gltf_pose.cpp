// SPDX-License-Identifier: MIT
// The pose a viewer shows of an animated glTF scene: which animations count (their spans, and
// the stored blend of morph targets as one more), and at a time of one of them every node's
// local and world matrix and morph weights.
#include "io/detail/gltf_pose.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "meshmark/core/error.h"

namespace meshmark::detail
{

namespace
{

// Blender shows an animation in frames at 24 per second (its default scene rate).
constexpr double kFramesPerSecond = 24.0;
// A key time within this fraction of a frame number of it is that frame: float32 key times
// (~6e-8 relative) miss the exact frame by far less.
constexpr double kFrameTolerance = 1e-6;

// A time of an animation as Blender's frames show it ("10/24 s": frame 10 at 24 frames per
// second), or in seconds when it falls between frames.
std::string time_name(double t)
{
    const double frame = std::round(t * kFramesPerSecond);
    if (std::abs(t * kFramesPerSecond - frame) <= kFrameTolerance * std::max(1.0, std::abs(frame)))
    {
        return std::to_string(static_cast<long long>(frame)) + "/24 s";
    }
    std::ostringstream out;
    out << t << " s";
    return out.str();
}

}  // namespace

// A malformed animation only means no animation. The stored blend (shape keys left at a
// value) counts as a pose because a viewer shows it, and Blender's copies carry it.
void add_animation_spans(const tinygltf::Model& model, const GltfAccessors& accessors,
                         std::vector<AnimationSpan>& spans)
{
    bool blends = false;
    for (std::size_t a = 0; a < model.animations.size(); ++a)
    {
        try
        {
            if (auto span = animation_span(model, accessors, a))
            {
                span->index = a;
                spans.push_back(std::move(*span));
                blends = blends || has_weights_channel(model, a);
            }
        }
        catch (const IoError&)
        {
        }
    }
    const auto weights = default_morph_weights(model);
    const bool shows_a_blend =
        std::any_of(weights.begin(), weights.end(),
                    [](const std::vector<double>& w)
                    { return std::any_of(w.begin(), w.end(), [](double x) { return x != 0.0; }); });
    if (!blends && shows_a_blend)
    {
        AnimationSpan span;
        span.index = model.animations.size();
        span.name = "the stored morph target weights";
        spans.push_back(std::move(span));
    }
}

// (for_each_animation_pose: detection reads a copy posed by the animation through it.) A blend
// of morph targets is a pose even where no node moves.
ScenePose scene_pose(const tinygltf::Model& model, const GltfAccessors& accessors,
                     std::size_t animation, double t)
{
    ScenePose pose;
    if (animation > model.animations.size())
    {
        return pose;
    }
    std::vector<Eigen::Matrix4d> locals;
    std::vector<std::vector<double>> weights;
    try
    {
        locals = animated_local_matrices(model, accessors, animation, t);
        weights = animated_morph_weights(model, accessors, animation, t);
    }
    catch (const IoError&)
    {
        return pose;
    }
    bool moves = false;
    for (std::size_t n = 0; n < locals.size(); ++n)
    {
        if (!locals[n].allFinite() || !std::all_of(weights[n].begin(), weights[n].end(),
                                                   [](double w) { return std::isfinite(w); }))
        {
            return pose;  // (a non-finite key: no pose)
        }
        moves =
            moves || !same_matrix(locals[n], local_matrix(model.nodes[n])) ||
            std::any_of(weights[n].begin(), weights[n].end(), [](double w) { return w != 0.0; });
    }
    if (!moves)
    {
        return pose;
    }
    if (animation == model.animations.size())
    {
        pose.name = "the stored morph target weights";
    }
    else
    {
        const std::string& name = model.animations[animation].name;
        pose.name =
            (name.empty() ? "animation " + std::to_string(animation) : "animation '" + name + "'") +
            " at " + time_name(t);
    }
    pose.globals = world_matrices(model, locals);
    pose.locals = std::move(locals);
    pose.weights = std::move(weights);
    return pose;
}

std::vector<Eigen::Matrix4d> world_matrices(const tinygltf::Model& model,
                                            const std::vector<Eigen::Matrix4d>& locals)
{
    // glTF nodes form a forest (a node has at most one parent); walk it from every parentless node.
    const std::size_t n = model.nodes.size();
    std::vector<Eigen::Matrix4d> globals(n, Eigen::Matrix4d::Identity());
    std::vector<char> has_parent(n, 0);
    for (const auto& node : model.nodes)
    {
        for (const int c : node.children)
        {
            if (c >= 0 && static_cast<std::size_t>(c) < n)
            {
                has_parent[static_cast<std::size_t>(c)] = 1;
            }
        }
    }
    std::vector<char> seen(n, 0);
    std::vector<int> stack;
    for (std::size_t r = 0; r < n; ++r)
    {
        if (has_parent[r] != 0)
        {
            continue;
        }
        globals[r] = locals[r];
        seen[r] = 1;
        stack.push_back(static_cast<int>(r));
        while (!stack.empty())
        {
            const auto k = static_cast<std::size_t>(stack.back());
            stack.pop_back();
            for (const int c : model.nodes[k].children)
            {
                if (c < 0 || static_cast<std::size_t>(c) >= n ||
                    seen[static_cast<std::size_t>(c)] != 0)
                {
                    continue;
                }
                const auto child = static_cast<std::size_t>(c);
                seen[child] = 1;
                globals[child] = globals[k] * locals[child];
                stack.push_back(c);
            }
        }
    }
    return globals;
}

}  // namespace meshmark::detail

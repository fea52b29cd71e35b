// SPDX-License-Identifier: MIT
// glTF morph targets: a primitive's stored positions with its targets blended in by the
// weights of the shown pose (base + sum of weight x POSITION delta, as the specification says).
#include <string>
#include <vector>

#include "io/detail/gltf_pose.h"
#include "meshmark/core/error.h"

namespace meshmark::detail
{

std::vector<double> morphed(const GltfAccessors& accessors, const ScenePose& pose, int node,
                            const tinygltf::Primitive& prim, const std::vector<double>& local,
                            const std::string& where)
{
    if (pose.empty() || node < 0 || prim.targets.empty())
    {
        return {};
    }
    const std::vector<double>& weights = pose.weights[static_cast<std::size_t>(node)];
    std::vector<double> shown;
    for (std::size_t k = 0; k < prim.targets.size() && k < weights.size(); ++k)
    {
        const auto position = prim.targets[k].find("POSITION");
        if (weights[k] == 0.0 || position == prim.targets[k].end())
        {
            continue;
        }
        std::vector<double> delta;
        try
        {
            delta =
                accessors.values(position->second, 3,
                                 where + " morph target " + std::to_string(k) + " POSITION", false);
        }
        catch (const IoError&)
        {
            continue;  // (a malformed target only means no blend of it, as a malformed animation
                       // means no pose)
        }
        if (delta.size() != local.size())
        {
            continue;  // (a target of another length: nothing a viewer would show either)
        }
        if (shown.empty())
        {
            shown = local;
        }
        for (std::size_t c = 0; c < shown.size(); ++c)
        {
            shown[c] += weights[k] * delta[c];
        }
    }
    return shown;
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// Variants of one mesh told apart by a fit onto each one's own surface (variant_fit.h).
#include "meshmark/registration/variant_fit.h"

#include <cmath>
#include <limits>

#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "registration/detail/icp.h"

namespace meshmark
{

std::vector<double> surface_fits(const Positions& suspect, std::span<const TriangleMesh> meshes,
                                 const ShapeFitPose& start, int rounds, int threads)
{
    std::vector<double> scores(meshes.size(), std::numeric_limits<double>::infinity());
    if (suspect.rows() < 3)
    {
        return scores;
    }
    Positions source = suspect;
    if (start.mirrored)
    {
        source.col(0) *= -1.0;
    }
    const Eigen::RowVector3d centre = source.colwise().mean();
    const double radius =
        std::sqrt((source.rowwise() - centre).squaredNorm() / static_cast<double>(source.rows()));
    if (!(radius > 0.0))
    {
        return scores;
    }
    detail::IcpSettings settings;  // trims to the closest nine tenths, as shape_fit
    settings.max_iterations = rounds;
    const detail::Similarity from{start.scale, start.rotation, start.translation};
    for_each_index(meshes.size(), threads,
                   [&](std::size_t k)
                   {
                       if (meshes[k].F.rows() == 0)
                       {
                           return;
                       }
                       try
                       {
                           const SurfaceMatcher target(meshes[k]);
                           const detail::IcpOutcome fit =
                               detail::icp_point_to_plane(source, target, from, settings);
                           if (fit.transform.scale > 0.0 && std::isfinite(fit.trimmed_rms))
                           {
                               // target units -> the suspect's, over its radius
                               scores[k] = fit.trimmed_rms / (fit.transform.scale * radius);
                           }
                       }
                       catch (const Error&)
                       {
                           // a mesh the matcher refuses scores infinity
                       }
                   });
    return scores;
}

}  // namespace meshmark

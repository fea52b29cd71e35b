// SPDX-License-Identifier: MIT
// The frame of an animated original a re-posed copy fits best (a rigged character exported by
// Blender at frame 1, or at another frame or animation), and the copy taken back to the stored
// frame through that pose (docs/algorithms/detection.md, "Other poses").
#include "meshmark/registration/animation_pose.h"

#include <algorithm>
#include <cstddef>
#include <limits>
#include <map>
#include <numeric>
#include <utility>

#include <Eigen/Geometry>

#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/similarity_fit.h"

namespace meshmark
{
namespace
{

// How a frame is compared with the copy: the copy registered onto the original posed there,
// with these samples and iterations (a quarter to a half of a detection's registration), and
// the trimmed RMS residual of the fit. Registered in full (the coarse stage too): frame 1 and
// the kSpreadFrames frames whose principal spread is the copy's closest; then, started from the
// best kPoseCells of those, the frames within kPoseWindow of them (register_from).
constexpr int kPoseRefineSamples = 512;  // a quarter of a detection's: many frames are tried
constexpr int kPoseFineSamples = 1024;   // (the same)
constexpr int kPoseFinalSamples = 2048;  // (the same)
constexpr int kPoseIterations = 15;  // enough to rank frames; the chosen one is refitted in full
constexpr std::size_t kSpreadFrames =
    3;  // the right frame was among the 3 closest on every copy measured
constexpr std::size_t kPoseCells = 2;   // the best two fits are refined around
constexpr std::size_t kPoseWindow = 2;  // frames either side: the spread's pick can be a frame off

}  // namespace

std::optional<AnimationPoseFit> fit_animation_pose(const TriangleMesh& original,
                                                   const TriangleMesh& suspect,
                                                   const AnimationFrames& frames, int threads)
{
    const std::size_t frame_count = frames.animation.size();
    const auto mesh_in = [&](const Positions& V)
    {
        TriangleMesh posed;
        posed.V = V;
        posed.F = original.F;
        return posed;
    };
    // Each bending frame's distance from the copy in principal spread (the eigenvalues of the
    // surface's second moments over their sum); the frames registered in full: Blender's frame 1
    // (what a copy of its import shows unless the user moved the timeline) and the kSpreadFrames
    // frames whose spread is closest to the copy's (a copy exported at another frame; exact on
    // the copies measured, a shaking animation's included).
    std::vector<std::pair<double, std::size_t>>
        by_spread;  // (distance to the copy's spread, frame)
    {
        const Eigen::Vector3d copy_spread = principal_spread(suspect);
        std::vector<std::size_t> every(frame_count);
        std::iota(every.begin(), every.end(), std::size_t{0});
        frames.pose(every,
                    [&](FramePose&& pose, std::size_t index)
                    {
                        if (pose.V.rows() == original.V.rows())
                        {
                            by_spread.emplace_back(
                                (principal_spread(mesh_in(pose.V)) - copy_spread).norm(), index);
                        }
                    });
    }
    std::vector<std::size_t> first{frames.frame_one};
    const auto closest =
        by_spread.begin() + static_cast<std::ptrdiff_t>(std::min(by_spread.size(), kSpreadFrames));
    std::partial_sort(by_spread.begin(), closest, by_spread.end());
    std::for_each(by_spread.begin(), closest, [&](const auto& f) { first.push_back(f.second); });
    RegistrationOptions registration;
    registration.threads = threads;
    RegistrationOptions quick = registration;
    quick.refine_samples = kPoseRefineSamples;
    quick.fine_samples = kPoseFineSamples;
    quick.final_samples = kPoseFinalSamples;
    quick.max_iterations = kPoseIterations;
    // The whole's motion from the stored pose into \p V (a walk carries the character forward).
    const auto whole_into = [&](const Positions& V) -> Eigen::Matrix4d
    { return fit_similarity_rows(original.V, V); };
    std::sort(first.begin(), first.end());
    first.erase(std::unique(first.begin(), first.end()), first.end());
    // Their fits, then the frames within kPoseWindow of the best kPoseCells, started from those.
    struct Fit
    {
        double residual = std::numeric_limits<double>::infinity();
        std::size_t index = 0;
        Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
        Eigen::Matrix4d whole = Eigen::Matrix4d::Identity();
    };
    std::vector<Fit> fits;
    Fit chosen;
    FramePose best;
    const auto keep = [&](const RegistrationResult& fit, FramePose& pose, std::size_t index)
    {
        const Fit f{fit.rms_error, index, fit.transform, whole_into(pose.V)};
        fits.push_back(f);
        if (f.residual < chosen.residual)
        {
            chosen = f;
            best = std::move(pose);
        }
    };
    frames.pose(first,
                [&](FramePose&& pose, std::size_t index)
                {
                    if (pose.V.rows() ==
                        original.V.rows())  // (else the stored pose, already read, or none)
                    {
                        keep(register_to_reference(suspect, mesh_in(pose.V), quick), pose, index);
                    }
                });
    if (best.V.rows() == 0)
    {
        return std::nullopt;
    }
    std::sort(fits.begin(), fits.end(),
              [](const Fit& a, const Fit& b) { return a.residual < b.residual; });
    const std::vector<Fit> cells(fits.begin(), fits.begin() + static_cast<std::ptrdiff_t>(std::min(
                                                                  fits.size(), kPoseCells)));
    // (the frames of the same animation within kPoseWindow of each cell, each started from its
    // cell)
    std::vector<std::size_t> window;
    std::map<std::size_t, const Fit*> window_start;
    for (const Fit& cell : cells)
    {
        const std::size_t from = cell.index >= kPoseWindow ? cell.index - kPoseWindow : 0;
        const std::size_t to = std::min(frame_count, cell.index + kPoseWindow + 1);
        for (std::size_t k = from; k < to; ++k)
        {
            if (frames.animation[k] == frames.animation[cell.index] &&
                std::find(first.begin(), first.end(), k) == first.end() &&
                window_start.count(k) == 0)
            {
                window.push_back(k);
                window_start[k] = &cell;
            }
        }
    }
    frames.pose(
        window,
        [&](FramePose&& pose, std::size_t index)
        {
            const Fit& start = *window_start.at(index);
            if (pose.V.rows() == original.V.rows())
            {
                keep(register_from(suspect, mesh_in(pose.V),
                                   whole_into(pose.V) * start.whole.inverse() * start.transform,
                                   quick),
                     pose, index);
            }
        });
    AnimationPoseFit fit;
    fit.to_pose = register_from(suspect, mesh_in(best.V), chosen.transform, registration).transform;
    fit.pose = std::move(best);
    return fit;
}

TriangleMesh unposed(const TriangleMesh& original, const TriangleMesh& suspect,
                     const AnimationPoseFit& fit)
{
    const FramePose& best = fit.pose;
    const PointKdTree tree(best.V);
    TriangleMesh out;
    out.V = transform_points(fit.to_pose, suspect.V);
    out.F = suspect.F;
    for (Eigen::Index j = 0; j < out.V.rows(); ++j)
    {
        double squared = 0.0;
        const Eigen::Vector3d s = out.V.row(j).transpose();
        const auto i = static_cast<Eigen::Index>(tree.nearest(s, squared));
        out.V.row(j) = (original.V.row(i).transpose() +
                        best.to_rest[static_cast<std::size_t>(i)] * (s - best.V.row(i).transpose()))
                           .transpose();
    }
    return out;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "pipeline/detect/animation_poses.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

#include "meshmark/io/mesh_io.h"
#include "meshmark/registration/animation_pose.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/read_in_pose.h"

namespace meshmark::detail
{
namespace
{

// The frames of each animation a re-posed copy is compared with: Blender's frames (t = F/24 s)
// over its span, frame 1 (what Blender shows after importing, in the first) always among them;
// at most kMaxAnimationFrames, spread evenly over a longer span, and fewer when there are many
// animations (kMaxFramesInAll over all of them, but never fewer than kMinAnimationFrames each):
// the cost of the search grows with the frames.
constexpr int kMaxAnimationFrames = 120;
constexpr int kMaxFramesInAll = 480;
constexpr int kMinAnimationFrames = 24;
// Blender's frame 1 (its importer's default frame, 24 per second).
constexpr double kBlenderFrameOne = 1.0 / 24.0;

std::vector<double> animation_frame_times(const AnimationSpan& span, int max_frames)
{
    const auto first = static_cast<long long>(std::floor(span.first_key * 24.0));
    const auto last = static_cast<long long>(std::ceil(span.last_key * 24.0));
    std::vector<long long> frames;
    const long long count = last - first + 1;
    if (count <= max_frames)
    {
        for (long long f = first; f <= last; ++f)
        {
            frames.push_back(f);
        }
    }
    else
    {
        for (int k = 0; k < max_frames; ++k)
        {
            frames.push_back(first + (count - 1) * k / (max_frames - 1));
        }
    }
    frames.push_back(1);
    std::vector<double> times;
    for (const long long f : frames)
    {
        times.push_back(std::clamp(static_cast<double>(f) / 24.0, span.first_key, span.last_key));
    }
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    return times;
}

// One frame of one animation (AnimationSpan::index).
struct AnimationFrame
{
    std::size_t animation = 0;
    double time = 0.0;
};

// Every animation's frames (animation_frame_times), animation after animation, in time order.
std::vector<AnimationFrame> animation_frames(const std::vector<AnimationSpan>& animations)
{
    const int per_animation =
        std::clamp(kMaxFramesInAll / std::max(1, static_cast<int>(animations.size())),
                   kMinAnimationFrames, kMaxAnimationFrames);
    std::vector<AnimationFrame> frames;
    for (const AnimationSpan& span : animations)
    {
        for (const double t : animation_frame_times(span, per_animation))
        {
            frames.push_back({span.index, t});
        }
    }
    return frames;
}

// \p visit(pose, k) for each k of \p which: frames[k] posed, the frames of one animation in one
// walk of the file read up front (for_each_animation_pose), animation after animation.
void for_each_frame(const MeshFile& file, const std::vector<AnimationFrame>& frames,
                    const std::vector<std::size_t>& which,
                    const std::function<void(FramePose&&, std::size_t)>& visit)
{
    std::vector<std::size_t> order = which;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b)
                     { return frames[a].animation < frames[b].animation; });
    for (std::size_t begin = 0; begin < order.size();)
    {
        std::size_t end = begin;
        std::vector<double> times;
        while (end < order.size() && frames[order[end]].animation == frames[order[begin]].animation)
        {
            times.push_back(frames[order[end++]].time);
        }
        std::size_t at = begin;
        for_each_animation_pose(
            file, times,
            [&](ShownPose&& pose)
            {
                visit(FramePose{std::move(pose.name), std::move(pose.V), std::move(pose.to_rest)},
                      order[at++]);
            },
            frames[order[begin]].animation);
        begin = end;
    }
}

// Whether the animations bend the mesh at any of their frames (the reader gives no pose where
// they only move the whole, which the stored pose's registration already read): frame 1, the
// middle frame and the last of the first animation first, the others only when none of those
// does. Which frames bend the mesh depends on the original alone, so the charge for a second
// reading is the same for every key and every copy.
bool any_frame_bends(const AnimationFrames& posed, std::size_t shown_frames,
                     std::size_t frame_count, Eigen::Index rows)
{
    std::vector<std::size_t> probe{std::min(posed.frame_one, shown_frames - 1), shown_frames / 2,
                                   shown_frames - 1};
    std::sort(probe.begin(), probe.end());
    probe.erase(std::unique(probe.begin(), probe.end()), probe.end());
    bool bends = false;
    const auto bent = [&](FramePose&& pose, std::size_t)
    { bends = bends || pose.V.rows() == rows; };
    posed.pose(probe, bent);
    if (!bends)
    {
        std::vector<std::size_t> others;
        for (std::size_t k = 0; k < frame_count; ++k)
        {
            if (std::find(probe.begin(), probe.end(), k) == probe.end())
            {
                others.push_back(k);
            }
        }
        posed.pose(others, bent);
    }
    return bends;
}

}  // namespace

// An animated original (a rigged glTF character, a machine whose parts move) is shown by
// Blender in the pose of its first animation at frame 1, and every copy made from that import
// (its PLY and OBJ writers, its modifiers) carries the pose; a user may also export it at
// another frame, or of another animation (Blender keeps the others as actions; a character
// posed for a print or a render). A rigid registration can fit only part of such a copy, and the
// mark reads noise (assimp's BVH and FBX samples: z -0.2 to 1.8). The frames of the animations
// are compared with the copy (fit_animation_pose: by principal spread, then registration) and
// the one it fits best is taken: the copy is registered onto the original in that pose, each of
// its vertices taken back to the stored frame through the pose of the original's vertex nearest
// to it (unposed; everything from the original and the copy, nothing from the key: the choice
// is the same for every key), and read again. Two readings: each is claimed at twice its
// false-positive probabilities (a union bound, as for the symmetric poses), unless no frame
// bends the mesh (then there is no second reading; an animation the reader sees only moves the
// whole, a turntable, never comes here).
void read_animation_pose(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                         const DetectInputs& in, const DetectFileOptions& options,
                         VoxelCache& voxel_cache)
{
    DetectReport& report = reading.report;
    if (in.animated == nullptr || in.animated->animations.empty() ||
        report.correspondence == Correspondence::None ||
        (mark.key().recipients && !mark.key().recipients->recipients.empty()) ||
        options.decision.verdict == VerdictRule::Bits || !options.pairs.empty())
    {
        return;
    }
    const AnimatedOriginal& animated = *in.animated;
    const TriangleMesh& original = in.original;
    timer.begin("poses");
    const std::vector<AnimationFrame> frames = animation_frames(animated.animations);
    if (frames.empty())
    {
        timer.lap("poses");
        return;
    }
    // (the first animation's frames come first; frame 1 of it is what Blender shows)
    const AnimationSpan& shown = animated.animations.front();
    const std::size_t shown_frames = static_cast<std::size_t>(
        std::count_if(frames.begin(), frames.end(),
                      [&](const AnimationFrame& f) { return f.animation == shown.index; }));
    AnimationFrames posed;
    posed.frame_one = static_cast<std::size_t>(
        std::lower_bound(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(shown_frames),
                         std::clamp(kBlenderFrameOne, shown.first_key, shown.last_key),
                         [](const AnimationFrame& f, double t) { return f.time < t; }) -
        frames.begin());
    for (const AnimationFrame& f : frames)
    {
        posed.animation.push_back(f.animation);
    }
    posed.pose = [&](const std::vector<std::size_t>& which,
                     const std::function<void(FramePose&&, std::size_t)>& visit)
    { for_each_frame(*animated.file, frames, which, visit); };
    const bool bends = any_frame_bends(posed, shown_frames, frames.size(), original.V.rows());
    timer.lap("poses");
    if (!bends)
    {
        return;
    }
    const auto bounded = [&](DetectReport& r)
    { charge_readings(r.decision, 2.0, options.decision); };
    bounded(report);
    if (report.decision.is_present)
    {
        return;
    }
    timer.begin("register");
    const std::optional<AnimationPoseFit> fit =
        fit_animation_pose(original, in.suspect, posed, options.threads);
    timer.lap("register");
    if (!fit)
    {
        return;
    }
    timer.begin("unpose");
    const TriangleMesh copy = unposed(original, in.suspect, *fit);
    timer.lap("unpose");
    PoseReading other;
    const Eigen::Matrix4d in_place = Eigen::Matrix4d::Identity();
    const DetectInputs unposed_in{original, in.instances, copy, in.suspect_path, nullptr};
    read_in_pose(other, timer, mark, unposed_in, options, &in_place, nullptr, voxel_cache);
    bounded(other.report);
    other.report.transform = other.report.transform * fit->to_pose;
    other.report.correspondence = Correspondence::AnimationFrame;
    other.report.pose = fit->pose.name;
    keep_more_significant(reading, other);
}

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
// Detection as a list of stages (docs/architecture.md, "Detect"); each stage is a function of
// its own in src/pipeline/detect/, each algorithm it calls in the module below that owns it
// (registration: renumbering, vertex matching, self-symmetries, animation poses).
#include "meshmark/pipeline/detect_file.h"

#include <optional>
#include <utility>

#include "meshmark/meshmark.h"
#include "pipeline/detect/animation_poses.h"
#include "pipeline/detect/correspondence.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/detect/read_in_pose.h"
#include "pipeline/detect/symmetric_poses.h"
#include "pipeline/timer.h"

namespace meshmark
{

std::string correspondence_method(Correspondence correspondence, const std::string& pose)
{
    switch (correspondence)
    {
        case Correspondence::InOrder:
            return "same-connectivity";
        case Correspondence::VerticesMatched:
            return "registration (vertices matched)";
        case Correspondence::Registered:
            return "registration";
        case Correspondence::RegisteredNotConverged:
            return "registration (not converged)";
        case Correspondence::AnimationFrame:
            return "registration (" + pose + ")";
        case Correspondence::None:
            break;
    }
    return "none";
}

namespace
{

// Detection, stage after stage; every entry point comes here with its inputs in files or in
// memory.
DetectReport run_detection(const detail::DetectSources& sources, const DetectFileOptions& options)
{
    options.decision.validate();
    detail::PoseReading reading;
    detail::PhaseTimer timer(reading.report.seconds, options.progress);

    // 1. Read: the key, the original and the suspect, once, up front.
    detail::ReadInputs read;
    const detail::DetectInputs in = detail::read_inputs(sources, options, timer, read);

    // 2. Basis: the watermark regenerated from the original and the key (unless given).
    std::optional<SpectralWatermark> built;
    if (sources.mark == nullptr)
    {
        timer.begin("basis");
        built.emplace(in.original, *detail::key_of(sources, read), options.threads);
        timer.lap("basis");
    }
    const SpectralWatermark& mark = sources.mark != nullptr ? *sources.mark : *built;

    // 3-5. Correspondence, readings, verdict and tracing, in the pose found.
    detail::PoseHints hints;
    detail::VoxelCache voxel_cache;
    detail::read_in_pose(reading, timer, mark, in, options, nullptr, &hints, voxel_cache);

    // 6. Other poses of a symmetric original, under the union bound.
    detail::read_symmetric_poses(reading, timer, mark, in, options, hints, voxel_cache);

    // 7. Other poses of an animated original, under the union bound.
    detail::read_animation_pose(reading, timer, mark, in, options, voxel_cache);

    return std::move(reading.report);
}

}  // namespace

DetectReport detect(const TriangleMesh& suspect, const TriangleMesh& original, const Key& key,
                    const DetectFileOptions& options)
{
    detail::DetectSources sources;
    sources.suspect = &suspect;
    sources.original = &original;
    sources.key = &key;
    return run_detection(sources, options);
}

DetectReport detect_mesh(const SpectralWatermark& mark, const TriangleMesh& original,
                         const TriangleMesh& suspect, const DetectFileOptions& options)
{
    detail::DetectSources sources;
    sources.suspect = &suspect;
    sources.original = &original;
    sources.mark = &mark;
    return run_detection(sources, options);
}

DetectReport detect_file(const std::filesystem::path& suspect_path,
                         const std::filesystem::path& original_path,
                         const std::filesystem::path& key_path, const DetectFileOptions& options)
{
    detail::DetectSources sources;
    sources.suspect_path = suspect_path;
    sources.original_path = original_path;
    sources.key_path = key_path;
    return run_detection(sources, options);
}

DetectReport detect_against_file(const TriangleMesh& suspect,
                                 const std::filesystem::path& original_path,
                                 const std::filesystem::path& key_path,
                                 const DetectFileOptions& options)
{
    validate(suspect, "suspect");
    detail::DetectSources sources;
    sources.suspect = &suspect;
    sources.original_path = original_path;
    sources.key_path = key_path;
    return run_detection(sources, options);
}

DetectReport detect_against_original(const TriangleMesh& suspect,
                                     const std::filesystem::path& original_path, const Key& key,
                                     const DetectFileOptions& options)
{
    validate(suspect, "suspect");
    detail::DetectSources sources;
    sources.suspect = &suspect;
    sources.original_path = original_path;
    sources.key = &key;
    return run_detection(sources, options);
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "pipeline/detect/read_in_pose.h"

#include <utility>

#include "meshmark/core/bounding_box.h"
#include "meshmark/watermark/detector.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/readings.h"
#include "pipeline/detect/rows.h"
#include "pipeline/detect/voxel_prediction.h"

namespace meshmark::detail
{

void read_in_pose(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                  const DetectInputs& in, const DetectFileOptions& options,
                  const Eigen::Matrix4d* pose, PoseHints* hints, VoxelCache& voxel_cache)
{
    DetectReport& report = reading.report;
    report.suspect_vertices = in.suspect.vertex_count();
    report.original_vertices = in.original.vertex_count();
    const double diagonal = bounding_box(in.original.V).diagonal();
    const double amplitude = mark_amplitude(mark.key().options, diagonal);
    report.mark_strength = amplitude / diagonal;

    SuspectInFrame found = find_correspondence(timer, in, amplitude, options, pose, hints);
    report.correspondence = found.kind;
    report.transform = found.transform;
    report.registration_rms = found.registration_rms;
    report.cropped_fraction = found.cropped_fraction;
    report.outlier_fraction = found.outlier_fraction;

    VoxelPredictor voxel(in, found, voxel_cache, options.threads, options.predict_voxel);

    timer.begin("extract");
    Detector detector(mark, in.original);
    const bool tracing = is_tracing(mark, options);
    FirstReadings first = read_owner_mark(report.extraction, timer, detector, mark, in, found,
                                          options, tracing, &voxel);
    report.voxel_resolution = voxel.used() != nullptr ? voxel.used()->resolution : 0.0;
    decide_owner(report, mark, options.decision);
    if (tracing)
    {
        read_recipient_codes(report.extraction, detector, found, std::move(first), options);
        trace_recipients(report, mark, options.decision);
    }
    timer.lap("extract");
}

}  // namespace meshmark::detail

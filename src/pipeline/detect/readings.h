// SPDX-License-Identifier: MIT
#pragma once

// Detection's readings stage: the mark's coefficients read off the suspect in the original's
// frame (Detector), once or twice for a resampled suspect, and a family key's codes.

#include <optional>
#include <vector>

#include "meshmark/pipeline/detect_file.h"
#include "meshmark/watermark/detector.h"
#include "pipeline/detect/correspondence.h"
#include "pipeline/detect/inputs.h"
#include "pipeline/detect/voxel_prediction.h"
#include "pipeline/timer.h"

namespace meshmark::detail
{

/// What the owner's first reading leaves for the codes' (a family key's, traced).
struct FirstReadings
{
    std::vector<std::vector<double>> plain_regions;  ///< The code's regions, first reading.
    std::optional<Extraction> plain_code;            ///< A cropped suspect's code, first reading.
};

/// Whether a family key's recipients are traced (DetectFileOptions::trace, and the key has some).
[[nodiscard]] bool is_tracing(const SpectralWatermark& mark, const DetectFileOptions& options);

/// \brief The owner's mark read into \p extraction (phases "extract", "match surface").
/// \details A resampled suspect is read a second time against the original's surface under its
/// own triangles (match_reference_surface, which updates \p found's samples) unless the first
/// reading alone, paying for the statistics of both, already claims (the early stop), or
/// options.match_surface is off; the two readings are joined (add_further_reading). A suspect
/// \p voxel finds voxel-remeshed, when the first reading does not stop the detection, is read
/// twice more beside the original's own remesh (Detector::set_predicted_change), each reading
/// fitting it sampled as it samples the suspect; the first reading stays among the statistics
/// and the detector keeps the last field set for the code's readings (\p voxel must outlive
/// them).
[[nodiscard]] FirstReadings read_owner_mark(Extraction& extraction, PhaseTimer& timer,
                                            Detector& detector, const SpectralWatermark& mark,
                                            const DetectInputs& in, SuspectInFrame& found,
                                            const DetectFileOptions& options, bool tracing,
                                            VoxelPredictor* voxel = nullptr);

/// \brief A family key's recipient codes read into \p extraction (after the owner's verdict):
/// jointly with the owner's mark, or apart for a cropped suspect, and region by region.
void read_recipient_codes(Extraction& extraction, const Detector& detector,
                          const SuspectInFrame& found, FirstReadings&& first,
                          const DetectFileOptions& options);

}  // namespace meshmark::detail

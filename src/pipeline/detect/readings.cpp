// SPDX-License-Identifier: MIT
#include "pipeline/detect/readings.h"

#include <algorithm>
#include <iterator>
#include <utility>

#include "meshmark/registration/resampling.h"
#include "meshmark/watermark/decision.h"

namespace meshmark::detail
{
namespace
{

// The first reading of a resampled suspect ends the detection when its score alone would claim
// at the price of this many statistics, more than the 7 the two readings' verdict pays (the
// damped readings of each, 2 + 2, and the three joined, add_further_reading): a copy
// the first reading claims only narrowly is read again, so its reported score and R are the
// better reading's (ogre's 5% remesh: 5.38 and R 0.71 from the first reading, 9.51 and R 1.0
// from the second). 10 is the level of the early stop before the verdict scored the damped
// readings alone, so clear copies stop where they did.
constexpr int kEarlyStopStatistics = 10;

// One reading of the owner's mark at the suspect's points. A family key's code is read jointly
// with the owner's mark unless the suspect is cropped (Detector::extract_resampled); rows left
// out as outliers alone do not make it cropped.
Extraction read_once(const Detector& detector, const SuspectInFrame& found,
                     const DetectOptions& decision)
{
    const Positions& at = found.points();
    const std::vector<std::uint8_t>* kept = found.kept();
    return !found.is_resampled() ? (kept != nullptr ? detector.extract_kept(at, decision, *kept)
                                                    : detector.extract(at, decision))
           : found.is_cropped
               ? detector.extract_resampled(at, decision, kept, found.weight_scale)
               : detector.extract_resampled_with_code(at, decision, kept, found.weight_scale);
}

// Whether the first reading of a resampled suspect alone, paying for the statistics of both
// readings, already claims by its score (not by its bit count, which the second reading would
// not repeat): the claim is then one the two readings make too, and a clear copy is read at the
// cost of one reading (docs/algorithms/detection.md). Marks the statistics left unread.
bool is_conclusive(Extraction& extraction, const SpectralWatermark& mark,
                   const DetectOptions& decision, bool may_predict_voxel)
{
    // The second reading would bring as many statistics as the first has and the joined ones;
    // the stop asks for more (kEarlyStopStatistics), which implies the claim. It asks it of the
    // formula bound, not of the tail counted for the first reading's weights: that one claims
    // copies from z ~ 5 whose second reading scores 9-10, and a clear copy should report the
    // score it has (the claim is the same either way).
    const Decision first = mark.decide(extraction, decision);
    // Unread: the second reading's own statistics and the two readings joined; for a copy that
    // may be read beside the original's voxel remesh, also this reading's damped readings
    // again (the readings with the remesh replace it and keep its statistics).
    const auto damped = static_cast<int>(extraction.further_changes.size());
    const int unread =
        first.statistic_count + joined_reading_count(damped) + (may_predict_voxel ? damped : 0);
    const int paid = std::max(first.statistic_count + unread, kEarlyStopStatistics);
    const double both = std::min(1.0, paid * rademacher_tail_bound(first.score));
    const double factor = score_level_factor(decision.verdict);
    const bool conclusive = factor > 0.0 && both * factor <= decision.max_false_positive;
    if (conclusive)
    {
        extraction.unread_statistics = unread;
    }
    return conclusive;
}

}  // namespace

bool is_tracing(const SpectralWatermark& mark, const DetectFileOptions& options)
{
    return options.trace && mark.key().recipients && !mark.key().recipients->recipients.empty();
}

FirstReadings read_owner_mark(Extraction& extraction, PhaseTimer& timer, Detector& detector,
                              const SpectralWatermark& mark, const DetectInputs& in,
                              SuspectInFrame& found, const DetectFileOptions& options, bool tracing,
                              VoxelPredictor* voxel)
{
    FirstReadings first;
    detector.set_predicted_change(nullptr);
    extraction = read_once(detector, found, options.decision);
    const bool is_resampled = found.is_resampled();
    const bool may_predict = voxel != nullptr && voxel->is_possible() && options.match_surface;
    const bool conclusive = is_resampled && options.match_surface && !tracing &&
                            is_conclusive(extraction, mark, options.decision, may_predict);
    if (conclusive)
    {
        found.sampled.element = std::vector<std::int32_t>();
    }
    if (is_resampled && options.match_surface && !conclusive)
    {
        // Read again against the original's surface under the suspect's triangles
        // (match_reference_surface): a coarse copy's triangles cut under a curved surface by
        // many times the mark's amplitude even where they carry nothing, and the same
        // triangles laid through the closest points of their corners on the ORIGINAL cut the
        // same way, so the difference keeps what the corners carry. That second reading is
        // the primary one (bits, R, the family code); the first's statistics stay in the
        // verdict, because a simplifier that places its vertices off the surface (quadric
        // placement) leaves an error that the chord partly cancels in the first reading and
        // that the second sees whole (docs/algorithms/detection.md, "General suspects"). Only
        // the original and the suspect enter either reading, so the bound holds, paying for
        // the statistics of both.
        // A voxel-remeshed copy: both readings again beside the original's own remesh, each
        // sampled as it samples the suspect (Detector::set_predicted_change); the reading
        // without it stays among the statistics, so a copy it would have claimed alone is
        // claimed (docs/algorithms/detection.md, "Voxel-remeshed suspects").
        const VoxelPrediction* prediction = nullptr;
        if (may_predict)
        {
            timer.lap("extract");
            timer.begin("voxel prediction");
            prediction = voxel->prediction();
            timer.lap("voxel prediction");
            timer.begin("extract");
        }
        std::optional<Extraction> unfitted;
        if (prediction != nullptr)
        {
            unfitted = std::move(extraction);
            detector.set_predicted_change(&prediction->plain);
            extraction = read_once(detector, found, options.decision);
        }
        Extraction plain = std::move(extraction);
        if (tracing)
        {
            // The code's regions are read both ways too; the trace's union bound counts them.
            if (found.is_cropped)
            {
                first.plain_code = detector.extract_resampled_with_code(
                    found.points(), options.decision, found.kept(), found.weight_scale);
            }
            first.plain_regions = detector.region_changes(
                found.points(), is_resampled, found.kept(), found.weight_scale,
                first.plain_code ? first.plain_code->code_sampling : plain.code_sampling);
        }
        timer.lap("extract");
        timer.begin("match surface");
        match_reference_surface(found.sampled, in.original, in.suspect, found.to_original,
                                options.threads);
        timer.lap("match surface");
        timer.begin("extract");
        detector.set_predicted_change(prediction != nullptr ? &prediction->matched : nullptr);
        extraction = read_once(detector, found, options.decision);
        add_further_reading(extraction, plain);
        if (unfitted)
        {
            add_further_reading(extraction, *unfitted);
        }
    }
    return first;
}

void read_recipient_codes(Extraction& extraction, const Detector& detector,
                          const SuspectInFrame& found, FirstReadings&& first,
                          const DetectFileOptions& options)
{
    const Positions& at = found.points();
    const std::vector<std::uint8_t>* kept = found.kept();
    std::vector<double> cropped_sampling;  // the code's sampling, where the code is read apart
    if (found.is_cropped)
    {
        // The owner's coefficients were read alone (cropped suspect); the code's, read jointly
        // with them, still serve a slightly cropped one (remeshing, simplification).
        Extraction with_code =
            detector.extract_resampled_with_code(at, options.decision, kept, found.weight_scale);
        cropped_sampling = std::move(with_code.code_sampling);
        extraction.recipient_change = std::move(with_code.recipient_change);
        extraction.recipient_weights = std::move(with_code.recipient_weights);
        if (first.plain_code)
        {
            // Both readings of the code, as for the owner's coefficients: the code's further
            // readings (its damped ones, then the first reading's statistics).
            Extraction code;
            code.normalized_change = std::move(with_code.normalized_change);
            code.weights = std::move(with_code.weights);
            code.recipient_change = extraction.recipient_change;
            code.further_changes = std::move(with_code.further_changes);
            code.further_recipient_changes = std::move(with_code.further_recipient_changes);
            add_further_reading(code, *first.plain_code);
            extraction.further_recipient_changes = std::move(code.further_recipient_changes);
        }
    }
    extraction.region_changes =
        detector.region_changes(at, found.is_resampled(), kept, found.weight_scale,
                                found.is_cropped ? cropped_sampling : extraction.code_sampling);
    std::move(first.plain_regions.begin(), first.plain_regions.end(),
              std::back_inserter(extraction.region_changes));
}

}  // namespace meshmark::detail

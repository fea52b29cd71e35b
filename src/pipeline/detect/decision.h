// SPDX-License-Identifier: MIT
#pragma once

// Detection's verdict stage: the owner's decision, a family key's tracing, and the union bound
// over several readings of one copy (docs/statistics.md, "Several poses").

#include "meshmark/pipeline/detect_file.h"
#include "meshmark/watermark/watermark.h"
#include "pipeline/detect/correspondence.h"

namespace meshmark::detail
{

/// One reading of the copy in one pose: its report (with how the copy was put in
/// correspondence, DetectReport::correspondence and ::pose).
struct PoseReading
{
    DetectReport report;
};

/// The owner's verdict on report.extraction: report.decision, and ownership as that decision
/// (a family key's tracing may widen it: trace_recipients).
void decide_owner(DetectReport& report, const SpectralWatermark& mark,
                  const DetectOptions& decision);

/// Every recipient of a family key scored on report.extraction, the accused and the ownership
/// concluded (conclude_trace).
void trace_recipients(DetectReport& report, const SpectralWatermark& mark,
                      const DetectOptions& decision);

/// A traced report's accused (from report.traced) and ownership (report.decision and the joint
/// readings): what its probabilities conclude at the level of \p decision.
void conclude_trace(DetectReport& report, const DetectOptions& decision);

/// One of k = \p readings readings of a copy (several poses): each of its false-positive
/// probabilities times k (a union bound over the k), and the verdict again.
void charge_readings(Decision& d, double readings, const DetectOptions& decision);

/// The same for a whole report: with a family key traced, every recipient's probabilities too,
/// and the accused and the ownership again.
void charge_readings(DetectReport& report, double readings, const DetectOptions& decision);

/// \p report becomes \p other when that reading is the more significant (the smaller
/// false-positive probability it rests on); the phase times stay (the timer writes into the
/// first report's).
void keep_more_significant(PoseReading& reading, PoseReading& other);

}  // namespace meshmark::detail

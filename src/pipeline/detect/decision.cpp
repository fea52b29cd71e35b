// SPDX-License-Identifier: MIT
#include "pipeline/detect/decision.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace meshmark::detail
{
namespace
{

// The smallest false-positive probability a report rests on: its verdict's, or with a family key
// traced, the ownership's or the first accused recipient's.
double strongest_evidence(const DetectReport& report)
{
    if (report.recipients_traced == 0)
    {
        return report.decision.false_positive_probability;
    }
    double p = report.owner_false_positive_probability;
    for (const RecipientScore& r : report.traced)
    {
        p = std::min(p, r.false_positive_probability);
    }
    return p;
}

}  // namespace

void decide_owner(DetectReport& report, const SpectralWatermark& mark,
                  const DetectOptions& decision)
{
    report.decision = mark.decide(report.extraction, decision);
    report.owner_detected = report.decision.is_present;
    report.owner_false_positive_probability = report.decision.false_positive_probability;
}

void trace_recipients(DetectReport& report, const SpectralWatermark& mark,
                      const DetectOptions& decision)
{
    report.traced = mark.trace(report.extraction, decision);
    report.recipients_traced = report.traced.size();
    conclude_trace(report, decision);
}

void conclude_trace(DetectReport& report, const DetectOptions& decision)
{
    std::vector<RecipientScore> scores = report.traced;
    std::erase_if(scores, [](const RecipientScore& s) { return !s.is_accused; });
    // Strongest evidence first: the smallest false-positive probability (whichever reading,
    // whole model or regions, gave it), then the larger score.
    std::sort(scores.begin(), scores.end(),
              [](const RecipientScore& a, const RecipientScore& b)
              {
                  if (a.false_positive_probability != b.false_positive_probability)
                  {
                      return a.false_positive_probability < b.false_positive_probability;
                  }
                  return a.score > b.score;
              });
    report.accused = std::move(scores);
    // Ownership: the owner's verdict or the best joint reading of the owner's mark with a
    // recipient's code, each with half the level (a union bound over both tests).
    double joint = 1.0;
    for (const RecipientScore& r : report.traced)
    {
        joint = std::min(joint, r.joint_false_positive_probability);
    }
    report.owner_false_positive_probability =
        std::min({1.0, 2.0 * report.decision.false_positive_probability, 2.0 * joint});
    report.owner_detected = report.owner_false_positive_probability <= decision.max_false_positive;
}

void charge_readings(Decision& d, double readings, const DetectOptions& decision)
{
    d.score_false_positive_probability =
        std::min(1.0, readings * d.score_false_positive_probability);
    d.bits_false_positive_probability = std::min(1.0, readings * d.bits_false_positive_probability);
    d.false_positive_probability = std::min(1.0, readings * d.false_positive_probability);
    d.is_present = d.false_positive_probability <= decision.max_false_positive;
}

// The same for a whole report: with a family key traced, every recipient's probabilities too,
// and the accused and the ownership again.
void charge_readings(DetectReport& report, double readings, const DetectOptions& decision)
{
    charge_readings(report.decision, readings, decision);
    if (report.recipients_traced == 0)
    {
        return;
    }
    for (RecipientScore& r : report.traced)
    {
        r.false_positive_probability = std::min(1.0, readings * r.false_positive_probability);
        r.joint_false_positive_probability =
            std::min(1.0, readings * r.joint_false_positive_probability);
        r.is_accused = r.false_positive_probability <= decision.max_false_positive;
    }
    conclude_trace(report, decision);
}

void keep_more_significant(PoseReading& reading, PoseReading& other)
{
    if (strongest_evidence(other.report) < strongest_evidence(reading.report))
    {
        other.report.seconds = std::move(reading.report.seconds);
        reading = std::move(other);
    }
}

}  // namespace meshmark::detail

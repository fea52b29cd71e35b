// SPDX-License-Identifier: MIT
#pragma once

/// \file
/// \brief The one verdict of a detection, said one way (text, `--json`, Python, the evidence
/// report): claimed or not, whose copy, and the false-positive probability of that statement.

#include <string>
#include <vector>

#include "meshmark/core/plain_numbers.h"
#include "meshmark/pipeline/detect_file.h"

namespace meshmark
{

/// \brief What a detection concludes, as a person reads it.
/// \details Claimed when ownership is shown: by the owner's mark (alone, or read jointly with a
/// recipient's code: DetectReport::owner_detected) or by an accused recipient's code (a copy
/// of the key's original carries it only if it was made from that recipient's copy).
/// The probability is that of the statement made: when recipients are accused, the strongest
/// accusation's bound (an accusation covers every recipient of the key, so a mesh without the
/// mark accuses anyone that strongly at most this often); otherwise the ownership's bound
/// (DetectReport::owner_false_positive_probability). Not claimed: the same number says how
/// often chance alone would do as well as the strongest reading (docs/statistics.md).
struct Verdict
{
    bool claimed = false;
    std::vector<std::string> accused;           ///< Whose copy: the accused, strongest first.
    double false_positive_probability = 1.0;    ///< Of this verdict (see above).
    double max_false_positive_probability = 0;  ///< The bound a claim needs (--max-fpp).
    bool traced = false;                        ///< A family key's recipients were scored.
};

/// \brief The verdict of \p report decided at \p max_false_positive (DetectOptions).
[[nodiscard]] Verdict verdict_of(const DetectReport& report, double max_false_positive);

/// \brief One sentence that says \p verdict, e.g. "Claimed: a copy of the original, made from
/// the copy issued to bob. The chance that a mesh without this mark gives this result is at most
/// 1 in 3.2 billion (3.1e-10)." Names no key material.
[[nodiscard]] std::string headline(const Verdict& verdict);

}  // namespace meshmark

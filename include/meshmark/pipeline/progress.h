// SPDX-License-Identifier: MIT
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace meshmark
{

/// \brief Progress of a long operation: a phase name and the fraction done (0..1) within it.
/// \details The pipelines call it with fraction 0 when a phase starts, 1 when it ends, and
/// values between while it runs (when they can tell). It may be called from a worker thread
/// of the pipeline: keep it cheap, thread-safe and non-throwing.
using ProgressCallback = std::function<void(std::string_view phase, double fraction)>;

/// Time spent per phase, in seconds (reported by `--json` as "seconds").
struct PhaseTimings
{
    std::vector<std::pair<std::string, double>> phases;  ///< In the order they ran.
    double total = 0.0;  ///< Wall time from start to the last phase's end.
};

}  // namespace meshmark

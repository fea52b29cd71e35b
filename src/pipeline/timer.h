// SPDX-License-Identifier: MIT
#pragma once

#include <chrono>
#include <string>

#include "meshmark/pipeline/progress.h"

namespace meshmark::detail
{

// Records the wall time of consecutive phases into PhaseTimings.
class PhaseTimer
{
public:
    explicit PhaseTimer(PhaseTimings& timings, const ProgressCallback& progress)
        : timings_(timings), progress_(progress), start_(Clock::now()), last_(start_)
    {
    }
    // Announces the phase that starts now (progress fraction 0).
    void begin(const std::string& name)
    {
        if (progress_)
        {
            progress_(name, 0.0);
        }
    }
    // Ends the current phase under \p name and starts the next one.
    void lap(const std::string& name)
    {
        const auto now = Clock::now();
        timings_.phases.emplace_back(name, std::chrono::duration<double>(now - last_).count());
        timings_.total = std::chrono::duration<double>(now - start_).count();
        last_ = now;
        if (progress_)
        {
            progress_(name, 1.0);
        }
    }

private:
    using Clock = std::chrono::steady_clock;
    PhaseTimings& timings_;
    const ProgressCallback& progress_;
    Clock::time_point start_;
    Clock::time_point last_;
};

}  // namespace meshmark::detail

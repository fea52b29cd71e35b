// SPDX-License-Identifier: MIT
// The terminal progress line of the long commands (embed, detect, attack, compare).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <utility>
#include <vector>

#include "meshmark/pipeline/progress.h"

namespace meshmark::cli
{

/// Options of PhaseProgress.
struct PhaseProgressOptions
{
    std::string label = "meshmark";  ///< Line prefix, e.g. "meshmark embed".
    double delay_seconds = 1.0;      ///< Nothing is shown before the command has run this long.
    double refresh_seconds = 0.1;    ///< Redraw interval of the running phase's clock.
    std::FILE* stream = stderr;
    /// \throws InvalidOption unless delay >= 0, refresh > 0 and stream is not null.
    void validate() const;
};

/// \brief A status line for long commands: finished phases with their times, then the running
/// phase with its elapsed time (and fraction when the pipeline reports one), redrawn in place.
/// \details Feed it through callback() (a ProgressCallback: fraction 0 starts a phase, 1 ends
/// it, values between update it). It stays silent for commands that finish within
/// delay_seconds, so short runs print nothing; finish() (or the destructor) ends the line.
/// Use it only when the stream is a terminal (see should_show). Hand-written: a one-line
/// status needs a few escape codes, and Debian packages no small C++ progress library.
class PhaseProgress
{
public:
    explicit PhaseProgress(PhaseProgressOptions options);
    ~PhaseProgress();
    PhaseProgress(const PhaseProgress&) = delete;
    PhaseProgress& operator=(const PhaseProgress&) = delete;

    /// True when progress should be shown on \p stream: not quiet and the stream is a terminal.
    [[nodiscard]] static bool should_show(bool quiet, std::FILE* stream = stderr);

    /// The callback to pass to a pipeline; valid while this object lives.
    [[nodiscard]] ProgressCallback callback();

    /// Stop redrawing and end the line if anything was shown. Idempotent.
    void finish();

private:
    using Clock = std::chrono::steady_clock;
    void update(std::string_view phase, double fraction);
    void draw_locked();
    void run_ticker();

    PhaseProgressOptions options_;
    Clock::time_point start_;
    Clock::time_point phase_start_;
    std::vector<std::pair<std::string, double>> done_;
    std::string current_;
    double fraction_ = 0.0;
    bool shown_ = false;
    bool stopping_ = false;
    std::mutex mutex_;
    std::condition_variable wake_;
    std::thread ticker_;
};

/// \brief Runs \p work (which returns the command's report) with a PhaseProgress titled
/// \p title when should_show(quiet), its callback stored in \p callback first, and ends the
/// line once the work is done (the destructor ends it when the work throws).
template <class Work>
auto with_progress(const char* title, bool quiet, ProgressCallback& callback, Work&& work)
{
    std::optional<PhaseProgress> progress;
    if (PhaseProgress::should_show(quiet))
    {
        progress.emplace(PhaseProgressOptions{title});
        callback = progress->callback();
    }
    auto report = work();
    if (progress)
    {
        progress->finish();
    }
    return report;
}

}  // namespace meshmark::cli

// SPDX-License-Identifier: MIT
#include "progress.h"

#include <unistd.h>

#include "meshmark/core/error.h"

namespace meshmark::cli
{

void PhaseProgressOptions::validate() const
{
    if (!(delay_seconds >= 0.0) || !(refresh_seconds > 0.0) || stream == nullptr)
    {
        throw InvalidOption(
            "progress: the delay must be >= 0, the refresh interval > 0 and the "
            "stream set.");
    }
}

PhaseProgress::PhaseProgress(PhaseProgressOptions options)
    : options_(std::move(options)), start_(Clock::now()), phase_start_(start_)
{
    options_.validate();
    ticker_ = std::thread([this] { run_ticker(); });
}

PhaseProgress::~PhaseProgress()
{
    finish();
}

bool PhaseProgress::should_show(bool quiet, std::FILE* stream)
{
    return !quiet && stream != nullptr && ::isatty(::fileno(stream)) != 0;
}

ProgressCallback PhaseProgress::callback()
{
    return [this](std::string_view phase, double fraction) { update(phase, fraction); };
}

void PhaseProgress::update(std::string_view phase, double fraction)
{
    const std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    if (fraction >= 1.0)
    {
        done_.emplace_back(std::string(phase),
                           std::chrono::duration<double>(now - phase_start_).count());
        current_.clear();
        phase_start_ = now;
    }
    else
    {
        if (phase != current_)
        {
            current_ = std::string(phase);
            phase_start_ = now;
        }
        fraction_ = fraction;
    }
    draw_locked();
}

void PhaseProgress::draw_locked()
{
    const auto now = Clock::now();
    if (!shown_ && std::chrono::duration<double>(now - start_).count() < options_.delay_seconds)
    {
        return;
    }
    shown_ = true;
    std::string line = "\r\033[K" + options_.label + ":";
    char buffer[64];
    const char* separator = " ";
    for (const auto& [name, seconds] : done_)
    {
        std::snprintf(buffer, sizeof(buffer), " %.2f s", seconds);
        line += separator + name + buffer;
        separator = " | ";
    }
    if (!current_.empty())
    {
        const double elapsed = std::chrono::duration<double>(now - phase_start_).count();
        if (fraction_ > 0.0)
        {
            std::snprintf(buffer, sizeof(buffer), " %3.0f%% %.1f s", 100.0 * fraction_, elapsed);
        }
        else
        {
            std::snprintf(buffer, sizeof(buffer), " %.1f s", elapsed);
        }
        line += separator + current_ + "..." + buffer;
    }
    std::fputs(line.c_str(), options_.stream);
    std::fflush(options_.stream);
}

void PhaseProgress::run_ticker()
{
    std::unique_lock lock(mutex_);
    const auto interval = std::chrono::duration<double>(options_.refresh_seconds);
    while (!stopping_)
    {
        wake_.wait_for(lock, interval);
        if (!stopping_ && !current_.empty())
        {
            draw_locked();
        }
    }
}

void PhaseProgress::finish()
{
    {
        const std::lock_guard lock(mutex_);
        if (stopping_)
        {
            return;
        }
        stopping_ = true;
        if (shown_)
        {
            current_.clear();
            draw_locked();
            std::fputc('\n', options_.stream);
            std::fflush(options_.stream);
        }
    }
    wake_.notify_all();
    ticker_.join();
}

}  // namespace meshmark::cli

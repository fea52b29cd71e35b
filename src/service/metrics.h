// SPDX-License-Identifier: MIT
// The service's counters, in Prometheus's text exposition format (version 0.0.4). Written by
// hand: a few counters and one histogram family do not justify a client library (Debian 12
// packages none for C++).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "asset_cache.h"

namespace meshmark::service
{

class Metrics
{
public:
    /// One answered request: its route's name ("copies", "scan", ...), status and seconds.
    void observe(const std::string& route, int status, double seconds);

    std::atomic<std::uint64_t> copies{0};          ///< Copies sent.
    std::atomic<std::uint64_t> new_recipients{0};  ///< Names recorded for the first time.
    std::atomic<std::int64_t> in_flight{0};  ///< Requests being computed or waiting for a worker.

    /// The exposition text.
    [[nodiscard]] std::string text(const CacheStats& cache, std::size_t budget) const;

private:
    static constexpr std::array<double, 11> kBuckets{0.005, 0.01, 0.025, 0.05, 0.1, 0.25,
                                                     0.5,   1.0,  2.5,   5.0,  10.0};
    struct Histogram
    {
        std::array<std::uint64_t, kBuckets.size()> counts{};  // cumulative at exposition, not here
        std::uint64_t count = 0;
        double sum = 0.0;
    };
    mutable std::mutex mutex_;
    std::map<std::pair<std::string, int>, std::uint64_t> requests_;
    std::map<std::string, Histogram> latency_;
};

}  // namespace meshmark::service

// SPDX-License-Identifier: MIT
#include "metrics.h"

#include <cstdio>

namespace meshmark::service
{

void Metrics::observe(const std::string& route, int status, double seconds)
{
    const std::lock_guard lock(mutex_);
    ++requests_[{route, status}];
    Histogram& h = latency_[route];
    for (std::size_t b = 0; b < kBuckets.size(); ++b)
    {
        if (seconds <= kBuckets[b])
        {
            ++h.counts[b];
            break;
        }
    }
    ++h.count;
    h.sum += seconds;
}

std::string Metrics::text(const CacheStats& cache, std::size_t budget) const
{
    std::string out;
    char line[256];
    auto add = [&](const char* format, auto... values)
    {
        std::snprintf(line, sizeof line, format, values...);
        out += line;
    };
    const std::lock_guard lock(mutex_);
    out +=
        "# HELP meshmark_requests_total Requests answered, by route and status.\n"
        "# TYPE meshmark_requests_total counter\n";
    for (const auto& [labels, count] : requests_)
    {
        add("meshmark_requests_total{route=\"%s\",status=\"%d\"} %llu\n", labels.first.c_str(),
            labels.second, static_cast<unsigned long long>(count));
    }
    out +=
        "# HELP meshmark_request_seconds Time from the request's arrival to its answer sent, by "
        "route.\n"
        "# TYPE meshmark_request_seconds histogram\n";
    for (const auto& [route, h] : latency_)
    {
        std::uint64_t cumulative = 0;
        for (std::size_t b = 0; b < kBuckets.size(); ++b)
        {
            cumulative += h.counts[b];
            add("meshmark_request_seconds_bucket{route=\"%s\",le=\"%g\"} %llu\n", route.c_str(),
                kBuckets[b], static_cast<unsigned long long>(cumulative));
        }
        add("meshmark_request_seconds_bucket{route=\"%s\",le=\"+Inf\"} %llu\n", route.c_str(),
            static_cast<unsigned long long>(h.count));
        add("meshmark_request_seconds_sum{route=\"%s\"} %.6f\n", route.c_str(), h.sum);
        add("meshmark_request_seconds_count{route=\"%s\"} %llu\n", route.c_str(),
            static_cast<unsigned long long>(h.count));
    }
    add("# HELP meshmark_copies_issued_total Marked copies sent.\n# TYPE "
        "meshmark_copies_issued_total counter\n"
        "meshmark_copies_issued_total %llu\n",
        static_cast<unsigned long long>(copies.load()));
    add("# HELP meshmark_recipients_recorded_total Recipient names recorded for the first time.\n"
        "# TYPE meshmark_recipients_recorded_total counter\nmeshmark_recipients_recorded_total "
        "%llu\n",
        static_cast<unsigned long long>(new_recipients.load()));
    add("# HELP meshmark_cache_hits_total Requests that found their asset warm.\n"
        "# TYPE meshmark_cache_hits_total counter\nmeshmark_cache_hits_total %llu\n",
        static_cast<unsigned long long>(cache.hits));
    add("# HELP meshmark_cache_misses_total Requests that had their asset read and its basis "
        "built.\n"
        "# TYPE meshmark_cache_misses_total counter\nmeshmark_cache_misses_total %llu\n",
        static_cast<unsigned long long>(cache.misses));
    add("# HELP meshmark_cache_evictions_total Warm assets dropped to stay within the memory "
        "budget.\n"
        "# TYPE meshmark_cache_evictions_total counter\nmeshmark_cache_evictions_total %llu\n",
        static_cast<unsigned long long>(cache.evictions));
    add("# HELP meshmark_cache_bytes Estimated bytes of the warm assets.\n# TYPE "
        "meshmark_cache_bytes gauge\n"
        "meshmark_cache_bytes %zu\n",
        cache.bytes);
    add("# HELP meshmark_cache_assets Warm assets.\n# TYPE meshmark_cache_assets "
        "gauge\nmeshmark_cache_assets %zu\n",
        cache.assets);
    add("# HELP meshmark_cache_budget_bytes The memory budget of the warm assets.\n"
        "# TYPE meshmark_cache_budget_bytes gauge\nmeshmark_cache_budget_bytes %zu\n",
        budget);
    add("# HELP meshmark_requests_in_flight Requests computing or waiting for a worker.\n"
        "# TYPE meshmark_requests_in_flight gauge\nmeshmark_requests_in_flight %lld\n",
        static_cast<long long>(in_flight.load()));
    return out;
}

}  // namespace meshmark::service

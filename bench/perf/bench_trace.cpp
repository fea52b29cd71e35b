// SPDX-License-Identifier: MIT
// Tracing a suspect against a family key (SpectralWatermark::trace): every recipient's code
// drawn from the key and correlated with the extraction's 3M recipient coefficients, for
// 100, 1,000 and 10,000 recipients. The extraction itself is shared with the owner's verdict
// and is not part of this cost. Also the counted tail of one statistic (RademacherTail), which
// every soft statistic of a verdict or a trace computes once.
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "meshmark/core/rng.h"
#include "meshmark/geometry/shapes.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"

namespace
{

using namespace meshmark;

void BM_TraceRecipients(benchmark::State& state)
{
    const auto recipients = static_cast<std::uint32_t>(state.range(0));
    const TriangleMesh mesh = lumpy_ellipsoid(4);
    EmbedOptions options;
    options.repetitions =
        kFamilyRepetitions;  // a family key's owner mark, as `embed --recipient` makes it
    Key key = make_key(options, 11);
    key.original = fingerprint(mesh);
    key.recipients = RecipientCodes{};
    for (std::uint32_t i = 0; i < recipients; ++i)
    {
        std::string name(1, 'r');  // (appended: GCC 12 reports a false -Wrestrict on "r" + string)
        name += std::to_string(i);
        key.recipients->recipients.push_back({name, i});
    }
    const SpectralWatermark mark(mesh, key, static_cast<int>(state.range(1)));
    Extraction extraction;
    Rng rng(5);
    for (int c = 0; c < 3 * mark.recipient_modes(); ++c)
    {
        extraction.recipient_change.push_back(rng.normal());
        extraction.recipient_weights.push_back(1.0 + rng.uniform());
    }
    // As in a detection of a resampled suspect, read twice (detect_file): the owner's readings
    // (for the joint score), the further readings of both (the two damped ones of the primary
    // reading, then the other reading's three weightings and two damped ones, then the three
    // joining the two readings' damped ones: add_further_reading), and both readings' regions
    // (2 x Detector::kRegionCount).
    const auto owner = static_cast<int>(mark.embedded_signs().size());
    for (int c = 0; c < owner; ++c)
    {
        extraction.normalized_change.push_back(rng.normal());
        extraction.weights.push_back(1.0 + rng.uniform());
    }
    const int further_readings = 2 + 3 + 2 + joined_reading_count(2);
    for (int level = 0; level < further_readings; ++level)
    {
        std::vector<double> damped_owner;
        std::vector<double> damped_code;
        for (int c = 0; c < owner; ++c)
        {
            damped_owner.push_back(rng.normal());
        }
        for (int c = 0; c < 3 * mark.recipient_modes(); ++c)
        {
            damped_code.push_back(rng.normal());
        }
        extraction.further_changes.push_back(std::move(damped_owner));
        extraction.further_recipient_changes.push_back(std::move(damped_code));
    }
    extraction.region_changes.resize(static_cast<std::size_t>(2 * Detector::kRegionCount));
    for (std::vector<double>& region : extraction.region_changes)
    {
        for (int c = 0; c < 3 * mark.recipient_modes(); ++c)
        {
            region.push_back(rng.normal());
        }
    }
    for (auto _ : state)
    {
        benchmark::DoNotOptimize(mark.trace(extraction, DetectOptions{}));
    }
    state.SetItemsProcessed(state.iterations() * recipients);
}

// One statistic's tail for n weights of uneven sizes (as an extraction's |a_c x_c|): the
// counting is about n^2.5 / (4 resolution) additions.
void BM_CountedTail(benchmark::State& state)
{
    Rng rng(7);
    std::vector<double> weights;
    for (std::int64_t c = 0; c < state.range(0); ++c)
    {
        weights.push_back(rng.normal());
    }
    for (auto _ : state)
    {
        const RademacherTail tail(weights);
        benchmark::DoNotOptimize(tail(5.0));
    }
}

}  // namespace

// Args: n (48 and 96: a family key's and a small mesh's owner mark; 120: the default from
// 5,000 vertices; 312: a family key's joint owner-and-code score).
BENCHMARK(BM_CountedTail)
    ->ArgName("n")
    ->Arg(48)
    ->Arg(96)
    ->Arg(120)
    ->Arg(312)
    ->Unit(benchmark::kMillisecond);

// Args: recipients, threads. Wall time (several threads score the recipients of a large key).
BENCHMARK(BM_TraceRecipients)
    ->ArgNames({"recipients", "threads"})
    ->Args({100, 1})
    ->Args({100, 2})
    ->Args({1000, 1})
    ->Args({10000, 1})
    ->Args({10000, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

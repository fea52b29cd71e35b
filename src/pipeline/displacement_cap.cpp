// SPDX-License-Identifier: MIT
// embed --max-displacement: one rescale of the (linear) mark, and the check that the lowered
// mark still reads back from an undamaged float32 copy.
#include "meshmark/pipeline/displacement_cap.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "meshmark/core/error.h"
#include "meshmark/watermark/detector.h"

namespace meshmark
{
namespace
{

// 2^-24 |x| bounds float32 rounding of a coordinate x (half an ulp), and 2^-23 |x| a text
// coordinate written with the shortest float32 digits and read back as a double; over the
// vertex's length (all three coordinates at once) 2^-23 |p| bounds both; twice that is kept.
constexpr double kRoundingMargin = 0x1p-22;
// Bisection steps for the smallest detectable strength: 2^-30 of the range.
constexpr int kBisectionSteps = 30;

double largest_row_norm(const Positions& rows)
{
    return rows.rows() == 0 ? 0.0 : rows.rowwise().norm().maxCoeff();
}

std::string length_text(double value, std::optional<LengthUnit> unit)
{
    if (unit)
    {
        return format_length(value, *unit);
    }
    char text[64];
    std::snprintf(text, sizeof text, "%.3g (the mesh's units)", value);
    return text;
}

// The verdict on the undamaged copy of \p mesh marked by \p field times \p factor, its
// positions rounded to float32, under \p mark (scaled by the same factor already).
Decision intact_decision(const SpectralWatermark& mark, const TriangleMesh& mesh,
                         const Positions& field, double factor)
{
    const Positions marked = ((mesh.V + factor * field).cast<float>()).cast<double>();
    const Detector detector(mark, mesh);
    const DetectOptions options;
    return mark.decide(detector.extract(marked, options), options);
}

// \p value rounded up to 3 significant digits (as length_text prints it): a cap named as
// fitting must fit as printed.
double rounded_up(double value)
{
    const double step = std::pow(10.0, std::floor(std::log10(value)) - 2.0);
    return std::ceil(value / step) * step;
}

}  // namespace

double largest_row_distance(const Positions& a, const Positions& b)
{
    return largest_row_norm(a - b);
}

DisplacementCap cap_displacement(SpectralWatermark& mark, const TriangleMesh& mesh,
                                 Positions& field, EmbedStats* stats, double cap,
                                 const std::filesystem::path& name, std::optional<LengthUnit> unit)
{
    DisplacementCap out;
    out.cap = cap;
    out.uncapped_max = largest_row_norm(field);
    out.rounding_margin = kRoundingMargin * largest_row_norm(mesh.V + field);
    const double target = cap - out.rounding_margin;
    if (out.uncapped_max <= target)
    {
        return out;  // the strength asked for fits
    }
    // The mark's strength relative to the one asked for; the field stays unscaled until the end.
    double current = 1.0;
    const auto scale_to = [&](double factor)
    {
        mark.scale_strength(factor / current);
        current = factor;
    };
    const double factor = target > 0.0 ? target / out.uncapped_max : 0.0;
    Decision decision;
    if (factor > 0.0)
    {
        scale_to(factor);
        decision = intact_decision(mark, mesh, field, factor);
    }
    if (!decision.is_present)
    {
        // The smallest detectable factor, between this one (not detected) and 1 (the strength
        // asked for; assumed detected: were it not, no cap would help).
        double low = std::max(factor, 1e-12);
        double high = 1.0;
        for (int step = 0; step < kBisectionSteps; ++step)
        {
            const double middle = std::sqrt(low * high);
            scale_to(middle);
            (intact_decision(mark, mesh, field, middle).is_present ? high : low) = middle;
        }
        scale_to(1.0);  // as it came in
        const std::string why =
            factor > 0.0 ? "leaves a mark too weak to be detected even on an undamaged copy (z " +
                               std::to_string(decision.score) + ")"
                         : "is below the float32 precision of coordinates this large";
        throw InvalidOption(
            name.string() + ": --max-displacement " + length_text(cap, unit) + " " + why +
            "; the smallest cap that fits is " +
            length_text(rounded_up(high * out.uncapped_max + out.rounding_margin), unit) + ".");
    }
    field *= factor;
    out.factor = factor;
    out.intact_score = decision.score;
    if (stats != nullptr)
    {
        stats->max_displacement_rel *= factor;
        stats->rms_displacement_rel *= factor;
        stats->surface_rms_rel *= factor;
        stats->modulation_step *= factor;
    }
    return out;
}

}  // namespace meshmark

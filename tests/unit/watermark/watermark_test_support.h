// SPDX-License-Identifier: MIT
// Helpers shared by the watermark tests (watermark_*_test.cpp): a key for a mesh, a detection
// of positions, a noisy copy.
#pragma once

#include <cstdint>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/rng.h"
#include "meshmark/watermark/detector.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark::test
{
inline Key make_key(const TriangleMesh& mesh, std::uint64_t seed,
                    EmbeddingRule rule = EmbeddingRule::Additive, double strength = -1.0)
{
    EmbedOptions options;
    options.rule = rule;
    options.strength = strength;
    Key key = meshmark::make_key(options, seed);
    key.original = fingerprint(mesh);
    return key;
}

inline Decision detect_positions(const SpectralWatermark& mark, const TriangleMesh& original,
                                 const Positions& suspect)
{
    const DetectOptions options;
    return mark.decide(Detector(mark, original).extract(suspect, options), options);
}

// \p P with uniform noise of at most 1e-3 of \p mesh's bounding box diagonal on every coordinate.
inline Positions with_noise(const TriangleMesh& mesh, Positions P, std::uint64_t seed)
{
    const double D = bounding_box(mesh.V).diagonal();
    Rng rng(seed);
    for (Eigen::Index i = 0; i < P.size(); ++i)
    {
        P.data()[i] += rng.uniform(-1e-3, 1e-3) * D;
    }
    return P;
}
}  // namespace meshmark::test

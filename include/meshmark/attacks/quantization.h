// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the coordinate-quantization attack.
struct QuantizationOptions
{
    /// Bits per coordinate; the benchmark's levels are 7 to 12 [Wang et al. 2008]. Range 1..30.
    int bits = 10;

    /// \throws InvalidOption when bits is outside 1..30.
    void validate() const;
    bool operator==(const QuantizationOptions&) const = default;
};

/// \brief Snap every coordinate to the nearest of 2^bits evenly spaced levels spanning the
/// bounding box on its axis.
/// \details On axis d with extent [lo, hi], the levels are `lo + k * step`, k = 0..2^bits - 1,
/// `step = (hi - lo) / (2^bits - 1)`, so both box faces are levels and no coordinate moves by
/// more than step / 2. An axis of zero extent is left as it is. Connectivity is unchanged.
/// \throws InvalidOption from options.validate().
[[nodiscard]] TriangleMesh quantize(const TriangleMesh& mesh, const QuantizationOptions& options);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "meshmark/core/length_unit.h"
#include "meshmark/core/triangle_mesh.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// What capping the mark's largest vertex displacement did (cap_displacement).
struct DisplacementCap
{
    double cap = 0.0;  ///< The cap, in the mesh's coordinates; 0: no cap was asked for.
    /// Kept free below the cap for the written file's rounding: 2^-22 times the largest
    /// marked position's length, twice the most a float32 file (binary, or text in shortest
    /// float32 digits read back as doubles) can move a vertex.
    double rounding_margin = 0.0;
    double uncapped_max = 0.0;  ///< Largest displacement at the strength asked for, mesh units.
    double factor = 1.0;        ///< The strength's scaling; 1 when the cap did not bind.
    /// When the cap bound: the verdict's z on the undamaged copy (positions rounded to float32),
    /// as detect decides with its default options; 0 otherwise (not measured).
    double intact_score = 0.0;
};

/// \brief Cap the largest vertex displacement of a mark just synthesized at \p cap (mesh units).
/// \details The additive and the paper's displacement are linear in the strength: when the
/// field's largest row exceeds the cap less the rounding margin, the strength is lowered once
/// by the ratio (SpectralWatermark::scale_strength, recorded in the key) and \p field and
/// \p stats are scaled with it. The lowered mark must stay detectable: the undamaged copy, its
/// positions rounded to float32 as most mesh files store them, is read back (Detector::extract)
/// and decided with the default options (false-positive bound 1e-6); if it is not claimed, the
/// cap is refused, naming the smallest cap that is (found by bisection on the strength).
/// \param mark    The watermark of \p mesh, its strength calibrated (embed's order).
/// \param mesh    The original the mark was built on.
/// \param field   #V x 3, the displacement synthesized by \p mark.
/// \param stats   If not null, scaled with the field.
/// \param cap     The cap in the mesh's coordinates, > 0.
/// \param name    The file, named in errors. \param unit  The mesh's unit, for errors' lengths.
/// \throws InvalidOption naming the file, the cap and the smallest cap that fits, when the cap
/// is below the coordinates' float32 precision or leaves a mark that is not detected.
DisplacementCap cap_displacement(SpectralWatermark& mark, const TriangleMesh& mesh,
                                 Positions& field, EmbedStats* stats, double cap,
                                 const std::filesystem::path& name, std::optional<LengthUnit> unit);

/// \brief Largest distance between rows of \p a and \p b (#V x 3 each, same rows).
[[nodiscard]] double largest_row_distance(const Positions& a, const Positions& b);

}  // namespace meshmark

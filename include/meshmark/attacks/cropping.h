// SPDX-License-Identifier: MIT
#pragma once

#include <optional>

#include <Eigen/Core>

#include "meshmark/attacks/attack_result.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the cropping attack.
struct CropOptions
{
    /// Fraction of the referenced vertices kept; the benchmark's levels keep 0.9, 0.7 and 0.5.
    /// Range (0, 1].
    double vertex_fraction = 0.9;
    /// Normal of the cutting plane, pointing to the side cut away (any length > 0); when empty,
    /// a direction uniform on the sphere is drawn from the stream.
    std::optional<Eigen::Vector3d> direction;

    /// \throws InvalidOption naming the field when a value is out of range or not finite.
    void validate() const;
    bool operator==(const CropOptions&) const = default;
};

/// \brief Cut the mesh by a plane and keep the side that holds the requested fraction of the
/// vertices.
/// \details The plane is placed at the quantile of the referenced vertices' projections on the
/// direction, so that `round(vertex_fraction * count)` of them lie on the kept side. Faces with
/// all three corners on the kept side are kept; vertices no kept face uses are dropped and the
/// rest renumbered in their original order. A vertex whose faces all cross the plane is lost
/// too, so slightly fewer vertices than the target may remain (a thin band along the cut). For
/// a point cloud, exactly the target count of points remains.
/// \return The cropped mesh and, for each of its vertices, the input vertex it was.
/// \throws InvalidOption from options.validate().
[[nodiscard]] AttackResult crop(const TriangleMesh& mesh, const CropOptions& options, Rng& rng);

}  // namespace meshmark

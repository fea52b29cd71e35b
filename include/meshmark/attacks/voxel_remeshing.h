// SPDX-License-Identifier: MIT
#pragma once

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// Parameters of the voxel remeshing attack.
struct VoxelRemeshingOptions
{
    /// Voxels along the bounding-box diagonal: the voxel edge is diagonal / resolution. The
    /// benchmark's levels are 300 and 150 (Blender users pick voxel sizes of this order).
    /// Range [10, 2000]: below, little of the shape is left; above, the grid (and the output,
    /// about surface area / voxel edge^2 vertices) grows past what an attack needs.
    double resolution = 150.0;
    static constexpr double kLowestResolution = 10.0;     ///< The range's lower end.
    static constexpr double kHighestResolution = 2000.0;  ///< The range's upper end.

    /// \throws InvalidOption when resolution is not in [10, 2000].
    void validate() const;
    bool operator==(const VoxelRemeshingOptions&) const = default;
};

/// \brief Voxel remeshing, as Blender's voxel remesher (Remesh modifier in Voxel mode, sculpt
/// mode's Voxel Remesh) does it: the surface is re-extracted from a signed-distance grid.
/// \details With OpenVDB: the triangles are converted to a narrow-band level set
/// (openvdb::tools::meshToLevelSet, band of one voxel either side) on a grid of voxel edge
/// `diagonal / resolution`, and its zero level set is extracted by dual contouring
/// (openvdb::tools::volumeToMesh, adaptivity 0: one vertex per surface voxel). The quads are
/// split along their shorter diagonal and oriented outwards. The grid is aligned to the
/// origin as in Blender; the mesh is moved by a whole number of voxels towards the origin
/// before it is converted to single precision, so far-off coordinates lose no accuracy and the
/// cells are the same. The result is closed; detail below the voxel size, thin parts and
/// inner surfaces are lost, and the sign of the distance is found by flood fill from outside,
/// so a mesh with holes wider than a voxel loses or doubles the surface around them. No
/// correspondence with the input vertices. The result does not depend on \p threads.
/// \param threads  Worker threads of OpenVDB's TBB tasks (0 = all cores).
/// \throws InvalidOption from options.validate(); InvalidMesh for a mesh with no faces, or
/// when no surface is left at this resolution.
[[nodiscard]] TriangleMesh voxel_remesh(const TriangleMesh& mesh,
                                        const VoxelRemeshingOptions& options, int threads = 0);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "registration/detail/coarse_candidates.h"

#include <algorithm>
#include <cmath>

#include "meshmark/core/rng.h"

namespace meshmark::detail
{
namespace
{

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

// A suspect whose centroid lies within this fraction of the reference's RMS radius of the
// reference's, with an RMS radius within this factor of the reference's, may stand where the
// original stands: its start in place is kept through every round and refined in the fine
// stage. Loose on purpose: a voxel remesh of a thin-walled part (head.ply, 1/150 of the
// diagonal) moves the area moments' centroid by 4-11% of the radius and the radius by 8%.
constexpr double kInPlaceOffset = 0.25;
constexpr double kInPlaceScale = 1.25;
// A suspect whose triangles cover less than this share of the area the reference's cover, at the
// same size, is measured by its vertices (has_collapsed_triangles): no decimation, remesh or crop
// comes near (they keep the area per squared extent within a few times: a screw's Blender
// decimation to 5% 0.99, its bisection 1.56), while a soup whose triangles were shrunk to
// slivers keeps almost none (the screw's STL smoothed by Open3D without welding: 1.6e-15 to
// 2.6e-6; Blender's Smooth modifier on a model imported with every triangle apart: 0.0017).
constexpr double kCollapsedArea = 0.01;
// A suspect whose bounding box has the reference's extents within this factor, in some order of
// the axes, is also started on the reference's coordinate axes at scale 1 (add_axis_candidates).
constexpr double kAxisExtentRatio = 1.1;

/// True when the suspect's moments are close to the reference's (kInPlaceOffset, kInPlaceScale):
/// it may have been re-worked where the original stands (a modelling tool leaves it there), and
/// the identity is a start that the tournament must not drop. A mirror-symmetric shape that
/// was coarsely resampled in place (a voxel remesh) fits its mirror image about as well as
/// itself, and the coarse rounds on few samples then kept only mirrored fits and wrong turns
/// (docs/algorithms/registration.md, failure modes). A moved copy's moments differ, and its
/// starts are as before.
bool stands_in_place(const Moments& suspect, const Moments& reference)
{
    const double radius2 = reference.covariance.trace();
    const double ratio2 = suspect.covariance.trace() / radius2;
    return (suspect.centroid - reference.centroid).squaredNorm() <=
               kInPlaceOffset * kInPlaceOffset * radius2 &&
           ratio2 <= kInPlaceScale * kInPlaceScale && ratio2 * kInPlaceScale * kInPlaceScale >= 1.0;
}

/// Starts that map the suspect's principal frame onto a target frame by every rotation in
/// \p rotations, for the suspect and (when allowed) its mirror image; the scale matches the
/// RMS radii, the translation the centroids.
void add_frame_candidates(const Problem& p, const Moments& suspect, const Moments& target,
                          const std::vector<Mat3>& rotations, std::vector<Candidate>& out)
{
    const Mat3 E_t = principal_frame(target.covariance);
    const double s0 = std::sqrt(target.covariance.trace() / suspect.covariance.trace());
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !p.options.allow_reflection)
        {
            continue;
        }
        const Mat3 M = mirrored ? mirror_matrix() : Mat3::Identity();
        const Vec3 c_y = M * suspect.centroid;
        const Mat3 E_y = principal_frame(M * suspect.covariance * M);
        for (const Mat3& P : rotations)
        {
            Candidate c;
            c.mirrored = mirrored;
            c.transform.rotation = E_t * P * E_y.transpose();
            c.transform.scale = s0;
            c.transform.translation = target.centroid - s0 * c.transform.rotation * c_y;
            out.push_back(c);
        }
    }
}

/// Starts that turn the suspect by each rotation of the coordinate axes onto themselves, at
/// scale 1, its bounding box's centre onto the reference's, for the suspect and (when allowed)
/// its mirror image: the frame changes of exporters (Y up to Z up) at the original's units,
/// which need neither the moments' scale nor their axes. A copy that lost or gained surface
/// away from its outline (a voxel remesh drops the inner parts of an assembly and keeps its
/// outer shell, whose box is the original's) has other moments, which start every frame too
/// small or too large and turned; the trimmed ICP does not undo that (Khronos'
/// 2CylinderEngine voxel-remeshed by Blender, written Z up: registered at scale 0.868).
void add_axis_candidates(const Problem& p, const BoundingBox& suspect, const BoundingBox& reference,
                         std::vector<Candidate>& out)
{
    // Only for a copy whose box has the original's extents in some order (a whole copy turned
    // by axes); a crop's or a rescaled copy's starts come from the moments.
    Vec3 a = suspect.max - suspect.min;
    Vec3 b = reference.max - reference.min;
    std::sort(a.data(), a.data() + 3);
    std::sort(b.data(), b.data() + 3);
    for (int k = 0; k < 3; ++k)
    {
        if (!(a(k) <= kAxisExtentRatio * b(k) && b(k) <= kAxisExtentRatio * a(k)))
        {
            return;
        }
    }
    const Vec3 c_s = suspect.center();
    const Vec3 c_r = reference.center();
    for (const bool mirrored : {false, true})
    {
        if (mirrored && !p.options.allow_reflection)
        {
            continue;
        }
        const Mat3 M = mirrored ? mirror_matrix() : Mat3::Identity();
        for (const Mat3& P : axis_rotations())
        {
            Candidate c;
            c.mirrored = mirrored;
            c.transform.rotation = P;
            c.transform.scale = 1.0;
            c.transform.translation = c_r - P * (M * c_s);
            out.push_back(c);
        }
    }
}

}  // namespace

/// Its area over its bounding box's squared diagonal is below kCollapsedArea times the
/// reference's (a triangle soup smoothed triangle by triangle, Open3D's Taubin filter on an STL
/// read without welding, shrinks every triangle to a sliver).
bool has_collapsed_triangles(const Problem& p, const TriangleMesh& suspect,
                             const std::vector<std::int32_t>& suspect_rows, const Moments& ms,
                             const Moments& mr)
{
    const double suspect_span = bounding_box(suspect.V, suspect_rows).diagonal();
    const double reference_span = p.reference_diagonal;
    if (!(suspect_span > 0.0) || !(mr.weight > 0.0))
    {
        return false;
    }
    const double suspect_cover = ms.weight / (suspect_span * suspect_span);
    const double reference_cover = mr.weight / (reference_span * reference_span);
    return suspect_cover < kCollapsedArea * reference_cover;
}

std::vector<Candidate> coarse_starts(const Problem& p, const TriangleMesh& suspect,
                                     const TriangleMesh& reference,
                                     const std::vector<std::int32_t>& suspect_rows,
                                     const std::vector<std::int32_t>& reference_rows,
                                     const Moments& ms, const Moments& mr, bool use_area)
{
    std::vector<Candidate> candidates;
    // The suspect where it stands: a copy cut, bisected or edited in the original's own frame
    // (what a modelling tool does unless told to move it) needs no alignment at all, while the
    // moments of an unexpected part can miss it (a bisected open scan:
    // docs/algorithms/registration.md).
    candidates.push_back(Candidate{});
    candidates.back().kept_in_place = stands_in_place(ms, mr);
    add_frame_candidates(p, ms, mr, axis_rotations(), candidates);
    add_axis_candidates(p, bounding_box(suspect.V, suspect_rows),
                        bounding_box(reference.V, reference_rows), candidates);
    for (const Moments& part : crop_hypotheses(reference, use_area, reference_rows, mr, ms,
                                               derive_seed(p.options.seed, "crop elements")))
    {
        add_frame_candidates(p, ms, part, frame_rotations(part.covariance, ms.covariance),
                             candidates);
    }
    return candidates;
}

std::vector<Similarity> half_turns(const Moments& m)
{
    const Eigen::Matrix3d frame = principal_frame(m.covariance);
    std::vector<Similarity> turns;
    for (int k = 0; k < 3; ++k)
    {
        const Eigen::Vector3d axis = frame.col(k).normalized();
        Similarity S;
        S.rotation = 2.0 * axis * axis.transpose() - Eigen::Matrix3d::Identity();
        S.translation = m.centroid - S.rotation * m.centroid;
        turns.push_back(S);
    }
    return turns;
}

Similarity then(const Similarity& T, const Similarity& S)
{
    Similarity R;
    R.scale = T.scale;
    R.rotation = S.rotation * T.rotation;
    R.translation = S.rotation * T.translation + S.translation;
    return R;
}

}  // namespace meshmark::detail

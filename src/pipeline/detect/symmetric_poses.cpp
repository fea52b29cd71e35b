// SPDX-License-Identifier: MIT
#include "pipeline/detect/symmetric_poses.h"

#include <optional>
#include <vector>

#include <Eigen/Geometry>

#include "meshmark/core/bounding_box.h"
#include "meshmark/registration/self_symmetry.h"
#include "pipeline/detect/decision.h"
#include "pipeline/detect/read_in_pose.h"
#include "pipeline/detect/rows.h"

namespace meshmark::detail
{

// A registered copy of a symmetric original (an egg, a sphere, a torus, a vase, a teapot, most
// animals and vehicles) fits it as well in every pose the original's symmetries relate, and
// registration picks one of them: the mark is read only in the right one (Blender's PLY copy
// of an egg registered turned half a turn about its axis: z 0.71; a 5% remesh of the teapot
// registered as its mirror image: z 3.37). A copy whose vertices were matched where they stand
// without registration (renumbered_in_place) can be matched the same wrong way: a mirrored
// copy of a mirror-symmetric mesh puts each vertex where its mirror partner was. A nearly
// mirror-symmetric original whose near mirror self_symmetries does not find (a small part on
// one side can change its third moments by more than its moment tolerance) fits a mirrored
// copy about as well both ways too: the registration then gives its fit of the other
// handedness (\p hints), read first. Every such pose is read, and the verdict takes the best
// reading at k times its false-positive probability for k readings (a union bound: each
// reading alone keeps the bound, docs/statistics.md), so the poses cost nothing in validity.
// A family key's copy is traced in each pose, every recipient's probabilities charged the same
// way (a buyer's mirrored copy of a symmetric asset accuses the buyer).
void read_symmetric_poses(PoseReading& reading, PhaseTimer& timer, const SpectralWatermark& mark,
                          const DetectInputs& in, const DetectFileOptions& options,
                          const PoseHints& hints, VoxelCache& voxel_cache)
{
    const DetectReport& report = reading.report;
    const TriangleMesh& original = in.original;
    const std::optional<Eigen::Matrix4d>& other_handedness = hints.other_handedness;
    // A copy in the original's vertex order, or put in it by its triangles, is read by index:
    // it has no other pose.
    const bool in_order =
        report.correspondence == Correspondence::InOrder &&
        (hints.is_numbered_by_triangles || has_same_triangles(in.suspect, original));
    const bool placed = report.correspondence != Correspondence::None;
    if (!placed || in_order || options.decision.verdict == VerdictRule::Bits)
    {
        return;
    }
    std::vector<Eigen::Matrix4d> poses;  // suspect -> original
    if (other_handedness)
    {
        poses.push_back(*other_handedness);
    }
    if (in.instances.vertex_count() == 0)
    {
        const double diagonal = bounding_box(original.V).diagonal();
        std::vector<Eigen::Matrix4d> searched;  // unless searched after the registration already
        if (!hints.symmetries)  // a copy matched without registration (renumbered_in_place)
        {
            timer.begin("symmetry");
            searched = self_symmetries(original, mark_amplitude(mark.key().options, diagonal),
                                       options.threads);
            timer.lap("symmetry");
        }
        const std::vector<Eigen::Matrix4d>& symmetries =
            hints.symmetries ? *hints.symmetries : searched;
        const Eigen::Vector3d centre = other_handedness && !symmetries.empty()
                                           ? bounding_box(in.suspect.V).center()
                                           : Eigen::Vector3d::Zero();
        for (const Eigen::Matrix4d& S : symmetries)
        {
            const Eigen::Matrix4d pose = S.inverse() * report.transform;
            if (!other_handedness || !same_pose(pose, *other_handedness, centre, diagonal))
            {
                poses.push_back(pose);
            }
        }
    }
    if (poses.empty())
    {
        return;
    }
    const double readings = static_cast<double>(poses.size() + 1);
    const auto bounded = [&](DetectReport& r) { charge_readings(r, readings, options.decision); };
    bounded(reading.report);
    for (const Eigen::Matrix4d& pose : poses)
    {
        // Settled: someone accused, or a single-owner mark found (ownership alone may still
        // find whose copy it is in another pose).
        if (report.recipients_traced > 0 ? !report.accused.empty() : report.decision.is_present)
        {
            break;
        }
        PoseReading other;
        read_in_pose(other, timer, mark, in, options, &pose, nullptr, voxel_cache);
        bounded(other.report);
        keep_more_significant(reading, other);
    }
}

}  // namespace meshmark::detail

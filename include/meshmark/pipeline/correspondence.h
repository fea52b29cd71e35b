// SPDX-License-Identifier: MIT
#pragma once

// How detection put a suspect in correspondence with the original (DetectReport::correspondence,
// docs/algorithms/detection.md): the typed value stages decide on, and the words reports print.

#include <string>

namespace meshmark
{

/// How the suspect was put in correspondence with the original. Code decides on this value,
/// never on its words (correspondence_method, `detect --json`'s registration.method).
enum class Correspondence
{
    None,  ///< Not read: "none".
    /// In the original's vertex order: as it is, renumbered by its triangles (Blender's PLY
    /// writer) or where it stands (a re-encoded Draco file), after a closed-form similarity:
    /// "same-connectivity".
    InOrder,
    /// Registered, and its vertices are the original's again: read vertex for vertex:
    /// "registration (vertices matched)".
    VerticesMatched,
    Registered,  ///< Registered and resampled at the original's vertices: "registration".
    /// The same, the registration short of its stopping tolerance: "registration (not
    /// converged)".
    RegisteredNotConverged,
    /// Read through a frame of the original's animations (DetectReport::pose), registered:
    /// "registration (POSE)".
    AnimationFrame,
};

/// Whether \p correspondence registered the suspect onto the original (its vertices are not the
/// original's in its order): everything but None and InOrder.
[[nodiscard]] constexpr bool is_registered(Correspondence correspondence) noexcept
{
    return correspondence != Correspondence::None && correspondence != Correspondence::InOrder;
}

/// \brief The words of \p correspondence in reports (`detect --json`'s registration.method):
/// "none", "same-connectivity", "registration (vertices matched)", "registration",
/// "registration (not converged)", or "registration (POSE)" with \p pose the animation frame's
/// name (Correspondence::AnimationFrame; ignored otherwise).
[[nodiscard]] std::string correspondence_method(Correspondence correspondence,
                                                const std::string& pose);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// The nuisance model of the extraction (internal to the watermark module): fields a suspect
// may show without any watermark (similarity motions, smoothing) and the joint least squares
// that fits them beside the watermark's coefficients (docs/algorithms/detection.md).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "meshmark/basis/spectral_basis.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark::detail
{

// Fields (#V x 3) whose effect a suspect may show without any watermark: the 7 infinitesimal
// similarity motions about the centroid (left over by registration), L P, L^2 P, L^3 P
// (smoothing), when given \p extra (an attack's predicted change of the original:
// Detector::set_predicted_change), and for a mesh read with polygons the same three powers of
// the polygons' Laplacian (polygon_adjacency: smoothing over the file's own edges), in that
// order. Evaluated row by row: only the Laplacian powers and the extra field are stored.
class NuisanceFields
{
public:
    NuisanceFields(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                   const Eigen::Vector3d& origin, const Positions* extra = nullptr);

    [[nodiscard]] Eigen::Index count() const noexcept
    {
        return kSimilarityFields + static_cast<Eigen::Index>(laplacians_.size());
    }

    /// The polygons' fields, the last ones (none for a mesh read without polygons).
    [[nodiscard]] Eigen::Index polygon_count() const noexcept { return polygon_fields_; }

    /// Row \p i of field \p f (i among the rows given to the constructor).
    [[nodiscard]] Eigen::RowVector3d row(Eigen::Index f, std::int32_t i) const
    {
        if (f >= kSimilarityFields)
        {
            return laplacians_[static_cast<std::size_t>(f - kSimilarityFields)].row(i);
        }
        if (f == kSimilarityFields - 1)
        {
            return V_->row(i) - origin_.transpose();  // scale
        }
        const auto axis = static_cast<int>(f / 2);
        if (f % 2 == 0)
        {
            return Eigen::RowVector3d::Unit(axis);  // translation
        }
        return Eigen::Vector3d::Unit(axis)
            .cross(V_->row(i).transpose() - origin_)
            .transpose();  // rotation
    }

private:
    static constexpr Eigen::Index kSimilarityFields = 7;
    const Positions* V_;
    Eigen::Vector3d origin_;
    std::vector<Positions> laplacians_;
    Eigen::Index polygon_fields_ = 0;
};

// Throws InvalidOption unless \p weight_scale, the scale of the resampled rows' weights
// (Detector::extract_resampled), is 0 or positive and finite.
void check_weight_scale(double weight_scale);

// Least squares with the variance of every unknown, up to the common noise variance:
// diag((A^T A)^+) from the SVD of A. Unknowns the data cannot determine get infinite variance.
struct JointSolution
{
    Eigen::VectorXd amplitudes;
    Eigen::VectorXd variances;
};

[[nodiscard]] JointSolution solve_jointly(const Eigen::MatrixXd& raw_design,
                                          const Eigen::VectorXd& target);

// The damping levels of damped_readings, as fractions of the mean eigenvalue of the modulated
// unknowns' Gram matrix: light (a half-surface crop) and strong (a coarse resampling).
inline constexpr std::array<double, 2> kDampingLevels = {1e-2, 1.0};

// Damped (ridge) least squares of the first \p modulated unknowns of design = [modulated |
// nuisance]: the nuisance columns' span is projected out of the modulated columns A and the
// target o, then x = (A^T A + lambda I)^-1 A^T o for lambda = level * trace(A^T A) / modulated,
// one vector per level of kDampingLevels. Where the modulated columns are nearly dependent (a
// crop leaves half the surface; a coarse remesh samples it sparsely) plain least squares
// amplifies the noise along the weak directions; damping trades that for a small bias. Depends
// on the design and the target only, never on the embedded signs. Empty when A is zero.
[[nodiscard]] std::vector<Eigen::VectorXd> damped_readings(const Eigen::MatrixXd& design,
                                                           Eigen::Index modulated,
                                                           const Eigen::VectorXd& target);

/// The responses U_r^T N_f of the nuisance fields on the leading r modes.
struct NuisanceModel
{
    int modes = 0;  ///< r: modulated + unmodulated modes used; 0 = too few to fit.
    std::vector<Eigen::MatrixX3d> responses;  ///< U_r^T N_f per nuisance field (r x 3).
};

/// \brief The nuisance model of \p fields on the well-conditioned modes of \p basis, or
/// modes = 0 when they leave fewer than 4 unmodulated modes per field beyond the first
/// \p modulated_head (first_mode + m r). A pure function: one pass over the rows.
[[nodiscard]] NuisanceModel nuisance_model(const SpectralBasis& basis, const NuisanceFields& fields,
                                           int modulated_head);

/// Modes used to fit the nuisance: eigenvalue above 1e-8 of the largest (W ratio 1e-4), where
/// projections are still accurate to many digits despite the Gram matrix's conditioning.
inline constexpr double kNuisanceModeTolerance = 1e-8;

}  // namespace meshmark::detail

// SPDX-License-Identifier: MIT
#include "watermark/nuisance.h"

#include <iterator>
#include <limits>
#include <span>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "meshmark/geometry/adjacency.h"

namespace meshmark::detail
{
namespace
{

// Powers of the uniform Laplacian applied to the positions: the directions in which N steps
// of Laplacian (or Taubin) smoothing move a mesh, (I - lambda L)^N P = P - N lambda L P + ...
constexpr int kLaplacianPowers = 3;
// An unknown with a null-space component above this (of a unit vector) is undetermined; the
// null space's rows are of order 1, so this only separates exact zeros from rounding. Chosen
// by hand; no study on record.
constexpr double kNullSpaceComponent = 1e-8;
// Unmodulated modes needed per nuisance field before the fit is attempted: room to spare
// against overfitting the modulated modes. Chosen by hand; no study on record.
constexpr int kModesPerNuisanceField = 4;

// L P, L^2 P, L^3 P with the uniform Laplacian of \p adjacency (#V x 3 each), zero on rows that
// take no part.
std::vector<Positions> laplacian_powers(const VertexAdjacency& adjacency, const Positions& V,
                                        const std::vector<std::int32_t>& rows)
{
    const auto n = V.rows();
    std::vector<Positions> fields;
    Positions current = V;
    for (int power = 0; power < kLaplacianPowers; ++power)
    {
        Positions next = Positions::Zero(n, 3);
        for (const auto i : rows)
        {
            const auto neighbors = adjacency.of(static_cast<std::size_t>(i));
            if (neighbors.empty())
            {
                continue;
            }
            Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
            for (const auto j : neighbors)
            {
                mean += current.row(j);
            }
            next.row(i) = mean / static_cast<double>(neighbors.size()) - current.row(i);
        }
        fields.push_back(next);
        current = std::move(next);
    }
    return fields;
}

}  // namespace

NuisanceFields::NuisanceFields(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                               const Eigen::Vector3d& origin, const Positions* extra)
    : V_(&mesh.V), origin_(origin)
{
    if (!mesh.is_point_cloud())
    {
        laplacians_ = laplacian_powers(vertex_adjacency(mesh), mesh.V, rows);
    }
    if (extra != nullptr)
    {
        laplacians_.push_back(*extra);
    }
    if (!mesh.is_point_cloud() && !mesh.polygons.empty())
    {
        // A tool that smooths the file's polygons averages over their outlines alone (Blender's
        // Smooth: the bus's 0.5 x 10 copy read at z 4.45 with the triangles' Laplacian alone,
        // 10.80 with the polygons' too; bench/results/2026-12-02-smoothed-polygons.md).
        std::vector<Positions> polygon = laplacian_powers(polygon_adjacency(mesh), mesh.V, rows);
        polygon_fields_ = static_cast<Eigen::Index>(polygon.size());
        std::move(polygon.begin(), polygon.end(), std::back_inserter(laplacians_));
    }
}

// The SVDs below are Eigen's divide-and-conquer one (BDCSVD): a resampled suspect's design is
// nearly square (3r rows for 3M + q columns: 276 x 250 for a furniture model traced against its
// recipients), where the one-sided Jacobi SVD took half of a detection's time; the singular
// values agree to rounding (bench/perf/bench_design_svd.cpp).
JointSolution solve_jointly(const Eigen::MatrixXd& raw_design, const Eigen::VectorXd& target)
{
    // Columns scaled to unit norm first, so that the rank cutoff below compares directions, not
    // units (a nuisance field can be 1e-12 of another column without being any less independent).
    Eigen::VectorXd scale = raw_design.colwise().norm().transpose();
    for (Eigen::Index c = 0; c < scale.size(); ++c)
    {
        scale(c) = scale(c) > 0.0 ? 1.0 / scale(c) : 1.0;
    }
    const Eigen::MatrixXd design = raw_design * scale.asDiagonal();
    const Eigen::BDCSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    const double cutoff = sv.size() > 0 ? 1e-10 * sv(0) : 0.0;
    JointSolution result;
    result.amplitudes = Eigen::VectorXd::Zero(design.cols());
    result.variances = Eigen::VectorXd::Zero(design.cols());
    const Eigen::VectorXd projected = svd.matrixU().transpose() * target;
    Eigen::Index rank = 0;
    for (Eigen::Index j = 0; j < sv.size(); ++j)
    {
        if (sv(j) > cutoff)
        {
            result.amplitudes += svd.matrixV().col(j) * (projected(j) / sv(j));
            result.variances += svd.matrixV().col(j).cwiseAbs2() / (sv(j) * sv(j));
            ++rank;
        }
    }
    if (rank < design.cols())
    {
        // Directions of the null space: unknowns with a component there are undetermined.
        const Eigen::MatrixXd null_space = svd.matrixV().rightCols(design.cols() - rank);
        for (Eigen::Index c = 0; c < design.cols(); ++c)
        {
            if (null_space.row(c).norm() > kNullSpaceComponent)
            {
                result.variances(c) = std::numeric_limits<double>::infinity();
            }
        }
    }
    // Back to the unknowns of the raw design.
    result.amplitudes = result.amplitudes.cwiseProduct(scale);
    result.variances = result.variances.cwiseProduct(scale.cwiseAbs2());
    return result;
}

std::vector<Eigen::VectorXd> damped_readings(const Eigen::MatrixXd& design, Eigen::Index modulated,
                                             const Eigen::VectorXd& target)
{
    Eigen::MatrixXd A = design.leftCols(modulated);
    Eigen::VectorXd o = target;
    const Eigen::Index q = design.cols() - modulated;
    if (q > 0)
    {
        // An orthonormal basis of the nuisance columns' span, from their SVD with the rank
        // cutoff of solve_jointly (columns scaled to unit norm first, for the same reason).
        Eigen::MatrixXd nuisance = design.rightCols(q);
        for (Eigen::Index f = 0; f < q; ++f)
        {
            const double norm = nuisance.col(f).norm();
            if (norm > 0.0)
            {
                nuisance.col(f) /= norm;
            }
        }
        const Eigen::BDCSVD<Eigen::MatrixXd> svd(nuisance, Eigen::ComputeThinU);
        const Eigen::VectorXd& sv = svd.singularValues();
        Eigen::Index rank = 0;
        while (rank < sv.size() && sv(rank) > 1e-10 * sv(0))
        {
            ++rank;
        }
        const Eigen::MatrixXd basis = svd.matrixU().leftCols(rank);
        A -= basis * (basis.transpose() * A);
        o -= basis * (basis.transpose() * o);
    }
    const Eigen::MatrixXd gram = A.transpose() * A;
    const Eigen::VectorXd correlation = A.transpose() * o;
    const double mean_eigenvalue =
        modulated > 0 ? gram.trace() / static_cast<double>(modulated) : 0.0;
    std::vector<Eigen::VectorXd> readings;
    if (!(mean_eigenvalue > 0.0))
    {
        return readings;
    }
    for (const double level : kDampingLevels)
    {
        Eigen::MatrixXd damped = gram;
        damped.diagonal().array() += level * mean_eigenvalue;
        readings.push_back(damped.ldlt().solve(correlation));
    }
    return readings;
}

NuisanceModel nuisance_model(const SpectralBasis& basis, const NuisanceFields& fields,
                             int modulated_head)
{
    NuisanceModel model;
    model.modes = basis.well_conditioned_modes(kNuisanceModeTolerance);
    // Enough unmodulated modes to fit the nuisance fields with room to spare; the polygons'
    // fields are left out first.
    const auto has_room = [&](Eigen::Index fields_used)
    { return model.modes - modulated_head >= kModesPerNuisanceField * fields_used; };
    Eigen::Index q = fields.count();
    if (!has_room(q))
    {
        q -= fields.polygon_count();
    }
    if (!has_room(q))
    {
        model.modes = 0;
        return model;
    }
    // U_r^T N_f of every field in one pass, the fields evaluated row by row (never stored).
    const auto width = static_cast<std::size_t>(3 * q);
    const Eigen::MatrixXd responses = basis.project_design(
        model.modes, 0, width,
        [&](std::span<const std::int32_t> block, const double* /*U*/, double* X)
        {
            for (std::size_t a = 0; a < block.size(); ++a)
            {
                for (Eigen::Index f = 0; f < q; ++f)
                {
                    const Eigen::RowVector3d value = fields.row(f, block[a]);
                    for (Eigen::Index d = 0; d < 3; ++d)
                    {
                        X[a * width + static_cast<std::size_t>(3 * f + d)] = value(d);
                    }
                }
            }
        });
    for (Eigen::Index f = 0; f < q; ++f)
    {
        model.responses.emplace_back(responses.middleCols(3 * f, 3));
    }
    return model;
}

}  // namespace meshmark::detail

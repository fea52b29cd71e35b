// SPDX-License-Identifier: MIT
#include "meshmark/watermark/watermark.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/normals.h"

namespace meshmark {
namespace {

// Vertices whose second principal extent is below this fraction of the first are collinear:
// the watermark would have no room to move them off their line.
constexpr double kCollinearTolerance = 1e-12;

// A modulated coefficient below this fraction of the largest one carries a weak bit under the
// paper's multiplicative rule (DESIGN.md, "Evidence": those fail first under noise).
constexpr double kWeakCoefficientFraction = 0.1;

double third_moment(const Positions& V, const std::vector<std::int32_t>& rows,
                    const Eigen::Vector3d& origin, const Eigen::Vector3d& axis)
{
    double sum = 0.0;
    for (const auto i : rows)
    {
        const double t = (V.row(i).transpose() - origin).dot(axis);
        sum += t * t * t;
    }
    return sum;
}

// Modes used to fit the nuisance: eigenvalue above 1e-8 of the largest (W ratio 1e-4), where
// projections are still accurate to many digits despite the Gram matrix's conditioning.
constexpr double kNuisanceModeTolerance = 1e-8;

// Powers of the uniform Laplacian applied to the positions: the directions in which N steps
// of Laplacian (or Taubin) smoothing move a mesh, (I - lambda L)^N P = P - N lambda L P + ...
constexpr int kLaplacianPowers = 3;

// Fields (#V x 3) whose effect a suspect may show without any watermark: the 7 infinitesimal
// similarity motions about the centroid (left over by registration) and L P, L^2 P, L^3 P
// (smoothing). Zero on rows that take no part.
std::vector<Positions> nuisance_fields(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
                                       const Eigen::Vector3d& origin)
{
    const auto n = mesh.V.rows();
    std::vector<Positions> fields;
    for (int axis = 0; axis < 3; ++axis)
    {
        Positions t = Positions::Zero(n, 3);
        Positions r = Positions::Zero(n, 3);
        const Eigen::Vector3d e = Eigen::Vector3d::Unit(axis);
        for (const auto i : rows)
        {
            t(i, axis) = 1.0;
            r.row(i) = e.cross(mesh.V.row(i).transpose() - origin).transpose();
        }
        fields.push_back(std::move(t));
        fields.push_back(std::move(r));
    }
    Positions scale = Positions::Zero(n, 3);
    for (const auto i : rows)
    {
        scale.row(i) = mesh.V.row(i) - origin.transpose();
    }
    fields.push_back(std::move(scale));
    if (mesh.is_point_cloud())
    {
        return fields;
    }
    const VertexAdjacency adjacency = vertex_adjacency(mesh);
    Positions current = mesh.V;
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

Eigen::MatrixX3d SpectralWatermark::remove_nuisance(const Eigen::MatrixX3d& observed,
                                                    const NuisanceModel& model, int m)
{
    // Fit the nuisance amplitudes on the unmodulated modes m..r-1 only (they carry no
    // watermark, so the fit cannot see, absorb or forge bits), then subtract the fitted
    // nuisance from the modulated modes.
    const int rest = model.modes - m;
    const Eigen::MatrixX3d observed_rest = observed.bottomRows(rest);
    const Eigen::VectorXd target = Eigen::Map<const Eigen::VectorXd>(observed_rest.data(), 3 * rest);
    const Eigen::VectorXd gamma = model.rest_design.colPivHouseholderQr().solve(target);
    Eigen::MatrixX3d result = observed.topRows(m);
    for (std::size_t f = 0; f < model.responses.size(); ++f)
    {
        result -= gamma(static_cast<Eigen::Index>(f)) * model.responses[f].topRows(m);
    }
    return result;
}

CanonicalFrame canonical_frame(const Positions& V, const std::vector<std::int32_t>& rows)
{
    if (rows.empty())
    {
        throw NumericalError("the mesh has no vertex to analyse.");
    }
    CanonicalFrame frame;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto i : rows)
    {
        sum += V.row(i).transpose();
    }
    frame.origin = sum / static_cast<double>(rows.size());
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const auto i : rows)
    {
        const Eigen::Vector3d p = V.row(i).transpose() - frame.origin;
        covariance += p * p.transpose();
    }
    covariance /= static_cast<double>(rows.size());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
    if (!(eigenvalues(2) > 0.0) || eigenvalues(1) <= kCollinearTolerance * eigenvalues(2))
    {
        throw NumericalError("the vertices are all collinear or coincident, so the RBF Gram matrix "
                             "is degenerate and no watermark can be embedded.");
    }
    Eigen::Vector3d e1 = solver.eigenvectors().col(2);
    Eigen::Vector3d e2 = solver.eigenvectors().col(1);
    if (third_moment(V, rows, frame.origin, e1) < 0.0)
    {
        e1 = -e1;
    }
    if (third_moment(V, rows, frame.origin, e2) < 0.0)
    {
        e2 = -e2;
    }
    frame.axes.row(0) = e1.transpose();
    frame.axes.row(1) = e2.transpose();
    frame.axes.row(2) = e1.cross(e2).normalized().transpose();
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (const auto i : rows)
    {
        const Eigen::Vector3d q = frame.axes * (V.row(i).transpose() - frame.origin);
        lo = lo.cwiseMin(q);
        hi = hi.cwiseMax(q);
    }
    frame.diagonal = (hi - lo).norm();
    return frame;
}

void DetectOptions::validate() const
{
    if (!(threshold > 0.0 && threshold <= 1.0))
    {
        throw InvalidOption("detection threshold must be in (0, 1], got " + std::to_string(threshold) + ".");
    }
    if (!(epsilon >= 0.0 && epsilon < 1.0))
    {
        throw InvalidOption("epsilon must be in [0, 1), got " + std::to_string(epsilon) + ".");
    }
}

double binomial_tail_half(int n, int k)
{
    if (k <= 0)
    {
        return 1.0;
    }
    if (k > n)
    {
        return 0.0;
    }
    // Sum of C(n, i) / 2^n for i >= k, in log space to stay exact enough for any n.
    double total = 0.0;
    for (int i = k; i <= n; ++i)
    {
        const double log_term = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) -
                                n * std::log(2.0);
        total += std::exp(log_term);
    }
    return std::min(1.0, total);
}

SpectralWatermark::SpectralWatermark(const TriangleMesh& original, const Key& key, int threads)
    : original_(&original), key_(key), threads_(threads)
{
    key_.options.validate();
    const int m = key_.options.coefficients;
    const int bit_count = payload_bit_count(key_.options);
    if (static_cast<int>(key_.payload.size()) != bit_count)
    {
        throw InvalidOption("the payload has " + std::to_string(key_.payload.size()) +
                            " bits, but the key's parameters need " + std::to_string(bit_count) + ".");
    }

    // Analysed vertices -> canonical frame -> keyed centers -> RBF basis.
    std::vector<std::int32_t> active = referenced_vertices(original);
    if (static_cast<int>(active.size()) < key_.options.basis_size)
    {
        throw InvalidMesh("the mesh has " + std::to_string(active.size()) +
                          " usable vertices, fewer than the " + std::to_string(key_.options.basis_size) +
                          " basis functions (use a smaller --basis-size).");
    }
    frame_ = canonical_frame(original.V, active);
    centers_ = random_centers(original.V, active, key_.options.basis_size,
                              derive_seed(key_.seed, "centers"));
    const double sigma = key_.options.sigma_factor * frame_.diagonal / 2.0;
    const auto analysed = static_cast<double>(active.size());
    basis_.emplace(original.V, std::move(active), centers_, sigma, frame_.origin, threads);

    // Payload -> key-masked signs b' (bit t = 3 * mode + axis).
    mask_ = payload_mask(key_.seed, bit_count);
    signs_.resize(m, 3);
    for (int t = 0; t < bit_count; ++t)
    {
        const unsigned embedded = static_cast<unsigned>(key_.payload[static_cast<std::size_t>(t)]) ^
                                  static_cast<unsigned>(mask_[static_cast<std::size_t>(t)]);
        signs_(t / 3, t % 3) = embedded != 0 ? 1.0 : -1.0;
    }

    // Modulation per coefficient, in the canonical frame.
    const double strength = key_.options.resolved_strength();
    if (key_.options.rule == EmbeddingRule::Additive)
    {
        // |U_m b' s|_F^2 = 3 m s^2 for orthonormal modes, so this s gives an RMS displacement of
        // strength * D over the analysed vertices.
        const double step = strength * frame_.diagonal * std::sqrt(analysed / (3.0 * m));
        modulation_ = Eigen::MatrixX3d::Constant(m, 3, step);
    }
    else
    {
        const Eigen::MatrixX3d alpha_file = basis_->position_coefficients().topRows(m);
        const Eigen::MatrixX3d alpha = alpha_file * frame_.axes.transpose();
        modulation_ = alpha * strength;
        const double largest = alpha.cwiseAbs().maxCoeff();
        weak_bits_ = static_cast<int>((alpha.array().abs() < kWeakCoefficientFraction * largest).count());
    }
}

Positions SpectralWatermark::displacement(EmbedStats* stats) const
{
    // Coefficient change (canonical frame) -> file axes -> synthesis U_m (beta - alpha).
    const Eigen::MatrixX3d change = signs_.cwiseProduct(modulation_) * frame_.axes;
    double orthogonality = 0.0;
    Positions field = basis_->synthesize(change, &orthogonality);
    if (stats != nullptr)
    {
        const auto& rows = basis_->active_rows();
        const double aabb = bounding_box(original_->V, rows).diagonal();
        double max_sq = 0.0;
        double sum_sq = 0.0;
        for (const auto i : rows)
        {
            const double sq = field.row(i).squaredNorm();
            max_sq = std::max(max_sq, sq);
            sum_sq += sq;
        }
        stats->max_displacement_rel = std::sqrt(max_sq) / aabb;
        stats->rms_displacement_rel = std::sqrt(sum_sq / static_cast<double>(rows.size())) / aabb;
        stats->orthogonality_error = orthogonality;
        stats->modulation_step = key_.options.rule == EmbeddingRule::Additive ? modulation_(0, 0) : 0.0;
        stats->weak_bits = weak_bits_;
        stats->analysed_vertices = static_cast<int>(rows.size());
    }
    return field;
}

Extraction SpectralWatermark::extract(const Positions& suspect, const DetectOptions& options,
                                      const std::vector<std::uint8_t>* is_kept) const
{
    options.validate();
    if (suspect.rows() != original_->V.rows())
    {
        throw InvalidOption("the suspect has " + std::to_string(suspect.rows()) +
                            " vertices in correspondence, the original " +
                            std::to_string(original_->V.rows()) + ".");
    }
    const int m = key_.options.coefficients;
    // gamma - alpha: projection of the change (least squares if rows are cropped), canonical axes.
    const Positions change = suspect - original_->V;
    Eigen::MatrixX3d delta_file;
    if (is_kept != nullptr)
    {
        delta_file = basis_->project_least_squares(change, *is_kept, m);
    }
    else if (options.remove_nuisance && nuisance_model().modes > m)
    {
        delta_file = remove_nuisance(basis_->project(change, nuisance_model().modes), nuisance_model(), m);
    }
    else
    {
        delta_file = basis_->project(change, m);
    }
    const Eigen::MatrixX3d delta = delta_file * frame_.axes.transpose();

    // Sign-correct decision on the normalized change (DESIGN.md step 9).
    Extraction result;
    const int bit_count = 3 * m;
    result.normalized_change.resize(static_cast<std::size_t>(bit_count));
    result.bits_found.resize(static_cast<std::size_t>(bit_count));
    for (int t = 0; t < bit_count; ++t)
    {
        const double modulation = modulation_(t / 3, t % 3);
        const double value = modulation != 0.0 ? delta(t / 3, t % 3) / modulation : 0.0;
        result.normalized_change[static_cast<std::size_t>(t)] = value;
        std::uint8_t bit = 2;
        if (value > options.epsilon)
        {
            bit = 1;
        }
        else if (value < -options.epsilon)
        {
            bit = 0;
        }
        if (bit != 2)
        {
            bit = static_cast<std::uint8_t>(bit ^ mask_[static_cast<std::size_t>(t)]);
        }
        result.bits_found[static_cast<std::size_t>(t)] = bit;
    }
    return result;
}

Extraction SpectralWatermark::extract_resampled(const Positions& resampled, const DetectOptions& options,
                                                const std::vector<std::uint8_t>* is_kept) const
{
    options.validate();
    if (resampled.rows() != original_->V.rows())
    {
        throw InvalidOption("the resampled suspect has " + std::to_string(resampled.rows()) +
                            " rows, the original " + std::to_string(original_->V.rows()) + ".");
    }
    const int m = key_.options.coefficients;
    const int bit_count = 3 * m;
    const int r = basis_->well_conditioned_modes(kNuisanceModeTolerance);
    const auto& rows = basis_->active_rows();
    const auto n = original_->V.rows();

    // The sampling operator S: per-vertex projection on the original's normal (what a
    // closest-point resampling keeps of a small displacement), zero on cropped rows.
    const bool has_normals = !original_->is_point_cloud();
    const Positions normals = has_normals ? vertex_normals(*original_) : Positions();
    auto apply_operator = [&](Positions& field) {
        for (const auto i : rows)
        {
            if (is_kept != nullptr && (*is_kept)[static_cast<std::size_t>(i)] == 0)
            {
                field.row(i).setZero();
            }
            else if (has_normals)
            {
                const Eigen::RowVector3d normal = normals.row(i);
                field.row(i) = field.row(i).dot(normal) * normal;
            }
        }
    };

    // Fields: the expected response of each bit (b' = +1), the nuisance, and the observation.
    std::vector<Positions> fields;
    fields.reserve(static_cast<std::size_t>(bit_count) + 16);
    const Eigen::MatrixXd U = basis_->modes_dense(m);
    for (int t = 0; t < bit_count; ++t)
    {
        const Eigen::RowVector3d direction = frame_.axes.row(t % 3) * modulation_(t / 3, t % 3);
        Positions field = Positions::Zero(n, 3);
        for (std::size_t a = 0; a < rows.size(); ++a)
        {
            field.row(rows[a]) = U(static_cast<Eigen::Index>(a), t / 3) * direction;
        }
        apply_operator(field);
        fields.push_back(std::move(field));
    }
    for (auto& nuisance : nuisance_fields(*original_, rows, frame_.origin))
    {
        apply_operator(nuisance);
        fields.push_back(std::move(nuisance));
    }
    Positions observed = Positions::Zero(n, 3);
    for (const auto i : rows)
    {
        if (is_kept == nullptr || (*is_kept)[static_cast<std::size_t>(i)] != 0)
        {
            observed.row(i) = resampled.row(i) - original_->V.row(i);
        }
    }
    fields.push_back(std::move(observed));

    // Everything on the leading r modes, then joint least squares for (bits, nuisance).
    const auto projected = basis_->project(fields, r);
    const auto unknowns = static_cast<Eigen::Index>(fields.size() - 1);
    Eigen::MatrixXd design(3 * r, unknowns);
    for (Eigen::Index f = 0; f < unknowns; ++f)
    {
        design.col(f) = Eigen::Map<const Eigen::VectorXd>(projected[static_cast<std::size_t>(f)].data(), 3 * r);
    }
    const Eigen::VectorXd target = Eigen::Map<const Eigen::VectorXd>(projected.back().data(), 3 * r);
    const Eigen::VectorXd solution = design.colPivHouseholderQr().solve(target);

    Extraction result;
    result.normalized_change.resize(static_cast<std::size_t>(bit_count));
    result.bits_found.resize(static_cast<std::size_t>(bit_count));
    for (int t = 0; t < bit_count; ++t)
    {
        const double value = solution(t);
        result.normalized_change[static_cast<std::size_t>(t)] = value;
        std::uint8_t bit = 2;
        if (value > options.epsilon)
        {
            bit = static_cast<std::uint8_t>(1U ^ mask_[static_cast<std::size_t>(t)]);
        }
        else if (value < -options.epsilon)
        {
            bit = mask_[static_cast<std::size_t>(t)];
        }
        result.bits_found[static_cast<std::size_t>(t)] = bit;
    }
    return result;
}

const SpectralWatermark::NuisanceModel& SpectralWatermark::nuisance_model() const
{
    if (nuisance_)
    {
        return *nuisance_;
    }
    NuisanceModel model;
    const int m = key_.options.coefficients;
    model.modes = basis_->well_conditioned_modes(kNuisanceModeTolerance);
    // Enough unmodulated modes to fit the nuisance fields with room to spare.
    const auto fields = nuisance_fields(*original_, basis_->active_rows(), frame_.origin);
    const auto q = static_cast<Eigen::Index>(fields.size());
    if (model.modes - m < 4 * static_cast<int>(q))
    {
        model.modes = 0;
        nuisance_ = model;
        return *nuisance_;
    }
    model.responses = basis_->project(fields, model.modes);
    const Eigen::Index rest_rows = 3 * (model.modes - m);
    model.rest_design.resize(rest_rows, q);
    for (Eigen::Index f = 0; f < q; ++f)
    {
        const Eigen::MatrixX3d rest = model.responses[static_cast<std::size_t>(f)].bottomRows(model.modes - m);
        model.rest_design.col(f) = Eigen::Map<const Eigen::VectorXd>(rest.data(), rest_rows);
    }
    nuisance_ = std::move(model);
    return *nuisance_;
}

Decision SpectralWatermark::decide(const Extraction& extraction, const DetectOptions& options) const
{
    options.validate();
    Decision decision;
    decision.bit_count = static_cast<int>(key_.payload.size());
    for (std::size_t t = 0; t < key_.payload.size(); ++t)
    {
        const auto found = extraction.bits_found[t];
        decision.bits_expected.push_back(key_.payload[t] != 0 ? '1' : '0');
        decision.bits_found.push_back(found == 2 ? '?' : (found != 0 ? '1' : '0'));
        if (found == key_.payload[t])
        {
            ++decision.matches;
        }
    }
    decision.correlation = static_cast<double>(decision.matches) / decision.bit_count;
    decision.false_positive_probability = binomial_tail_half(decision.bit_count, decision.matches);
    decision.is_present = decision.correlation >= options.threshold;
    return decision;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/watermark/watermark.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>

#include "meshmark/basis/decimated_centers.h"
#include "meshmark/basis/laplacian_basis.h"
#include "meshmark/basis/rbf_basis.h"
#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/named_choice.h"
#include "meshmark/core/rng.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/normals.h"

namespace meshmark {
namespace {

// Vertices whose second principal extent is below this fraction of the first are collinear:
// the watermark would have no room to move them off their line.
constexpr double kCollinearTolerance = 1e-12;

// A modulated coefficient below this fraction of the largest one carries a weak bit under the
// paper's multiplicative rule (docs/algorithms/embedding.md, "Modulation": those fail first under noise).
constexpr double kWeakCoefficientFraction = 0.1;

// Normalized coefficient changes below this are rounding, not signal or attack.
constexpr double kNegligibleChange = 1e-6;

// Modes used to fit the nuisance: eigenvalue above 1e-8 of the largest (W ratio 1e-4), where
// projections are still accurate to many digits despite the Gram matrix's conditioning.
constexpr double kNuisanceModeTolerance = 1e-8;

// Powers of the uniform Laplacian applied to the positions: the directions in which N steps
// of Laplacian (or Taubin) smoothing move a mesh, (I - lambda L)^N P = P - N lambda L P + ...
constexpr int kLaplacianPowers = 3;

// L P, L^2 P, L^3 P with the uniform Laplacian (#V x 3 each), zero on rows that take no part.
std::vector<Positions> laplacian_powers(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows)
{
    const auto n = mesh.V.rows();
    std::vector<Positions> fields;
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

// Fields (#V x 3) whose effect a suspect may show without any watermark: the 7 infinitesimal
// similarity motions about the centroid (left over by registration) and L P, L^2 P, L^3 P
// (smoothing), in that order. Evaluated row by row: only the Laplacian powers are stored.
class NuisanceFields
{
public:
    NuisanceFields(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows, const Eigen::Vector3d& origin)
        : V_(&mesh.V), origin_(origin)
    {
        if (!mesh.is_point_cloud())
        {
            laplacians_ = laplacian_powers(mesh, rows);
        }
    }

    [[nodiscard]] Eigen::Index count() const noexcept
    {
        return kSimilarityFields + static_cast<Eigen::Index>(laplacians_.size());
    }

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
        return Eigen::Vector3d::Unit(axis).cross(V_->row(i).transpose() - origin_).transpose();  // rotation
    }

private:
    static constexpr Eigen::Index kSimilarityFields = 7;
    const Positions* V_;
    Eigen::Vector3d origin_;
    std::vector<Positions> laplacians_;
};

// Least squares with the variance of every unknown, up to the common noise variance:
// diag((A^T A)^+) from the SVD of A. Unknowns the data cannot determine get infinite variance.
struct JointSolution
{
    Eigen::VectorXd amplitudes;
    Eigen::VectorXd variances;
};

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
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
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
            if (null_space.row(c).norm() > 1e-8)
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

}  // namespace

namespace {

// One row of the third-moment and extent pass: add() and add_rows() both run exactly this.
inline void add_moments_row(const Eigen::Vector3d& q, const Eigen::Vector3d& e1, const Eigen::Vector3d& e2,
                            const Eigen::Matrix3d& unsigned_axes, double& moment1, double& moment2,
                            Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
    const double t1 = q.dot(e1);
    const double t2 = q.dot(e2);
    moment1 += t1 * t1 * t1;
    moment2 += t2 * t2 * t2;
    const Eigen::Vector3d r = unsigned_axes * q;
    lo = lo.cwiseMin(r);
    hi = hi.cwiseMax(r);
}

}  // namespace

void CanonicalFrameBuilder::add(const Eigen::Vector3d& p)
{
    switch (pass_)
    {
        case Pass::Centroid:
            sum_ += p;
            ++rows_;
            break;
        case Pass::Covariance:
        {
            const Eigen::Vector3d q = p - frame_.origin;
            covariance_ += q * q.transpose();
            break;
        }
        case Pass::Moments:
            add_moments_row(p - frame_.origin, e1_, e2_, unsigned_axes_, moment1_, moment2_, lo_, hi_);
            break;
        case Pass::Done:
            break;
    }
}

void CanonicalFrameBuilder::add_rows(const Positions& V, std::span<const std::int32_t> rows)
{
    // Each loop body is add()'s expression for its pass, so every sum is the same.
    switch (pass_)
    {
        case Pass::Centroid:
        {
            Eigen::Vector3d sum = sum_;
            for (const std::int32_t i : rows)
            {
                sum += V.row(i).transpose();
            }
            sum_ = sum;
            rows_ += rows.size();
            break;
        }
        case Pass::Covariance:
        {
            // add()'s covariance += q q^T entry by entry (each entry: one product, one sum; the
            // matrix is symmetric and q_a q_b == q_b q_a exactly), without Eigen's temporary.
            std::array<double, 6> c = {covariance_(0, 0), covariance_(1, 0), covariance_(2, 0),
                                       covariance_(1, 1), covariance_(2, 1), covariance_(2, 2)};
            const double ox = frame_.origin.x();
            const double oy = frame_.origin.y();
            const double oz = frame_.origin.z();
            for (const std::int32_t i : rows)
            {
                const double x = V(i, 0) - ox;
                const double y = V(i, 1) - oy;
                const double z = V(i, 2) - oz;
                c[0] += x * x;
                c[1] += y * x;
                c[2] += z * x;
                c[3] += y * y;
                c[4] += z * y;
                c[5] += z * z;
            }
            covariance_ << c[0], c[1], c[2], c[1], c[3], c[4], c[2], c[4], c[5];
            break;
        }
        case Pass::Moments:
        {
            double moment1 = moment1_;
            double moment2 = moment2_;
            Eigen::Vector3d lo = lo_;
            Eigen::Vector3d hi = hi_;
            for (const std::int32_t i : rows)
            {
                add_moments_row(V.row(i).transpose() - frame_.origin, e1_, e2_, unsigned_axes_, moment1, moment2,
                                lo, hi);
            }
            moment1_ = moment1;
            moment2_ = moment2;
            lo_ = lo;
            hi_ = hi;
            break;
        }
        case Pass::Done:
            break;
    }
}

void CanonicalFrameBuilder::next_pass()
{
    switch (pass_)
    {
        case Pass::Centroid:
            if (rows_ == 0)
            {
                throw NumericalError("the mesh has no vertex to analyse.");
            }
            frame_.origin = sum_ / static_cast<double>(rows_);
            pass_ = Pass::Covariance;
            break;
        case Pass::Covariance:
        {
            covariance_ /= static_cast<double>(rows_);
            const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance_);
            const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
            if (!(eigenvalues(2) > 0.0) || eigenvalues(1) <= kCollinearTolerance * eigenvalues(2))
            {
                throw NumericalError("the vertices are all collinear or coincident, so the RBF Gram matrix "
                                     "is degenerate and no watermark can be embedded.");
            }
            e1_ = solver.eigenvectors().col(2);
            e2_ = solver.eigenvectors().col(1);
            unsigned_axes_.row(0) = e1_.transpose();
            unsigned_axes_.row(1) = e2_.transpose();
            unsigned_axes_.row(2) = e1_.cross(e2_).normalized().transpose();
            lo_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
            hi_ = -lo_;
            pass_ = Pass::Moments;
            break;
        }
        case Pass::Moments:
        {
            // Signs: e -> -e negates e's projections exactly, and the cross product of the
            // signed axes is the unsigned one times both signs, exactly. So the extent along a
            // negated axis is [-hi, -lo] of the unsigned one, bit for bit what a fourth pass
            // over the signed axes would find, and hi - lo is the same difference.
            const std::array<double, 3> sign = {moment1_ < 0.0 ? -1.0 : 1.0, moment2_ < 0.0 ? -1.0 : 1.0,
                                                (moment1_ < 0.0) != (moment2_ < 0.0) ? -1.0 : 1.0};
            for (Eigen::Index k = 0; k < 3; ++k)
            {
                frame_.axes.row(k) = sign[static_cast<std::size_t>(k)] < 0.0 ? Eigen::RowVector3d(-unsigned_axes_.row(k))
                                                                             : Eigen::RowVector3d(unsigned_axes_.row(k));
                if (sign[static_cast<std::size_t>(k)] < 0.0)
                {
                    const double lo = lo_(k);
                    lo_(k) = -hi_(k);
                    hi_(k) = -lo;
                }
            }
            frame_.diagonal = (hi_ - lo_).norm();
            pass_ = Pass::Done;
            break;
        }
        case Pass::Done:
            break;
    }
}

CanonicalFrame canonical_frame(const Positions& V, const std::vector<std::int32_t>& rows)
{
    CanonicalFrameBuilder builder;
    while (builder.pass() != CanonicalFrameBuilder::Pass::Done)
    {
        builder.add_rows(V, rows);
        builder.next_pass();
    }
    return builder.frame();
}

void DisplacementSummary::add(const double* d) noexcept
{
    const double sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    max_squared = std::max(max_squared, sq);
    sum_squared += sq;
    ++rows;
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
    if (!(max_false_positive > 0.0 && max_false_positive <= 1.0))
    {
        throw InvalidOption("the largest false-positive probability (--max-fpp) must be in (0, 1], got " +
                            std::to_string(max_false_positive) + ".");
    }
}

const char* to_string(VerdictRule rule) noexcept
{
    return rule == VerdictRule::Bits ? "bits" : "correlation";
}

VerdictRule parse_verdict_rule(const std::string& name)
{
    return parse_named_choice<VerdictRule>(name, "verdict rule",
                                           {{"correlation", VerdictRule::Correlation}, {"bits", VerdictRule::Bits}});
}

double rademacher_tail_bound(double z)
{
    if (!(z > 0.0))
    {
        return 1.0;
    }
    // Hoeffding: P(S >= z |a|) <= exp(-z^2 / 2). Pinelis: P(S >= z |a|) <= c (1 - Phi(z)) with
    // c = 2 e^3 / 9 ~ 4.46, tighter beyond z ~ 3.3. Both hold for every weight vector a.
    const double hoeffding = std::exp(-0.5 * z * z);
    const double pinelis = 2.0 * std::exp(3.0) / 9.0 * 0.5 * std::erfc(z / std::sqrt(2.0));
    return std::min({1.0, hoeffding, pinelis});
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
    const auto analysed = static_cast<double>(active.size());
    basis_ = make_basis(original, std::move(active));
    init_modulation(analysed);
}

SpectralWatermark::SpectralWatermark(const Key& key, CanonicalFrame frame, std::vector<std::int32_t> centers,
                                     RbfBasis basis, std::size_t analysed_rows)
    : original_(nullptr), key_(key), frame_(std::move(frame)), centers_(std::move(centers)), threads_(0)
{
    key_.options.validate();
    const int bit_count = payload_bit_count(key_.options);
    if (static_cast<int>(key_.payload.size()) != bit_count)
    {
        throw InvalidOption("the payload has " + std::to_string(key_.payload.size()) +
                            " bits, but the key's parameters need " + std::to_string(bit_count) + ".");
    }
    if (key_.options.basis != BasisType::Rbf || key_.options.centers != CenterSelection::Random)
    {
        throw InvalidOption("a streamed watermark supports the RBF basis with random centers only.");
    }
    basis_ = std::make_unique<RbfBasis>(std::move(basis));
    init_modulation(static_cast<double>(analysed_rows));
}

void SpectralWatermark::require_original(const char* what) const
{
    if (original_ == nullptr)
    {
        throw InvalidOption(std::string("SpectralWatermark: ") + what +
                            " needs the original mesh in memory, but this watermark was built from a stream.");
    }
}

void SpectralWatermark::init_modulation(double analysed)
{
    const int bit_count = payload_bit_count(key_.options);
    // Payload -> key-masked signs b': coefficient c = 3 * mode + axis carries payload bit
    // c mod 3m, with its own mask bit, so the r copies of a bit get independent signs.
    const int modes = modulated_modes(key_.options);
    const int coefficient_count = 3 * modes;
    mask_ = payload_mask(key_.seed, coefficient_count);
    signs_.resize(modes, 3);
    for (int c = 0; c < coefficient_count; ++c)
    {
        const unsigned embedded = static_cast<unsigned>(key_.payload[static_cast<std::size_t>(c % bit_count)]) ^
                                  static_cast<unsigned>(mask_[static_cast<std::size_t>(c)]);
        signs_(c / 3, c % 3) = embedded != 0 ? 1.0 : -1.0;
    }

    // Modulation per coefficient, in the canonical frame.
    const double strength = key_.options.resolved_strength();
    if (key_.options.rule == EmbeddingRule::Additive)
    {
        // |U b' s|_F^2 = 3 m r s^2 for orthonormal modes, so this s gives an RMS displacement of
        // strength * D over the analysed vertices.
        const double step = strength * frame_.diagonal * std::sqrt(analysed / static_cast<double>(coefficient_count));
        modulation_ = Eigen::MatrixX3d::Constant(modes, 3, step);
    }
    else
    {
        const Eigen::MatrixX3d alpha_file = basis_->position_coefficients().middleRows(key_.options.first_mode, modes);
        const Eigen::MatrixX3d alpha = alpha_file * frame_.axes.transpose();
        modulation_ = alpha * strength;
        const double largest = alpha.cwiseAbs().maxCoeff();
        weak_bits_ = static_cast<int>((alpha.array().abs() < kWeakCoefficientFraction * largest).count());
    }
}

std::unique_ptr<const SpectralBasis> SpectralWatermark::make_basis(const TriangleMesh& original,
                                                                   std::vector<std::int32_t> active)
{
    if (key_.options.basis == BasisType::Laplacian)
    {
        LaplacianBasisOptions options;
        options.modes = key_.options.basis_size;
        return std::make_unique<LaplacianBasis>(original, std::move(active), frame_.origin, options);
    }
    centers_ = key_.options.centers == CenterSelection::Decimate
                   ? decimated_centers(original, active, key_.options.basis_size)
                   : random_centers(original.V, active, key_.options.basis_size,
                                    derive_seed(key_.seed, "centers"));
    const double sigma = key_.options.sigma_factor * frame_.diagonal / 2.0;
    return std::make_unique<RbfBasis>(original.V, std::move(active), centers_, sigma, frame_.origin, threads_,
                                      static_cast<std::size_t>(key_.options.gram_rows));
}

Eigen::MatrixX3d SpectralWatermark::coefficient_change() const
{
    // Coefficient change (canonical frame) -> file axes.
    const int first = key_.options.first_mode;
    Eigen::MatrixX3d change = Eigen::MatrixX3d::Zero(first + signs_.rows(), 3);
    change.bottomRows(signs_.rows()) = signs_.cwiseProduct(modulation_) * frame_.axes;
    return change;
}

void SpectralWatermark::describe(const DisplacementSummary& summary, double aabb_diagonal,
                                 double orthogonality_error, EmbedStats* stats) const
{
    stats->max_displacement_rel = std::sqrt(summary.max_squared) / aabb_diagonal;
    stats->rms_displacement_rel = std::sqrt(summary.sum_squared / static_cast<double>(summary.rows)) / aabb_diagonal;
    stats->orthogonality_error = orthogonality_error;
    stats->modulation_step = key_.options.rule == EmbeddingRule::Additive ? modulation_(0, 0) : 0.0;
    stats->weak_bits = weak_bits_;
    stats->analysed_vertices = static_cast<int>(summary.rows);
}

Positions SpectralWatermark::displacement(EmbedStats* stats) const
{
    require_original("displacement");
    // Synthesis U_m (beta - alpha) of the coefficient change.
    double orthogonality = 0.0;
    Positions field = basis_->synthesize(coefficient_change(), &orthogonality);
    if (stats != nullptr)
    {
        // Two independent serial passes, side by side (each as it would run alone).
        const auto& rows = basis_->active_rows();
        double aabb = 0.0;
        DisplacementSummary summary;
#pragma omp parallel sections num_threads(threads_ == 1 ? 1 : 2)
        {
#pragma omp section
            aabb = bounding_box(original_->V, rows).diagonal();
#pragma omp section
            for (const auto i : rows)
            {
                summary.add(field.data() + 3 * static_cast<std::size_t>(i));
            }
        }
        describe(summary, aabb, orthogonality, stats);
    }
    return field;
}

Extraction SpectralWatermark::extraction_from(const Eigen::VectorXd& normalized, const Eigen::VectorXd& variances,
                                              const DetectOptions& options) const
{
    // normalized(c): change of coefficient c divided by its modulation (docs/algorithms/detection.md,
    // sign-correct). Undo each coefficient's mask and average the r copies of every payload
    // bit weighted by their inverse variances (soft decision); the same weights serve the
    // correlation.
    const int bit_count = payload_bit_count(key_.options);
    const auto coefficient_count = normalized.size();
    Extraction result;
    result.normalized_change.resize(static_cast<std::size_t>(coefficient_count));
    result.weights.resize(static_cast<std::size_t>(coefficient_count));
    result.bit_values.assign(static_cast<std::size_t>(bit_count), 0.0);
    std::vector<double> weight_sums(static_cast<std::size_t>(bit_count), 0.0);
    for (Eigen::Index c = 0; c < coefficient_count; ++c)
    {
        const auto slot = static_cast<std::size_t>(c);
        const bool is_determined = std::isfinite(variances(c)) && variances(c) > 0.0;
        const double value = is_determined ? normalized(c) : 0.0;
        const double weight = is_determined ? 1.0 / variances(c) : 0.0;
        result.normalized_change[slot] = value;
        result.weights[slot] = weight;
        const auto bit = slot % static_cast<std::size_t>(bit_count);
        result.bit_values[bit] += weight * (mask_[slot] != 0 ? -value : value);
        weight_sums[bit] += weight;
    }
    result.bits_found.resize(static_cast<std::size_t>(bit_count));
    for (std::size_t t = 0; t < result.bit_values.size(); ++t)
    {
        const double value = weight_sums[t] > 0.0 ? result.bit_values[t] / weight_sums[t] : 0.0;
        result.bit_values[t] = value;
        result.bits_found[t] = value > options.epsilon ? 1 : (value < -options.epsilon ? 0 : 2);
    }
    return result;
}

Extraction SpectralWatermark::extract(const Positions& suspect, const DetectOptions& options,
                                      const std::vector<std::uint8_t>* is_kept) const
{
    require_original("extraction");
    options.validate();
    if (suspect.rows() != original_->V.rows())
    {
        throw InvalidOption("the suspect has " + std::to_string(suspect.rows()) +
                            " vertices in correspondence, the original " +
                            std::to_string(original_->V.rows()) + ".");
    }
    const int modes = static_cast<int>(modulation_.rows());
    const int first = key_.options.first_mode;
    const auto coefficients = static_cast<Eigen::Index>(3 * modes);
    const Positions change = suspect - original_->V;
    auto normalize = [&](const Eigen::MatrixX3d& delta_file) {
        const Eigen::MatrixX3d delta = delta_file * frame_.axes.transpose();
        Eigen::VectorXd x(coefficients);
        for (Eigen::Index c = 0; c < coefficients; ++c)
        {
            const double modulation = modulation_(c / 3, c % 3);
            x(c) = modulation != 0.0 ? delta(c / 3, c % 3) / modulation : 0.0;
        }
        return x;
    };
    if (is_kept != nullptr)
    {
        // gamma - alpha by least squares over the kept rows (cropped copies, docs/algorithms/basis.md).
        return extraction_from(
            normalize(basis_->project_least_squares(change, *is_kept, first + modes).bottomRows(modes)),
            Eigen::VectorXd::Ones(coefficients), options);
    }
    if (!options.remove_nuisance || nuisance_model().modes <= first + modes)
    {
        return extraction_from(normalize(basis_->project(change, first + modes).bottomRows(modes)),
                               Eigen::VectorXd::Ones(coefficients), options);
    }
    // Joint least squares on the leading r modes: the modulated coefficients are free (one
    // unknown each), the nuisance fields (similarity, smoothing) enter through their responses,
    // so their amplitudes are determined by the unmodulated modes and their effect on the
    // modulated ones is removed; the variances weight the correlation.
    const NuisanceModel& model = nuisance_model();
    const int r = model.modes;
    const auto q = static_cast<Eigen::Index>(model.responses.size());
    Eigen::MatrixXd design = Eigen::MatrixXd::Zero(3 * r, coefficients + q);
    for (Eigen::Index c = 0; c < coefficients; ++c)
    {
        const auto mode = c / 3;
        const auto axis = c % 3;
        for (Eigen::Index b = 0; b < 3; ++b)
        {
            // Canonical axis `axis` in file coordinates is frame_.axes.row(axis).
            design(first + mode + r * b, c) = modulation_(mode, axis) * frame_.axes(axis, b);
        }
    }
    for (Eigen::Index f = 0; f < q; ++f)
    {
        design.col(coefficients + f) =
            Eigen::Map<const Eigen::VectorXd>(model.responses[static_cast<std::size_t>(f)].data(), 3 * r);
    }
    const Eigen::MatrixX3d projected = basis_->project(change, r);
    const JointSolution solution =
        solve_jointly(design, Eigen::Map<const Eigen::VectorXd>(projected.data(), 3 * r));
    return extraction_from(solution.amplitudes.head(coefficients), solution.variances.head(coefficients), options);
}

Extraction SpectralWatermark::extract_resampled(const Positions& resampled, const DetectOptions& options,
                                                const std::vector<std::uint8_t>* is_kept) const
{
    require_original("extraction");
    options.validate();
    if (resampled.rows() != original_->V.rows())
    {
        throw InvalidOption("the resampled suspect has " + std::to_string(resampled.rows()) +
                            " rows, the original " + std::to_string(original_->V.rows()) + ".");
    }
    const int modes = static_cast<int>(modulation_.rows());
    const auto coefficients = static_cast<Eigen::Index>(3 * modes);

    // Model: the observed change o = S (U_M diag(mod) b' + sum_f g_f N_f) + noise, where S is
    // the sampling operator (per vertex: projection on the original's normal, S_i = n_i n_i^T,
    // which is what a closest-point resampling keeps of a small displacement; zero on cropped
    // rows; identity for a point cloud) and N_f the nuisance fields. Everything is projected on
    // the leading r well-conditioned modes and (b', g) solved by least squares. The 3r x
    // (3 m + q + 1) system A[(l, b), col] = sum_i U_il (S_i column_i)_b is accumulated by the
    // basis block by block (project_design): neither U_r (#active x r) nor a field per unknown
    // is ever formed. A modulated column (mode, axis) is mod * U_mode S_i a_axis, so its 3 file
    // components come from the 6 distinct products U_mode (S_i)_cb, c <= b: 6 m design columns
    // instead of 9 m (the accumulation's cost is linear in the width).
    const int first = key_.options.first_mode;
    const int r = std::max(basis_->well_conditioned_modes(kNuisanceModeTolerance), first + modes);
    const int head = first + modes;
    const bool has_normals = !original_->is_point_cloud();
    const Positions normals = has_normals ? vertex_normals(*original_) : Positions();
    const NuisanceFields nuisance(*original_, basis_->active_rows(), frame_.origin);
    const Eigen::Index q = nuisance.count();
    const Eigen::Index columns = coefficients + q + 1;
    constexpr Eigen::Index kPairs = 6;
    constexpr std::array<std::array<Eigen::Index, 3>, 3> kPair = {{{0, 1, 2}, {1, 3, 4}, {2, 4, 5}}};
    const Eigen::Index products = kPairs * modes;  // design columns of the modulated unknowns
    const auto width = static_cast<std::size_t>(products + 3 * (q + 1));

    auto is_row_kept = [&](std::int32_t i) {
        return is_kept == nullptr || (*is_kept)[static_cast<std::size_t>(i)] != 0;
    };
    auto sample = [&](std::int32_t i, const Eigen::RowVector3d& v) -> Eigen::RowVector3d {
        if (!has_normals)
        {
            return v;
        }
        const Eigen::RowVector3d normal = normals.row(i);
        return v.dot(normal) * normal;
    };
    // Row a of the block: U_mode (S_i)_cb at X[a][kPairs * mode + pair(c, b)], then for file
    // axis b the nuisance responses (S_i N_f,i)_b and the observed change o_i,b at
    // X[a][products + b (q + 1) + f] (f = q for the observation).
    auto fill = [&](std::span<const std::int32_t> block, const double* U, double* X) {
        const auto h = static_cast<std::size_t>(head);
        for (std::size_t a = 0; a < block.size(); ++a)
        {
            const std::int32_t i = block[a];
            if (!is_row_kept(i))
            {
                continue;
            }
            double* x = X + a * width;
            std::array<double, kPairs> sampling{};
            for (Eigen::Index c = 0; c < 3; ++c)
            {
                for (Eigen::Index b = c; b < 3; ++b)
                {
                    sampling[static_cast<std::size_t>(kPair[static_cast<std::size_t>(c)][static_cast<std::size_t>(b)])] =
                        has_normals ? normals(i, c) * normals(i, b) : (c == b ? 1.0 : 0.0);
                }
            }
            for (int mode = 0; mode < modes; ++mode)
            {
                const double u = U[a * h + static_cast<std::size_t>(first + mode)];
                for (Eigen::Index pair = 0; pair < kPairs; ++pair)
                {
                    x[kPairs * mode + pair] = u * sampling[static_cast<std::size_t>(pair)];
                }
            }
            for (Eigen::Index f = 0; f < q; ++f)
            {
                const Eigen::RowVector3d response = sample(i, nuisance.row(f, i));
                for (Eigen::Index b = 0; b < 3; ++b)
                {
                    x[products + b * (q + 1) + f] = response(b);
                }
            }
            const Eigen::RowVector3d observed = resampled.row(i) - original_->V.row(i);
            for (Eigen::Index b = 0; b < 3; ++b)
            {
                x[products + b * (q + 1) + q] = observed(b);
            }
        }
    };
    const Eigen::MatrixXd projected = basis_->project_design(r, head, width, fill);  // r x width
    Eigen::MatrixXd system(3 * r, columns);
    for (Eigen::Index b = 0; b < 3; ++b)
    {
        for (Eigen::Index c = 0; c < coefficients; ++c)
        {
            const Eigen::Index mode = c / 3;
            const Eigen::Index axis = c % 3;
            // (S a_axis)_b = sum_d S_bd a_axis,d, with a_axis = frame_.axes.row(axis).
            Eigen::VectorXd column = Eigen::VectorXd::Zero(r);
            for (Eigen::Index d = 0; d < 3; ++d)
            {
                column += frame_.axes(axis, d) *
                          projected.col(kPairs * mode + kPair[static_cast<std::size_t>(b)][static_cast<std::size_t>(d)]);
            }
            system.block(b * r, c, r, 1) = modulation_(mode, axis) * column;
        }
        system.block(b * r, coefficients, r, q + 1) = projected.middleCols(products + b * (q + 1), q + 1);
    }
    const JointSolution solution = solve_jointly(system.leftCols(columns - 1), system.col(columns - 1));
    return extraction_from(solution.amplitudes.head(coefficients), solution.variances.head(coefficients), options);
}

const SpectralWatermark::NuisanceModel& SpectralWatermark::nuisance_model() const
{
    if (nuisance_)
    {
        return *nuisance_;
    }
    NuisanceModel model;
    const int modes = key_.options.first_mode + static_cast<int>(modulation_.rows());
    model.modes = basis_->well_conditioned_modes(kNuisanceModeTolerance);
    // Enough unmodulated modes to fit the nuisance fields with room to spare.
    const NuisanceFields fields(*original_, basis_->active_rows(), frame_.origin);
    const Eigen::Index q = fields.count();
    if (model.modes - modes < 4 * static_cast<int>(q))
    {
        model.modes = 0;
        nuisance_ = model;
        return *nuisance_;
    }
    // U_r^T N_f of every field in one pass, the fields evaluated row by row (never stored).
    const auto width = static_cast<std::size_t>(3 * q);
    const Eigen::MatrixXd responses = basis_->project_design(
        model.modes, 0, width, [&](std::span<const std::int32_t> block, const double* /*U*/, double* X) {
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
    nuisance_ = std::move(model);
    return *nuisance_;
}

Decision SpectralWatermark::decide(const Extraction& extraction, const DetectOptions& options) const
{
    options.validate();
    Decision decision;
    decision.verdict = options.verdict;
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
    decision.bits_false_positive_probability = binomial_tail_half(decision.bit_count, decision.matches);

    // Soft-decision correlation with the embedded signs. For a mesh that does not carry this
    // key's mark, x does not depend on the key mask, so sum_c b'_c a_c x_c is a sum of
    // independent random signs with fixed weights (docs/statistics.md). Three weightings a:
    // uniform (best when every coefficient is read equally well), inverse variance (best when
    // the nuisance fit or a crop makes some coefficients far noisier than others) and their
    // geometric mean; the verdict takes the best and pays for the choice with a union bound.
    const auto& x = extraction.normalized_change;
    const auto& w = extraction.weights;
    constexpr std::array<double, 3> kWeightPowers = {0.0, 0.5, 1.0};
    decision.coefficient_count = static_cast<int>(x.size());
    decision.score = 0.0;
    double best_bound = 1.0;
    bool is_first = true;
    for (const double power : kWeightPowers)
    {
        double dot = 0.0;
        double norm_sq = 0.0;
        for (std::size_t c = 0; c < x.size(); ++c)
        {
            // A change below a millionth of the modulation is rounding (an unmarked original
            // compared with itself); dropping it keeps such a score at 0 and depends on no sign.
            const double value = std::abs(x[c]) < kNegligibleChange ? 0.0 : x[c];
            const double weight = power == 0.0 ? 1.0 : std::pow(w[c], power);
            const double wx = weight * value;
            dot += signs_(static_cast<Eigen::Index>(c / 3), static_cast<Eigen::Index>(c % 3)) * wx;
            norm_sq += wx * wx;
        }
        const double z = norm_sq > 0.0 ? dot / std::sqrt(norm_sq) : 0.0;
        if (is_first || z > decision.score)
        {
            decision.score = z;
            best_bound = rademacher_tail_bound(z);
            is_first = false;
        }
    }
    decision.score_false_positive_probability =
        std::min(1.0, static_cast<double>(kWeightPowers.size()) * best_bound);

    if (options.verdict == VerdictRule::Bits)
    {
        decision.false_positive_probability = decision.bits_false_positive_probability;
        decision.is_present = decision.correlation >= options.threshold;
    }
    else
    {
        decision.false_positive_probability = decision.score_false_positive_probability;
        decision.is_present = decision.score_false_positive_probability <= options.max_false_positive;
    }
    return decision;
}

}  // namespace meshmark

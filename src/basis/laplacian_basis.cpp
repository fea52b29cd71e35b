// SPDX-License-Identifier: MIT
#include "meshmark/basis/laplacian_basis.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <string>

#include <Eigen/CholmodSupport>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <Spectra/SymEigsShiftSolver.h>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

using SparseMatrix = Eigen::SparseMatrix<double>;

// The operator y = (L - sigma I)^-1 x that Spectra's shift-invert solver applies: one sparse
// factorization (set_shift), then two triangular solves per Lanczos step.
template <class Factorization>
class ShiftInvertOperator
{
public:
    using Scalar = double;

    explicit ShiftInvertOperator(const SparseMatrix& L) : L_(L) {}

    [[nodiscard]] Eigen::Index rows() const { return L_.rows(); }
    [[nodiscard]] Eigen::Index cols() const { return L_.cols(); }

    void set_shift(double sigma)
    {
        SparseMatrix A = L_;
        for (Eigen::Index i = 0; i < A.rows(); ++i)
        {
            A.coeffRef(i, i) -= sigma;  // the diagonal is stored (combinatorial_laplacian)
        }
        factorization_.compute(A);
        if (factorization_.info() != Eigen::Success)
        {
            throw NumericalError("the factorization of the shifted mesh Laplacian failed (shift " +
                                 std::to_string(sigma) + ").");
        }
    }

    void perform_op(const double* x_in, double* y_out) const
    {
        const Eigen::Map<const Eigen::VectorXd> x(x_in, L_.rows());
        Eigen::Map<Eigen::VectorXd>(y_out, L_.rows()) = factorization_.solve(x);
    }

private:
    const SparseMatrix& L_;
    Factorization factorization_;
};

struct Eigenpairs
{
    Eigen::VectorXd values;
    Eigen::MatrixXd vectors;
    long long operations = 0;
};

template <class Factorization>
Eigenpairs smallest_eigenpairs(const SparseMatrix& L, const LaplacianBasisOptions& options)
{
    const Eigen::Index n = L.rows();
    const Eigen::Index k = options.modes;
    // Lanczos subspace: twice the wanted count is Spectra's recommendation for steady convergence.
    const Eigen::Index ncv = std::min(n, std::max(2 * k + 1, k + 20));
    ShiftInvertOperator<Factorization> op(L);
    Spectra::SymEigsShiftSolver<ShiftInvertOperator<Factorization>> solver(op, k, ncv,
                                                                           options.shift);
    solver.init();  // fixed-seed start vector: deterministic
    solver.compute(Spectra::SortRule::LargestMagn, options.max_iterations, options.tolerance,
                   Spectra::SortRule::SmallestAlge);
    if (solver.info() != Spectra::CompInfo::Successful)
    {
        throw NumericalError("the Laplacian eigensolver did not converge to " + std::to_string(k) +
                             " eigenvectors in " + std::to_string(options.max_iterations) +
                             " restarts.");
    }
    return {solver.eigenvalues(), solver.eigenvectors(),
            static_cast<long long>(solver.num_operations())};
}

// Sign convention of the header: sum of cubes positive, else the largest component positive.
void fix_signs(Eigen::MatrixXd& U)
{
    // A sign test whose sum is within this of its scale is rounding: the largest component
    // decides instead. Chosen by hand; no study on record.
    constexpr double kSignTieTolerance = 1e-12;
    for (Eigen::Index j = 0; j < U.cols(); ++j)
    {
        auto u = U.col(j);
        const double cubes = u.array().cube().sum();
        double sign = cubes;
        if (std::abs(cubes) <= kSignTieTolerance * u.array().abs().cube().sum())
        {
            Eigen::Index largest = 0;
            u.cwiseAbs().maxCoeff(&largest);
            sign = u(largest);
        }
        if (sign < 0.0)
        {
            u = -u;
        }
    }
}

}  // namespace

void LaplacianBasisOptions::validate() const
{
    if (modes < 1)
    {
        throw InvalidOption("the Laplacian basis needs at least 1 mode, got " +
                            std::to_string(modes) + ".");
    }
    if (!(shift < 0.0) || !std::isfinite(shift))
    {
        throw InvalidOption("the shift of the Laplacian eigensolver must be negative, got " +
                            std::to_string(shift) + ".");
    }
    if (!(tolerance > 0.0 && tolerance < 1e-2) || max_iterations < 1)
    {
        throw InvalidOption(
            "the Laplacian eigensolver needs a tolerance in (0, 0.01) and at least "
            "one iteration.");
    }
}

SparseMatrix combinatorial_laplacian(const TriangleMesh& mesh,
                                     const std::vector<std::int32_t>& active)
{
    std::vector<std::int32_t> slot(static_cast<std::size_t>(mesh.V.rows()), -1);
    for (std::size_t a = 0; a < active.size(); ++a)
    {
        slot[static_cast<std::size_t>(active[a])] = static_cast<std::int32_t>(a);
    }
    // Directed edges (both ways) of every triangle over the active rows, deduplicated.
    std::vector<std::pair<std::int32_t, std::int32_t>> edges;
    edges.reserve(6 * static_cast<std::size_t>(mesh.F.rows()));
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        for (int e = 0; e < 3; ++e)
        {
            const auto a = slot[static_cast<std::size_t>(mesh.F(f, e))];
            const auto b = slot[static_cast<std::size_t>(mesh.F(f, (e + 1) % 3))];
            if (a >= 0 && b >= 0 && a != b)
            {
                edges.emplace_back(a, b);
                edges.emplace_back(b, a);
            }
        }
    }
    std::sort(edges.begin(), edges.end());
    edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
    const auto n = static_cast<Eigen::Index>(active.size());
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(edges.size() + active.size());
    Eigen::VectorXd degree = Eigen::VectorXd::Zero(n);
    for (const auto& [a, b] : edges)
    {
        triplets.emplace_back(a, b, -1.0);
        degree(a) += 1.0;
    }
    for (Eigen::Index a = 0; a < n; ++a)
    {
        triplets.emplace_back(a, a, degree(a));  // stored even when 0 (the shift goes there)
    }
    SparseMatrix L(n, n);
    L.setFromTriplets(triplets.begin(), triplets.end());
    return L;
}

LaplacianBasis::LaplacianBasis(const TriangleMesh& mesh, std::vector<std::int32_t> active,
                               const Eigen::Vector3d& origin, const LaplacianBasisOptions& options)
    : V_(&mesh.V), active_(std::move(active)), origin_(origin)
{
    options.validate();
    if (mesh.is_point_cloud())
    {
        throw InvalidMesh(
            "the Laplacian basis needs triangles, but the mesh is a point cloud (no "
            "faces); use the RBF basis (--basis rbf).");
    }
    if (static_cast<long long>(active_.size()) <= options.modes)
    {
        throw InvalidMesh("the mesh has " + std::to_string(active_.size()) +
                          " usable vertices, too few for " + std::to_string(options.modes) +
                          " Laplacian eigenvectors (use a smaller --basis-size).");
    }
    // Laplacian -> factorization of L - sigma I -> shift-invert Lanczos -> signs.
    const SparseMatrix L = combinatorial_laplacian(mesh, active_);
    Eigenpairs pairs =
        options.factorization == LaplacianFactorization::Cholmod
            ? smallest_eigenpairs<Eigen::CholmodSupernodalLLT<SparseMatrix, Eigen::Lower>>(L,
                                                                                           options)
            : smallest_eigenpairs<Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower>>(L, options);
    eigenvalues_ = std::move(pairs.values);
    U_ = std::move(pairs.vectors);
    operations_ = pairs.operations;
    fix_signs(U_);
}

void LaplacianBasis::check_modes(int modes) const
{
    if (modes <= 0 || modes > size())
    {
        throw InvalidOption("the number of modes must be in 1.." + std::to_string(size()) +
                            ", got " + std::to_string(modes) + ".");
    }
}

Eigen::MatrixX3d LaplacianBasis::gather(const Positions& X) const
{
    Eigen::MatrixX3d out(static_cast<Eigen::Index>(active_.size()), 3);
    for (std::size_t a = 0; a < active_.size(); ++a)
    {
        out.row(static_cast<Eigen::Index>(a)) = X.row(active_[a]);
    }
    return out;
}

Eigen::MatrixX3d LaplacianBasis::position_coefficients() const
{
    Eigen::MatrixX3d P = gather(*V_);
    P.rowwise() -= origin_.transpose();
    return U_.transpose() * P;
}

Eigen::MatrixX3d LaplacianBasis::project(const Positions& X, int modes) const
{
    check_modes(modes);
    return U_.leftCols(modes).transpose() * gather(X);
}

std::vector<Eigen::MatrixX3d> LaplacianBasis::project(const std::vector<Positions>& fields,
                                                      int modes) const
{
    std::vector<Eigen::MatrixX3d> result;
    result.reserve(fields.size());
    for (const auto& X : fields)
    {
        result.push_back(project(X, modes));
    }
    return result;
}

int LaplacianBasis::well_conditioned_modes(double /*relative_tolerance*/) const
{
    return size();
}

Eigen::MatrixX3d LaplacianBasis::project_least_squares(const Positions& X,
                                                       const std::vector<std::uint8_t>& is_kept,
                                                       int modes) const
{
    // Leading modes only, as for the RBF basis (see RbfBasis::project_least_squares).
    check_modes(modes);
    const auto m = static_cast<Eigen::Index>(modes);
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(m, m);
    Eigen::MatrixX3d rhs = Eigen::MatrixX3d::Zero(m, 3);
    for (std::size_t a = 0; a < active_.size(); ++a)
    {
        const auto row = active_[a];
        if (is_kept[static_cast<std::size_t>(row)] == 0)
        {
            continue;
        }
        const auto u = U_.row(static_cast<Eigen::Index>(a)).head(m);
        normal.noalias() += u.transpose() * u;
        rhs.noalias() += u.transpose() * X.row(row);
    }
    // U_m^T U_m is the identity on the whole mesh: a smallest eigenvalue at or below this over the
    // kept rows (a condition number of 1e8) leaves the coefficients undetermined. Chosen by
    // hand; no study on record.
    constexpr double kMinKeptEigenvalue = 1e-8;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> check(normal, Eigen::EigenvaluesOnly);
    if (check.info() != Eigen::Success || !(check.eigenvalues()(0) > kMinKeptEigenvalue))
    {
        throw NumericalError(
            "too few vertices survive the cropping to determine the watermark's "
            "coefficients (least-squares matrix is singular).");
    }
    return normal.ldlt().solve(rhs);
}

Positions LaplacianBasis::synthesize(const Eigen::MatrixX3d& c, double* orthogonality_error) const
{
    const int modes = static_cast<int>(c.rows());
    check_modes(modes);
    const Eigen::MatrixX3d field = U_.leftCols(modes) * c;
    Positions result = Positions::Zero(V_->rows(), 3);
    for (std::size_t a = 0; a < active_.size(); ++a)
    {
        result.row(active_[a]) = field.row(static_cast<Eigen::Index>(a));
    }
    if (orthogonality_error != nullptr)
    {
        const Eigen::MatrixXd utu = U_.leftCols(modes).transpose() * U_.leftCols(modes);
        *orthogonality_error =
            (utu - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff();
    }
    return result;
}

void LaplacianBasis::synthesize_streamed(const Eigen::MatrixX3d& c,
                                         std::size_t /*chunks_in_flight*/, const FieldSink& sink,
                                         double* orthogonality_error) const
{
    // The eigenvectors are in memory already: synthesize the field over the active rows at
    // once (as synthesize() does) and hand it out in chunks.
    const int modes = static_cast<int>(c.rows());
    check_modes(modes);
    using RowMajor3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
    const RowMajor3 field = U_.leftCols(modes) * c;
    if (orthogonality_error != nullptr)
    {
        const Eigen::MatrixXd utu = U_.leftCols(modes).transpose() * U_.leftCols(modes);
        *orthogonality_error =
            (utu - Eigen::MatrixXd::Identity(modes, modes)).cwiseAbs().maxCoeff();
    }
    for (std::size_t begin = 0; begin < active_.size(); begin += max_chunk_rows())
    {
        sink(begin, std::min(max_chunk_rows(), active_.size() - begin), field.data() + 3 * begin);
    }
}

Eigen::MatrixXd LaplacianBasis::modes_dense(int modes) const
{
    check_modes(modes);
    return U_.leftCols(modes);
}

Eigen::MatrixXd LaplacianBasis::project_design(int modes, int head, std::size_t width,
                                               const DesignFill& fill) const
{
    check_modes(modes);
    if (head < 0 || head > modes)
    {
        throw InvalidOption("project_design: head must be in 0.." + std::to_string(modes) +
                            ", got " + std::to_string(head) + ".");
    }
    // Serial, fixed blocks in row order: bit-identical for any thread count by construction
    // (1024 rows chosen by hand; no study on record).
    constexpr std::size_t kBlockRows = 1024;
    const auto cols = static_cast<Eigen::Index>(width);
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::MatrixXd result = Eigen::MatrixXd::Zero(modes, cols);
    RowMajor Ublock;
    RowMajor X;
    for (std::size_t begin = 0; begin < active_.size(); begin += kBlockRows)
    {
        const std::size_t rows = std::min(kBlockRows, active_.size() - begin);
        const auto r = static_cast<Eigen::Index>(rows);
        Ublock = U_.block(static_cast<Eigen::Index>(begin), 0, r, head);
        X.setZero(r, cols);
        fill(std::span<const std::int32_t>(active_.data() + begin, rows),
             head > 0 ? Ublock.data() : nullptr, X.data());
        result.noalias() += U_.block(static_cast<Eigen::Index>(begin), 0, r, modes).transpose() * X;
    }
    return result;
}

}  // namespace meshmark

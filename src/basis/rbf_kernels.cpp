// SPDX-License-Identifier: MIT
// Portable block kernels: the evaluation as a scalar loop, the products through Eigen, which
// vectorizes them for the baseline target (SSE2 on x86-64); and the run-time choice among the
// three builds (set_basis_kernel, MESHMARK_BASIS_KERNEL).
#include "basis/rbf_kernels.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <string_view>

#include <Eigen/Core>

#include "meshmark/basis/rbf_basis.h"

namespace meshmark::detail
{
namespace
{

using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using ConstBlock = Eigen::Map<const RowMajor>;
using Block = Eigen::Map<RowMajor>;

Eigen::Index as_index(std::size_t n)
{
    return static_cast<Eigen::Index>(n);
}

void evaluate(const double* P, std::size_t rows, const double* Q, std::size_t k, std::size_t ld,
              double inv_sigma, double* B)
{
    const double* qx = Q;
    const double* qy = Q + ld;
    const double* qz = Q + 2 * ld;
    const double outside_squared = outside_squared_distance(inv_sigma);
    for (std::size_t r = 0; r < rows; ++r)
    {
        const double px = P[3 * r];
        const double py = P[3 * r + 1];
        const double pz = P[3 * r + 2];
        double* row = B + r * ld;
        for (std::size_t j = 0; j < k; ++j)  // the AVX2 kernel's lanes, entry for entry
        {
            row[j] = wendland_entry(px, py, pz, qx[j], qy[j], qz[j], inv_sigma, outside_squared);
        }
        for (std::size_t j = k; j < ld; ++j)
        {
            row[j] = 0.0;
        }
    }
}

void gram(const double* B, std::size_t rows, std::size_t ld, double* G)
{
    const ConstBlock b(B, as_index(rows), as_index(ld));
    Block g(G, as_index(ld), as_index(ld));
    g.selfadjointView<Eigen::Lower>().rankUpdate(b.transpose());
}

void multiply(const double* B, std::size_t rows, std::size_t ld, const double* Mt, std::size_t w,
              double* out)
{
    const ConstBlock b(B, as_index(rows), as_index(ld));
    const ConstBlock mt(Mt, as_index(w), as_index(ld));
    Block o(out, as_index(rows), as_index(w));
    o.noalias() = b * mt.transpose();
}

void accumulate(const double* B, std::size_t rows, std::size_t ld, const double* X, std::size_t w,
                double* acc)
{
    const ConstBlock b(B, as_index(rows), as_index(ld));
    const ConstBlock x(X, as_index(rows), as_index(w));
    Block a(acc, as_index(w), as_index(ld));
    a.noalias() += x.transpose() * b;
}

constexpr BlockKernels kPortable{"portable", evaluate, gram, multiply, accumulate};

}  // namespace

const BlockKernels& portable_kernels() noexcept
{
    return kPortable;
}

namespace
{

BasisKernel kernel_from_environment() noexcept
{
    const char* value = std::getenv("MESHMARK_BASIS_KERNEL");
    if (value == nullptr)
    {
        return BasisKernel::Automatic;
    }
    const std::string_view text(value);
    if (text == "portable")
    {
        return BasisKernel::Portable;
    }
    if (text == "avx2")
    {
        return BasisKernel::Avx2;
    }
    return text == "avx512" ? BasisKernel::Avx512 : BasisKernel::Automatic;
}

std::atomic<BasisKernel>& kernel_choice() noexcept
{
    static std::atomic<BasisKernel> choice{kernel_from_environment()};
    return choice;
}

}  // namespace

const BlockKernels& selected_kernels() noexcept
{
    const BasisKernel choice = kernel_choice().load();
    if (choice == BasisKernel::Automatic || choice == BasisKernel::Avx512)
    {
        if (const auto* fastest = avx512_kernels())
        {
            return *fastest;
        }
    }
    if (choice != BasisKernel::Portable)
    {
        if (const auto* fast = avx2_kernels())
        {
            return *fast;
        }
    }
    return portable_kernels();
}

}  // namespace meshmark::detail

namespace meshmark
{

void set_basis_kernel(BasisKernel kernel) noexcept
{
    detail::kernel_choice().store(kernel);
}

std::string_view basis_kernel_name() noexcept
{
    return detail::selected_kernels().name;
}

}  // namespace meshmark

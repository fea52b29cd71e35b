// SPDX-License-Identifier: MIT
// The shared part of a family's copies, built once; then one code's field per copy.
#include "meshmark/pipeline/family_copies.h"

#include <algorithm>
#include <array>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/pipeline/embed_file.h"

namespace meshmark
{

namespace
{

// Rows of the analysed vertices summed per block: a block's sums stay in the first-level cache.
constexpr std::int64_t kRowBlock = 256;

// The code fields of a block of \p size analysed rows: sums[k * kRowBlock + r] =
// sum over modes m, in mode order, of u[m * kRowBlock + r] * changes[m * width + k], k < width
// (copy-major, then axis). Vectorized across rows, each sum still adds its products one mode
// after the other from zero, so a copy's bits do not depend on the instruction set, the block
// or the batch.
__attribute__((target_clones("avx512f", "avx2", "default"))) void code_field_block(
    const double* u, int modes, std::size_t size, const double* changes, std::size_t width,
    double* sums)
{
    // By 64 rows at a time, so that the sums of 8 copies (24 x 64 doubles) stay in the first-level
    // cache while every mode passes over them.
    constexpr std::size_t kSubRows = 64;
    for (std::size_t first = 0; first < size; first += kSubRows)
    {
        const std::size_t rows = std::min(kSubRows, size - first);
        for (std::size_t k = 0; k < width; ++k)
        {
            double* sum = sums + k * static_cast<std::size_t>(kRowBlock) + first;
            std::fill(sum, sum + rows, 0.0);
        }
        for (int mode = 0; mode < modes; ++mode)
        {
            const double* column =
                u + static_cast<std::size_t>(mode) * static_cast<std::size_t>(kRowBlock) + first;
            const double* c = changes + static_cast<std::size_t>(mode) * width;
            for (std::size_t k = 0; k < width; ++k)
            {
                const double ck = c[k];
                double* sum = sums + k * static_cast<std::size_t>(kRowBlock) + first;
                for (std::size_t r = 0; r < rows; ++r)
                {
                    sum[r] += column[r] * ck;
                }
            }
        }
    }
}

}  // namespace

FamilyCopies::FamilyCopies(const MeshFile& file, const Key& key, const std::filesystem::path& path,
                           int threads)
    : file_(&file), mark_(watermark_of(file.mesh, key, path, threads))
{
    if (!key.recipients)
    {
        throw InvalidOption(path.string() +
                            ": the key marks a single owner's copy, not a family of recipients.");
    }
    owner_ = mark_.displacement(&owner_stats_);
    prepare();
}

FamilyCopies::FamilyCopies(const MeshFile& file, SpectralWatermark mark, Positions owner,
                           const EmbedStats& owner_stats)
    : file_(&file), mark_(std::move(mark)), owner_(std::move(owner)), owner_stats_(owner_stats)
{
    prepare();
}

FamilyCopies::~FamilyCopies() = default;

void FamilyCopies::prepare()
{
    const EmbedOptions& options = mark_.key().options;
    // With the surface measure each copy's code is scaled so that the copy (owner's mark plus
    // code) is displaced by exactly the strength: the codes differ, and so, unscaled, would the
    // copies' surface distances (by up to 7% on the shared meshes). Only the code is scaled, so
    // the owner's mark stays the one detection rebuilds from the key; a code's statistics do not
    // depend on its scale (docs/fingerprinting.md, "Distortion of a copy").
    if (options.rule == EmbeddingRule::Additive && options.measure == StrengthMeasure::Surface)
    {
        copy_surface_.emplace(file_->mesh, owner_);
    }
    owner_ += file_->mesh.V;  // the positions every copy shares
    // The recipient modes, explicitly: one product per copy instead of a pass over the basis.
    const int head = options.first_mode + modulated_modes(options);
    const int modes = mark_.recipient_modes();
    // Stored by blocks of kRowBlock rows, each block's modes one after the other: a copy reads
    // them once, in order (#rows x M doubles: 25 MB for 48K rows and 64 modes), so the sums
    // wait on one sequential stream instead of M interleaved ones.
    const Eigen::MatrixXd dense = mark_.basis().modes_dense(head + modes);  // column-major
    const auto rows = dense.rows();
    const auto blocks = (rows + kRowBlock - 1) / kRowBlock;
    code_modes_.assign(static_cast<std::size_t>(blocks * modes * kRowBlock), 0.0);
    for (Eigen::Index block = 0; block < blocks; ++block)
    {
        const Eigen::Index first = block * kRowBlock;
        const Eigen::Index count = std::min<Eigen::Index>(kRowBlock, rows - first);
        for (int mode = 0; mode < modes; ++mode)
        {
            const double* from =
                dense.col(head + mode).data() + first;  // contiguous rows of one mode
            std::copy(from, from + count,
                      code_modes_.begin() +
                          static_cast<std::ptrdiff_t>((block * modes + mode) * kRowBlock));
        }
    }
    const std::vector<std::int32_t>& active = mark_.mesh_rows()->active();
    diagonal_ = bounding_box(file_->mesh.V, active).diagonal();  // EmbedStats' unit
    copy_target_ = options.resolved_strength() * diagonal_;
}

std::size_t FamilyCopies::memory_bytes() const noexcept
{
    // An estimate from the sizes that grow with the mesh: the shared positions, the modes, the
    // surface measure's per-face terms, the watermark's copy of the analysed rows (positions and
    // indices) and two k x k matrices of the basis.
    const auto n = static_cast<std::size_t>(owner_.rows());
    const auto faces = static_cast<std::size_t>(file_->mesh.F.rows());
    const auto k = static_cast<std::size_t>(mark_.basis().size());
    const std::size_t doubles = 3 * n + static_cast<std::size_t>(code_modes_.size()) +
                                (copy_surface_ ? 7 * faces : 0) + 3 * n + 2 * k * k;
    return sizeof(double) * doubles + sizeof(std::int32_t) * n;
}

void FamilyCopies::make(std::span<const std::uint32_t> indices, std::vector<Positions>& out,
                        std::span<EmbedStats> stats, int threads) const
{
    const std::size_t count = indices.size();
    if (count > kBatch || (!stats.empty() && stats.size() != count))
    {
        throw InvalidOption("FamilyCopies::make: at most " + std::to_string(kBatch) +
                            " copies at once, with one EmbedStats each or none.");
    }
    threads = resolve_threads(threads);
    const int modes = mark_.recipient_modes();
    const std::vector<std::int32_t>& active = mark_.mesh_rows()->active();
    const auto rows = static_cast<std::int64_t>(active.size());
    // Each mode's values are read once per block of rows for all the copies, and each coordinate
    // of each copy is its own sum over the modes in mode order (code_field_block), so a copy's
    // bytes do not depend on the batch nor on the thread count.
    const std::size_t width = 3 * count;
    std::vector<double> changes(static_cast<std::size_t>(modes) *
                                width);  // mode-major, then copy, axis
    for (std::size_t b = 0; b < count; ++b)
    {
        const Eigen::MatrixX3d change = mark_.recipient_change(indices[b]);
        for (int mode = 0; mode < modes; ++mode)
        {
            for (int axis = 0; axis < 3; ++axis)
            {
                changes[static_cast<std::size_t>(mode) * width + 3 * b +
                        static_cast<std::size_t>(axis)] = change(mode, axis);
            }
        }
    }
    out.resize(count);
    for (Positions& p : out)
    {
        p.setZero(owner_.rows(), 3);  // the code's field first; no new allocation when reused
    }
    const auto blocks = (rows + kRowBlock - 1) / kRowBlock;
#pragma omp parallel for num_threads(threads) schedule(static)
    for (std::int64_t block = 0; block < blocks; ++block)
    {
        const std::int64_t first = block * kRowBlock;
        const auto size = static_cast<std::size_t>(std::min<std::int64_t>(kRowBlock, rows - first));
        std::array<double, 3 * kBatch * kRowBlock> sums;  // copy-axis major, then row
        code_field_block(code_modes_.data() + static_cast<std::size_t>(block * modes * kRowBlock),
                         modes, size, changes.data(), width, sums.data());
        for (std::size_t r = 0; r < size; ++r)
        {
            const auto i = active[static_cast<std::size_t>(first) + r];
            for (std::size_t b = 0; b < count; ++b)
            {
                for (int axis = 0; axis < 3; ++axis)
                {
                    out[b](i, axis) =
                        sums[(3 * b + static_cast<std::size_t>(axis)) * kRowBlock + r];
                }
            }
        }
    }
    // Each copy: its code's scale (1 for the vertex measure, where owner + 1 * code is
    // owner + code to the bit), then the positions.
    std::array<double, kBatch> surface{};
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
    for (std::int64_t b = 0; b < static_cast<std::int64_t>(count); ++b)
    {
        Positions& copy = out[static_cast<std::size_t>(b)];
        double scale = 1.0;
        if (copy_surface_)
        {
            const SurfaceRmsOfSums::Terms terms = copy_surface_->terms(copy);
            scale = terms.scale_to(copy_target_);
            surface[static_cast<std::size_t>(b)] = terms.rms(scale);
        }
        copy = owner_ + scale * copy;
    }
    for (std::size_t b = 0; b < count && !stats.empty(); ++b)
    {
        DisplacementSummary summary;
        for (const std::int32_t i : active)
        {
            const Eigen::RowVector3d d = out[b].row(i) - file_->mesh.V.row(i);
            summary.add(d.data());
        }
        mark_.describe(summary, diagonal_, owner_stats_.orthogonality_error, &stats[b]);
        stats[b].surface_rms_rel = diagonal_ > 0.0 ? surface[b] / diagonal_ : 0.0;
    }
}

}  // namespace meshmark

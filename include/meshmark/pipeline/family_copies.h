// SPDX-License-Identifier: MIT
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include "meshmark/io/mesh_io.h"
#include "meshmark/metrics/distortion.h"
#include "meshmark/watermark/key.h"
#include "meshmark/watermark/watermark.h"

namespace meshmark
{

/// \brief What every copy of one family key's original shares, built once: the watermark, the
/// owner's mark added to the original's positions, and the recipients' modes. Each recipient's
/// copy then costs its code's field (M modes per analysed vertex) and nothing else
/// (docs/fingerprinting.md, "How a copy is marked").
/// \details embed_recipients builds one per call; the issuing service keeps one per asset it
/// serves (docs/service.md). make() is const and may run on several threads at once. A copy's
/// positions do not depend on which other copies are made with it nor on the thread count, so a
/// recipient issued again gets the same bytes.
class FamilyCopies
{
public:
    /// Copies made in one pass over the recipients' modes (make()'s most).
    static constexpr std::size_t kBatch = 8;

    /// \brief For the family key \p key of \p file (both must outlive this object); its basis is
    /// built on \p threads threads. \p path names the file in errors.
    /// \throws InvalidOption (not a family key), InvalidMesh, NumericalError (watermark_of).
    FamilyCopies(const MeshFile& file, const Key& key, const std::filesystem::path& path,
                 int threads);

    /// \brief From a watermark already built on \p file (a new key, calibrated) and its owner's
    /// field \p owner with \p owner_stats (SpectralWatermark::displacement()).
    FamilyCopies(const MeshFile& file, SpectralWatermark mark, Positions owner,
                 const EmbedStats& owner_stats);

    FamilyCopies(const FamilyCopies&) = delete;
    FamilyCopies& operator=(const FamilyCopies&) = delete;
    FamilyCopies(FamilyCopies&&) = delete;
    FamilyCopies& operator=(FamilyCopies&&) = delete;
    ~FamilyCopies();

    /// \brief The positions of the copies of recipients \p indices (at most kBatch), into \p out
    /// (resized; its matrices reused), each copy's distortion into \p stats (same size, or
    /// empty: not measured), on \p threads threads.
    void make(std::span<const std::uint32_t> indices, std::vector<Positions>& out,
              std::span<EmbedStats> stats, int threads) const;

    [[nodiscard]] const MeshFile& file() const noexcept { return *file_; }
    [[nodiscard]] const SpectralWatermark& watermark() const noexcept { return mark_; }
    /// Bytes held besides the file (an estimate: the shared positions, the modes, the basis).
    [[nodiscard]] std::size_t memory_bytes() const noexcept;

private:
    void prepare();

    const MeshFile* file_;
    SpectralWatermark mark_;
    Positions owner_;  ///< The original's positions plus the owner's mark.
    EmbedStats owner_stats_;
    std::optional<SurfaceRmsOfSums> copy_surface_;
    /// The recipients' modes on the analysed rows, by blocks of rows (family_copies.cpp).
    std::vector<double> code_modes_;
    double diagonal_ = 0.0;
    double copy_target_ = 0.0;
};

}  // namespace meshmark

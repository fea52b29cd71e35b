// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// \brief What is visible at each pixel: the nearest triangle (or point) and where on it.
/// \details A "visibility buffer": rasterization only decides visibility, and a separate pass
/// shades each pixel from the primitive and barycentric coordinates stored here.
struct VisibilityBuffer
{
    int width = 0;
    int height = 0;
    /// Per pixel, row-major from the top: depth of the nearest primitive (larger is nearer;
    /// -infinity where nothing was drawn).
    std::vector<float> depth;
    /// Per pixel: index of the nearest face (rasterize_triangles) or point (rasterize_points), -1
    /// for none.
    std::vector<std::int32_t> primitive;
    /// Per pixel, for triangles: barycentric weights of the face's 2nd and 3rd corners at the
    /// pixel centre (the 1st is 1 - u - v). For points: the pixel centre's offset from the
    /// point, in splat radii (x to the right, y down).
    std::vector<float> u;
    std::vector<float> v;

    VisibilityBuffer(int width, int height);
    [[nodiscard]] std::size_t index(int x, int y) const
    {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
               static_cast<std::size_t>(x);
    }
};

/// \brief Rasterize triangles with a depth buffer.
/// \details \p screen holds one row per vertex: x and y in pixels (x to the right, y down, pixel
/// (i, j) covering [i, i+1) x [j, j+1)), and a depth (larger is nearer, interpolated linearly, as
/// in an orthographic view). A pixel belongs to a triangle when its centre is inside or on a
/// top or left edge (the usual fill rule: triangles sharing an edge cover each of its pixels
/// once). Both windings are drawn (no back-face culling); degenerate triangles are skipped.
/// On equal depth the face listed first stays. The image is cut into bands of rows drawn in
/// parallel (\p threads, 0 = all cores); every band draws its faces in index order, so the
/// buffer is the same for any thread count.
/// \param faces  Indices into the rows of \p screen (must be in range).
[[nodiscard]] VisibilityBuffer rasterize_triangles(const Positions& screen, const Faces& faces,
                                                   int width, int height, int threads = 0);

/// \brief Rasterize points as discs of \p radius pixels (at least the pixel under the point)
/// with a depth buffer; \p screen as for rasterize_triangles, \p points the rows to draw.
/// \details On equal depth the point listed first stays; the same for any thread count.
[[nodiscard]] VisibilityBuffer rasterize_points(const Positions& screen,
                                                const std::vector<std::int32_t>& points,
                                                double radius, int width, int height,
                                                int threads = 0);

}  // namespace meshmark

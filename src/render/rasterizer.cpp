// SPDX-License-Identifier: MIT
// A small software rasterizer (no display or GPU): edge functions over the pixel centres,
// a depth buffer, rows cut into bands drawn in parallel. Written by hand: Debian packages no
// offscreen software renderer that takes a triangle list and gives back a depth and primitive
// buffer without a windowing or GL stack (OSMesa would need GL code around it for the same
// ~200 lines).
#include "meshmark/render/rasterizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "meshmark/core/threads.h"

namespace meshmark
{
namespace
{

// Rows per band: bands are the unit of parallel work (each thread draws whole bands); chosen by
// hand; no study on record.
constexpr int kBandRows = 16;

/// Primitives binned by band of rows, each band's list in primitive order (a counting sort).
struct Bins
{
    std::vector<std::size_t> start;  // band b's entries: items[start[b] .. start[b+1])
    std::vector<std::int32_t> items;
};

/// \p rows(i, lo, hi) gives primitive i's rows [lo, hi] (hi < lo when it covers none).
template <class RowRange>
Bins bin_by_band(std::size_t count, int height, RowRange rows)
{
    const int bands = (height + kBandRows - 1) / kBandRows;
    Bins bins;
    bins.start.assign(static_cast<std::size_t>(bands) + 1, 0);
    std::vector<std::pair<int, int>> range(count);
    for (std::size_t i = 0; i < count; ++i)
    {
        int lo = 0;
        int hi = -1;
        rows(i, lo, hi);
        lo = std::max(lo, 0);
        hi = std::min(hi, height - 1);
        range[i] = {lo / kBandRows, hi < lo ? -1 : hi / kBandRows};
        for (int b = range[i].first; b <= range[i].second; ++b)
        {
            ++bins.start[static_cast<std::size_t>(b) + 1];
        }
    }
    for (int b = 0; b < bands; ++b)
    {
        bins.start[static_cast<std::size_t>(b) + 1] += bins.start[static_cast<std::size_t>(b)];
    }
    bins.items.resize(bins.start.back());
    std::vector<std::size_t> next(bins.start.begin(), bins.start.end() - 1);
    for (std::size_t i = 0; i < count; ++i)
    {
        for (int b = range[i].first; b <= range[i].second; ++b)
        {
            bins.items[next[static_cast<std::size_t>(b)]++] = static_cast<std::int32_t>(i);
        }
    }
    return bins;
}

/// Rows j whose centre j + 0.5 lies in [lo, hi].
void centre_rows(double lo, double hi, int& first, int& last)
{
    if (!(std::isfinite(lo) && std::isfinite(hi)))
    {
        first = 0;
        last = -1;
        return;
    }
    const double limit = 1e9;
    first = static_cast<int>(std::ceil(std::clamp(lo - 0.5, -limit, limit)));
    last = static_cast<int>(std::floor(std::clamp(hi - 0.5, -limit, limit)));
}

/// One edge's line equation a x + b y + c, written for the edge's vertices in increasing index
/// order so that the two triangles sharing the edge evaluate exactly opposite values.
struct Edge
{
    double a = 0.0;
    double b = 0.0;
    double c = 0.0;
    bool owns_ties =
        false;  ///< Whether a pixel centre exactly on the edge belongs to this triangle.

    Edge(const Positions& s, std::int32_t i, std::int32_t j)
    {
        const bool flip = i > j;
        const std::int32_t p = flip ? j : i;
        const std::int32_t q = flip ? i : j;
        a = s(p, 1) - s(q, 1);
        b = s(q, 0) - s(p, 0);
        c = -(a * s(p, 0) + b * s(p, 1));
        if (flip)
        {
            a = -a;
            b = -b;
            c = -c;
        }
    }
    [[nodiscard]] double at(double x, double y) const { return (a * x + b * y) + c; }
    void negate()
    {
        a = -a;
        b = -b;
        c = -c;
    }
    // Of two triangles sharing an edge, exactly one has each sign of (a, b): it owns the ties.
    void decide_ties() { owns_ties = a > 0.0 || (a == 0.0 && b > 0.0); }
    [[nodiscard]] bool inside(double w) const { return w > 0.0 || (w == 0.0 && owns_ties); }
};

void draw_triangle(const Positions& s, const Faces& faces, std::int32_t f, int row_lo, int row_hi,
                   VisibilityBuffer& out)
{
    const std::int32_t i0 = faces(f, 0);
    const std::int32_t i1 = faces(f, 1);
    const std::int32_t i2 = faces(f, 2);
    Edge e0(s, i1, i2);  // weight of corner 0
    Edge e1(s, i2, i0);  // weight of corner 1
    Edge e2(s, i0, i1);  // weight of corner 2
    double area = e2.at(s(i2, 0), s(i2, 1));
    if (!(std::abs(area) > 0.0) || !std::isfinite(area))
    {
        return;  // degenerate or seen edge-on
    }
    if (area < 0.0)
    {
        e0.negate();
        e1.negate();
        e2.negate();
        area = -area;
    }
    e0.decide_ties();
    e1.decide_ties();
    e2.decide_ties();
    int y_first = 0;
    int y_last = -1;
    centre_rows(std::min({s(i0, 1), s(i1, 1), s(i2, 1)}), std::max({s(i0, 1), s(i1, 1), s(i2, 1)}),
                y_first, y_last);
    int x_first = 0;
    int x_last = -1;
    centre_rows(std::min({s(i0, 0), s(i1, 0), s(i2, 0)}), std::max({s(i0, 0), s(i1, 0), s(i2, 0)}),
                x_first, x_last);
    y_first = std::max(y_first, row_lo);
    y_last = std::min(y_last, row_hi);
    x_first = std::max(x_first, 0);
    x_last = std::min(x_last, out.width - 1);
    const double z0 = s(i0, 2);
    const double z1 = s(i1, 2);
    const double z2 = s(i2, 2);
    for (int y = y_first; y <= y_last; ++y)
    {
        const double py = y + 0.5;
        for (int x = x_first; x <= x_last; ++x)
        {
            const double px = x + 0.5;
            const double w0 = e0.at(px, py);
            const double w1 = e1.at(px, py);
            const double w2 = e2.at(px, py);
            if (!(e0.inside(w0) && e1.inside(w1) && e2.inside(w2)))
            {
                continue;
            }
            const double u = w1 / area;
            const double v = w2 / area;
            const auto z = static_cast<float>((1.0 - u - v) * z0 + u * z1 + v * z2);
            const std::size_t k = out.index(x, y);
            if (z > out.depth[k])
            {
                out.depth[k] = z;
                out.primitive[k] = f;
                out.u[k] = static_cast<float>(u);
                out.v[k] = static_cast<float>(v);
            }
        }
    }
}

void draw_point(const Positions& s, std::int32_t p, double radius, int row_lo, int row_hi,
                VisibilityBuffer& out)
{
    const double cx = s(p, 0);
    const double cy = s(p, 1);
    const auto z = static_cast<float>(s(p, 2));
    const int own_x = static_cast<int>(std::floor(cx));
    const int own_y = static_cast<int>(std::floor(cy));
    int y_first = 0;
    int y_last = -1;
    centre_rows(cy - radius, cy + radius, y_first, y_last);
    y_first = std::max(std::min(y_first, own_y), row_lo);
    y_last = std::min(std::max(y_last, own_y), row_hi);
    int x_first = 0;
    int x_last = -1;
    centre_rows(cx - radius, cx + radius, x_first, x_last);
    x_first = std::max(std::min(x_first, own_x), 0);
    x_last = std::min(std::max(x_last, own_x), out.width - 1);
    for (int y = y_first; y <= y_last; ++y)
    {
        const double dy = y + 0.5 - cy;
        for (int x = x_first; x <= x_last; ++x)
        {
            const double dx = x + 0.5 - cx;
            if (dx * dx + dy * dy > radius * radius && !(x == own_x && y == own_y))
            {
                continue;
            }
            const std::size_t k = out.index(x, y);
            if (z > out.depth[k])
            {
                out.depth[k] = z;
                out.primitive[k] = p;
                out.u[k] = static_cast<float>(std::clamp(dx / radius, -1.0, 1.0));
                out.v[k] = static_cast<float>(std::clamp(dy / radius, -1.0, 1.0));
            }
        }
    }
}

/// Draws every band's primitives, bands in parallel.
template <class Draw>
void draw_bands(const Bins& bins, int height, int threads, Draw draw)
{
    const int bands = static_cast<int>(bins.start.size()) - 1;
#pragma omp parallel for schedule(dynamic, 1) num_threads(resolve_threads(threads))
    for (int b = 0; b < bands; ++b)
    {
        const int row_lo = b * kBandRows;
        const int row_hi = std::min(row_lo + kBandRows, height) - 1;
        for (std::size_t k = bins.start[static_cast<std::size_t>(b)];
             k < bins.start[static_cast<std::size_t>(b) + 1]; ++k)
        {
            draw(bins.items[k], row_lo, row_hi);
        }
    }
}

}  // namespace

VisibilityBuffer::VisibilityBuffer(int width_, int height_)
    : width(width_),
      height(height_),
      depth(static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_),
            -std::numeric_limits<float>::infinity()),
      primitive(depth.size(), -1),
      u(depth.size(), 0.0f),
      v(depth.size(), 0.0f)
{
}

VisibilityBuffer rasterize_triangles(const Positions& screen, const Faces& faces, int width,
                                     int height, int threads)
{
    VisibilityBuffer out(width, height);
    const Bins bins =
        bin_by_band(static_cast<std::size_t>(faces.rows()), height,
                    [&](std::size_t f, int& lo, int& hi)
                    {
                        const auto row = faces.row(static_cast<Eigen::Index>(f));
                        const double y0 = screen(row[0], 1);
                        const double y1 = screen(row[1], 1);
                        const double y2 = screen(row[2], 1);
                        centre_rows(std::min({y0, y1, y2}), std::max({y0, y1, y2}), lo, hi);
                    });
    draw_bands(bins, height, threads,
               [&](std::int32_t f, int row_lo, int row_hi)
               { draw_triangle(screen, faces, f, row_lo, row_hi, out); });
    return out;
}

VisibilityBuffer rasterize_points(const Positions& screen, const std::vector<std::int32_t>& points,
                                  double radius, int width, int height, int threads)
{
    VisibilityBuffer out(width, height);
    radius = std::isfinite(radius) ? std::max(radius, 0.0) : 0.0;
    const Bins bins =
        bin_by_band(points.size(), height,
                    [&](std::size_t i, int& lo, int& hi)
                    {
                        const double y = screen(points[i], 1);
                        centre_rows(y - radius, y + radius, lo, hi);
                        if (std::isfinite(y))
                        {
                            const int own = static_cast<int>(std::floor(std::clamp(y, -1e9, 1e9)));
                            lo = std::min(lo, own);
                            hi = std::max(hi, own);
                        }
                    });
    draw_bands(bins, height, threads,
               [&](std::int32_t i, int row_lo, int row_hi)
               {
                   draw_point(screen, points[static_cast<std::size_t>(i)], std::max(radius, 1e-9),
                              row_lo, row_hi, out);
               });
    return out;
}

}  // namespace meshmark

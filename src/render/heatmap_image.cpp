// SPDX-License-Identifier: MIT
// The distance picture: framing, rasterization, shading with supersampling, the colour bar.
#include "meshmark/render/heatmap_image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/metrics/heatmap.h"
#include "meshmark/render/rasterizer.h"
#include "render/detail/text.h"

namespace meshmark
{
namespace
{

constexpr Rgb8 kBackground{255, 255, 255};
constexpr Rgb8 kInk{40, 40, 40};
constexpr double kAmbient = 0.25;  // light that reaches a surface seen edge-on; chosen by hand
constexpr double kMargin = 0.05;   // of the model area, on each side; chosen by hand
constexpr int kTicks = 5;          // labels on the colour bar: 0, 1/4, ..., 1 of the maximum
// A point cloud's points are drawn as discs of this many median spacings in radius (0.7: the
// neighbours' discs overlap and close the surface), at least kMinSplatRadius pixels and at most
// kMaxSplatHeight of the image height. All three chosen by hand; no study on record.
constexpr double kSplatSpacings = 0.7;
constexpr double kMinSplatRadius = 0.75;
constexpr double kMaxSplatHeight = 0.05;

const char* const kTitle[] = {"distance", "% of bbox", "diagonal"};

std::string percent_label(double percent)
{
    char text[32];
    std::snprintf(text, sizeof text, "%.3g%%", percent);
    return text;
}

/// Median distance from a point to its nearest neighbour, over up to 1000 evenly spread points.
double median_spacing(const Positions& V, const std::vector<std::int32_t>& rows)
{
    if (rows.size() < 2)
    {
        return 0.0;
    }
    Positions points(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t i = 0; i < rows.size(); ++i)
    {
        points.row(static_cast<Eigen::Index>(i)) = V.row(rows[i]);
    }
    const PointKdTree tree(std::move(points));
    const std::size_t stride = std::max<std::size_t>(1, rows.size() / 1000);
    std::vector<double> spacing;
    for (std::size_t i = 0; i < rows.size(); i += stride)
    {
        std::uint32_t index[2];
        double squared[2];
        const Eigen::Vector3d q = tree.points().row(static_cast<Eigen::Index>(i)).transpose();
        if (tree.nearest(q, 2, index, squared) == 2)
        {
            spacing.push_back(std::sqrt(squared[1]));
        }
    }
    if (spacing.empty())
    {
        return 0.0;
    }
    std::nth_element(spacing.begin(),
                     spacing.begin() + static_cast<std::ptrdiff_t>(spacing.size() / 2),
                     spacing.end());
    return spacing[spacing.size() / 2];
}

/// Screen rows (x, y in supersampled pixels, depth) of every vertex, the model fitted into
/// the model area with a margin. Returns the scale (supersampled pixels per mesh unit).
double project(const TriangleMesh& mesh, const std::vector<std::int32_t>& rows,
               const ViewFrame& frame, int area_width, int area_height, Positions& screen)
{
    screen.resize(mesh.V.rows(), 3);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const Eigen::Vector3d p = mesh.V.row(i).transpose();
        screen.row(i) << p.dot(frame.right), -p.dot(frame.up), p.dot(frame.toward);
    }
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    for (const std::int32_t r : rows)
    {
        lo = lo.cwiseMin(screen.row(r).head<2>().transpose());
        hi = hi.cwiseMax(screen.row(r).head<2>().transpose());
    }
    const Eigen::Vector2d extent = hi - lo;
    const double usable = 1.0 - 2.0 * kMargin;
    double scale = std::min(extent.x() > 0.0 ? usable * area_width / extent.x() : HUGE_VAL,
                            extent.y() > 0.0 ? usable * area_height / extent.y() : HUGE_VAL);
    if (!std::isfinite(scale))
    {
        scale = 1.0;  // a single point (or all points on one spot)
    }
    const Eigen::Vector2d mid = 0.5 * (lo + hi);
    screen.col(0) = (screen.col(0).array() - mid.x()) * scale + 0.5 * area_width;
    screen.col(1) = (screen.col(1).array() - mid.y()) * scale + 0.5 * area_height;
    screen.col(2) *= scale;
    return scale;
}

/// Colour of one sample (linear 0..255 channels), or nothing when no primitive covers it.
struct Shader
{
    const TriangleMesh& mesh;
    const VisibilityBuffer& buffer;
    const Eigen::VectorXd& t;  // distance / max_distance per vertex
    const Positions& normals;  // empty for a point cloud
    Eigen::Vector3d toward;

    bool shade(std::size_t k, Eigen::Vector3d& rgb) const
    {
        const std::int32_t p = buffer.primitive[k];
        if (p < 0)
        {
            return false;
        }
        const double u = buffer.u[k];
        const double v = buffer.v[k];
        double value = 0.0;
        double light = 1.0;
        if (mesh.is_point_cloud())
        {
            // A disc shaded as the sphere it stands for.
            value = t[p];
            light = std::sqrt(std::max(0.0, 1.0 - u * u - v * v));
        }
        else
        {
            const auto f = mesh.F.row(p);
            const double w = 1.0 - u - v;
            value = w * t[f[0]] + u * t[f[1]] + v * t[f[2]];
            const Eigen::Vector3d n =
                w * normals.row(f[0]) + u * normals.row(f[1]) + v * normals.row(f[2]);
            const double length = n.norm();
            light = length > 0.0 ? std::abs(n.dot(toward)) / length : 1.0;
        }
        const Rgb8 c = heat_color(value);
        rgb = (kAmbient + (1.0 - kAmbient) * light) * Eigen::Vector3d(c[0], c[1], c[2]);
        return true;
    }
};

void draw_colour_bar(RgbImage& image, const HeatmapLayout& layout, double max_percent)
{
    const int s = layout.text_scale;
    const int h = layout.bar_y1 - layout.bar_y0;
    for (int y = layout.bar_y0; y < layout.bar_y1; ++y)
    {
        const double t = h > 1 ? static_cast<double>(layout.bar_y1 - 1 - y) / (h - 1) : 1.0;
        for (int x = layout.bar_x0; x < layout.bar_x1; ++x)
        {
            image.set(x, y, heat_color(t));
        }
    }
    // Outline, ticks and labels.
    image.fill_rect(layout.bar_x0 - s, layout.bar_y0 - s, layout.bar_x1 + s, layout.bar_y0, kInk);
    image.fill_rect(layout.bar_x0 - s, layout.bar_y1, layout.bar_x1 + s, layout.bar_y1 + s, kInk);
    image.fill_rect(layout.bar_x0 - s, layout.bar_y0, layout.bar_x0, layout.bar_y1, kInk);
    image.fill_rect(layout.bar_x1, layout.bar_y0, layout.bar_x1 + s, layout.bar_y1, kInk);
    const int label_x = layout.bar_x1 + 6 * s;
    for (int i = 0; i < kTicks; ++i)
    {
        const double fraction = static_cast<double>(i) / (kTicks - 1);
        const int y = layout.bar_y1 - static_cast<int>(std::lround(fraction * h));
        image.fill_rect(layout.bar_x1, y - s / 2, layout.bar_x1 + 3 * s, y - s / 2 + s, kInk);
        if (max_percent > 0.0 || i == 0)
        {
            detail::draw_text(image, label_x, y - 4 * s, percent_label(fraction * max_percent), s,
                              kInk);
        }
    }
    int y = layout.bar_y0 - s * (12 * 3 + 6);
    for (const char* line : kTitle)
    {
        detail::draw_text(image, layout.bar_x0 - s, y, line, s, kInk);
        y += 12 * s;
    }
}

}  // namespace

void HeatmapImageOptions::validate() const
{
    if (size.width < kMinImageSide || size.height < kMinImageSide || size.width > kMaxImageSide ||
        size.height > kMaxImageSide)
    {
        throw InvalidOption("heatmap image size " + std::to_string(size.width) + "x" +
                            std::to_string(size.height) + " is outside " +
                            std::to_string(kMinImageSide) + " to " + std::to_string(kMaxImageSide) +
                            " pixels per side.");
    }
    if (supersampling < 1 || supersampling > 4)
    {
        throw InvalidOption("heatmap supersampling must be 1 to 4, not " +
                            std::to_string(supersampling) + ".");
    }
    if (!(max_distance >= 0.0) || !std::isfinite(max_distance) || !(unit_length >= 0.0) ||
        !std::isfinite(unit_length))
    {
        throw InvalidOption(
            "heatmap max_distance and unit_length must be finite and not negative.");
    }
    if (threads < 0)
    {
        throw InvalidOption("heatmap threads must not be negative.");
    }
}

HeatmapLayout heatmap_layout(const ImageSize& size)
{
    HeatmapLayout layout;
    // One font pixel per image pixel up to ~480 rows, two from ~600 (800x600, 1024x768), ...
    layout.text_scale = static_cast<int>(
        std::max(1L, std::min(std::lround(size.height / 400.0), std::lround(size.width / 450.0))));
    const int s = layout.text_scale;
    int label_width = detail::text_width(percent_label(-1.23e-05), s);
    for (const char* line : kTitle)
    {
        label_width = std::max(label_width, detail::text_width(line, s) - 8 * s);
    }
    const int panel = 8 * s + 10 * s + 6 * s + label_width + 8 * s;
    layout.model_width = size.width - panel;
    layout.bar_x0 = layout.model_width + 8 * s;
    layout.bar_x1 = layout.bar_x0 + 10 * s;
    layout.bar_y0 = size.height / 8 + s * (12 * 3 + 6);
    layout.bar_y1 = size.height - size.height / 8;
    return layout;
}

HeatmapPicture render_heatmap(const TriangleMesh& mesh, const Eigen::VectorXd& distances,
                              const HeatmapImageOptions& options)
{
    options.validate();
    if (distances.size() != mesh.vertex_count())
    {
        throw InvalidOption("heatmap: " + std::to_string(distances.size()) + " distances for " +
                            std::to_string(mesh.vertex_count()) + " vertices.");
    }
    const std::vector<std::int32_t> rows = referenced_vertices(mesh);
    if (rows.empty())
    {
        throw InvalidMesh("the mesh has no vertex to draw.");
    }
    HeatmapPicture out;
    out.layout = heatmap_layout(options.size);
    out.max_distance = options.max_distance;
    if (out.max_distance == 0.0)
    {
        for (const std::int32_t r : rows)
        {
            out.max_distance = std::max(out.max_distance, distances[r]);
        }
    }
    out.unit_length =
        options.unit_length > 0.0 ? options.unit_length : bounding_box(mesh.V, rows).diagonal();
    const Eigen::VectorXd t = out.max_distance > 0.0 ? Eigen::VectorXd(distances / out.max_distance)
                                                     : Eigen::VectorXd::Zero(distances.size());

    // Rasterize at supersampled resolution.
    const int ss = options.supersampling;
    const int width = out.layout.model_width * ss;
    const int height = options.size.height * ss;
    const ViewFrame frame = view_frame(options.view, options.up);
    Positions screen;
    const double scale = project(mesh, rows, frame, width, height, screen);
    Positions normals;
    VisibilityBuffer buffer = [&]
    {
        if (mesh.is_point_cloud())
        {
            const double radius = std::clamp(kSplatSpacings * median_spacing(mesh.V, rows) * scale,
                                             kMinSplatRadius, kMaxSplatHeight * height);
            return rasterize_points(screen, rows, radius, width, height, options.threads);
        }
        normals = vertex_normals(mesh);
        return rasterize_triangles(screen, mesh.F, width, height, options.threads);
    }();

    // Shade each sample and average ss x ss samples per pixel.
    out.image = RgbImage(options.size.width, options.size.height, kBackground);
    const Shader shader{mesh, buffer, t, normals, frame.toward};
    const Eigen::Vector3d background(kBackground[0], kBackground[1], kBackground[2]);
#pragma omp parallel for schedule(static) num_threads(resolve_threads(options.threads))
    for (int y = 0; y < options.size.height; ++y)
    {
        for (int x = 0; x < out.layout.model_width; ++x)
        {
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            for (int sy = 0; sy < ss; ++sy)
            {
                for (int sx = 0; sx < ss; ++sx)
                {
                    Eigen::Vector3d rgb;
                    sum += shader.shade(buffer.index(x * ss + sx, y * ss + sy), rgb) ? rgb
                                                                                     : background;
                }
            }
            sum /= ss * ss;
            out.image.set(x, y,
                          {static_cast<std::uint8_t>(std::lround(sum[0])),
                           static_cast<std::uint8_t>(std::lround(sum[1])),
                           static_cast<std::uint8_t>(std::lround(sum[2]))});
        }
    }
    draw_colour_bar(out.image, out.layout,
                    out.unit_length > 0.0 ? 100.0 * out.max_distance / out.unit_length : 0.0);
    return out;
}

}  // namespace meshmark

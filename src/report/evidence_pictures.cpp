// SPDX-License-Identifier: MIT
// The report's two pictures: the suspect laid on the original (two panels drawn from the same
// visibility buffers as the heatmap), and its distance to the original's surface (render_heatmap).
#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <memory>
#include <vector>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/median.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/normals.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/registration/surface_matcher.h"
#include "meshmark/render/rasterizer.h"
#include "meshmark/report/evidence_report.h"

namespace meshmark
{
namespace
{

constexpr Rgb8 kBackground{255, 255, 255};
const Eigen::Vector3d kOriginalColor(200.0, 200.0, 200.0);  // light grey
const Eigen::Vector3d kSuspectColor(235.0, 120.0, 20.0);    // orange
constexpr double kAmbient = 0.3;  // light on a surface seen edge-on; chosen by hand
constexpr double kMargin = 0.05;  // of the picture, on each side; chosen by hand
/// How far (in diagonals of the original) the suspect may lie behind the original's surface and
/// still be drawn over it: a copy lies on the surface, and without the bias the two would fight
/// pixel by pixel.
constexpr double kSuspectDepthBias = 0.005;

/// The 4x4 "registration.transform" of a detect report.
Eigen::Matrix4d transform_of(const nlohmann::json& detect)
{
    const nlohmann::json* rows = nullptr;
    if (detect.contains("registration") && detect["registration"].contains("transform"))
    {
        rows = &detect["registration"]["transform"];
    }
    if (rows == nullptr || !rows->is_array() || rows->size() != 4)
    {
        throw InvalidOption(
            "evidence report: the detect report has no registration.transform (4 rows of 4).");
    }
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r)
    {
        for (int c = 0; c < 4; ++c)
        {
            m(r, c) =
                (*rows)[static_cast<std::size_t>(r)].at(static_cast<std::size_t>(c)).get<double>();
        }
    }
    return m;
}

TriangleMesh transformed(const TriangleMesh& mesh, const Eigen::Matrix4d& m)
{
    TriangleMesh out = mesh;
    const Eigen::Matrix3d a = m.topLeftCorner<3, 3>();
    const Eigen::RowVector3d t = m.topRightCorner<3, 1>().transpose();
    out.V = (mesh.V * a.transpose()).rowwise() + t;
    return out;
}

/// One mesh drawn in a panel: its screen rows, normals and visibility buffer.
struct Layer
{
    const TriangleMesh* mesh = nullptr;
    Eigen::Vector3d color;
    double depth_bias = 0.0;  // added to its depth when layers are compared
    Positions screen;
    Positions normals;
    VisibilityBuffer buffer{0, 0};
};

/// The framing of a panel: the image-plane box of the framed vertices fitted into the area.
struct Framing
{
    ViewFrame frame;
    Eigen::Vector2d mid = Eigen::Vector2d::Zero();
    double scale = 1.0;  // supersampled pixels per mesh unit
    int width = 0;
    int height = 0;
};

Framing fit(const TriangleMesh& mesh, const ViewFrame& frame, int width, int height)
{
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    for (const std::int32_t r : referenced_vertices(mesh))
    {
        const Eigen::Vector3d p = mesh.V.row(r).transpose();
        const Eigen::Vector2d q(p.dot(frame.right), -p.dot(frame.up));
        lo = lo.cwiseMin(q);
        hi = hi.cwiseMax(q);
    }
    Framing out{frame, 0.5 * (lo + hi), 1.0, width, height};
    const Eigen::Vector2d extent = hi - lo;
    const double usable = 1.0 - 2.0 * kMargin;
    const double scale = std::min(extent.x() > 0.0 ? usable * width / extent.x() : HUGE_VAL,
                                  extent.y() > 0.0 ? usable * height / extent.y() : HUGE_VAL);
    out.scale = std::isfinite(scale) ? scale : 1.0;
    return out;
}

/// Median nearest-neighbour spacing of up to 1000 of a point cloud's points (its disc size).
double median_spacing(const Positions& V)
{
    if (V.rows() < 2)
    {
        return 0.0;
    }
    const PointKdTree tree{Positions(V)};
    const Eigen::Index stride = std::max<Eigen::Index>(1, V.rows() / 1000);
    std::vector<double> spacing;
    for (Eigen::Index i = 0; i < V.rows(); i += stride)
    {
        std::uint32_t index[2];
        double squared[2];
        if (tree.nearest(V.row(i).transpose(), 2, index, squared) == 2)
        {
            spacing.push_back(std::sqrt(squared[1]));
        }
    }
    if (spacing.empty())
    {
        return 0.0;
    }
    return median_in_place(spacing);
}

void rasterize(Layer& layer, const Framing& f, int threads)
{
    const TriangleMesh& mesh = *layer.mesh;
    layer.screen.resize(mesh.V.rows(), 3);
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        const Eigen::Vector3d p = mesh.V.row(i).transpose();
        layer.screen.row(i) << (p.dot(f.frame.right) - f.mid.x()) * f.scale + 0.5 * f.width,
            (-p.dot(f.frame.up) - f.mid.y()) * f.scale + 0.5 * f.height,
            p.dot(f.frame.toward) * f.scale;
    }
    if (mesh.is_point_cloud())
    {
        // Discs as the render module's heatmap draws them (heatmap_image.cpp, kSplatSpacings).
        const double radius =
            std::clamp(0.7 * median_spacing(mesh.V) * f.scale, 0.75, 0.05 * f.height);
        layer.buffer = rasterize_points(layer.screen, referenced_vertices(mesh), radius, f.width,
                                        f.height, threads);
    }
    else
    {
        if (layer.normals.rows() != mesh.V.rows())
        {
            layer.normals = vertex_normals(mesh);
        }
        layer.buffer = rasterize_triangles(layer.screen, mesh.F, f.width, f.height, threads);
    }
}

/// Headlight Lambert shading of sample \p k of \p layer (two-sided), linear 0..255 channels.
Eigen::Vector3d shade(const Layer& layer, std::size_t k, const Eigen::Vector3d& toward)
{
    const double u = layer.buffer.u[k];
    const double v = layer.buffer.v[k];
    double light = 1.0;
    if (layer.mesh->is_point_cloud())
    {
        light = std::sqrt(std::max(0.0, 1.0 - u * u - v * v));
    }
    else
    {
        const auto f = layer.mesh->F.row(layer.buffer.primitive[k]);
        const double w = 1.0 - u - v;
        const Eigen::Vector3d n =
            w * layer.normals.row(f[0]) + u * layer.normals.row(f[1]) + v * layer.normals.row(f[2]);
        const double length = n.norm();
        light = length > 0.0 ? std::abs(n.dot(toward)) / length : 1.0;
    }
    return (kAmbient + (1.0 - kAmbient) * light) * layer.color;
}

/// Draw \p layers (nearest wins, each with its depth bias) into columns [x0, x0 + width / ss)
/// of \p image, averaging ss x ss samples per pixel.
void compose(RgbImage& image, int x0, std::vector<Layer>& layers, const Framing& f, int ss,
             int threads)
{
    for (Layer& layer : layers)
    {
        rasterize(layer, f, threads);
    }
    const Eigen::Vector3d background(kBackground[0], kBackground[1], kBackground[2]);
    const int width = f.width / ss;
    const int height = f.height / ss;
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads))
    for (int y = 0; y < height; ++y)
    {
        for (int x = 0; x < width; ++x)
        {
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            for (int sy = 0; sy < ss; ++sy)
            {
                for (int sx = 0; sx < ss; ++sx)
                {
                    const std::size_t k = layers.front().buffer.index(x * ss + sx, y * ss + sy);
                    const Layer* nearest = nullptr;
                    double depth = -std::numeric_limits<double>::infinity();
                    for (const Layer& layer : layers)
                    {
                        if (layer.buffer.primitive[k] >= 0 &&
                            layer.buffer.depth[k] + layer.depth_bias > depth)
                        {
                            depth = layer.buffer.depth[k] + layer.depth_bias;
                            nearest = &layer;
                        }
                    }
                    sum += nearest != nullptr ? shade(*nearest, k, f.frame.toward) : background;
                }
            }
            sum /= ss * ss;
            image.set(x0 + x, y,
                      {static_cast<std::uint8_t>(std::lround(sum[0])),
                       static_cast<std::uint8_t>(std::lround(sum[1])),
                       static_cast<std::uint8_t>(std::lround(sum[2]))});
        }
    }
}

double percentile(std::vector<double> values, double q)
{
    if (values.empty())
    {
        return 0.0;
    }
    const auto k =
        static_cast<std::ptrdiff_t>(std::floor(q * static_cast<double>(values.size() - 1)));
    std::nth_element(values.begin(), values.begin() + k, values.end());
    return values[static_cast<std::size_t>(k)];
}

}  // namespace

EvidencePictures evidence_pictures(const TriangleMesh& suspect, const TriangleMesh& original,
                                   const nlohmann::json& detect,
                                   const EvidencePictureOptions& options)
{
    if (options.supersampling < 1 || options.supersampling > 4)
    {
        throw InvalidOption("evidence pictures: supersampling must be 1 to 4.");
    }
    const std::vector<std::int32_t> suspect_rows = referenced_vertices(suspect);
    if (suspect_rows.empty() || referenced_vertices(original).empty())
    {
        throw InvalidMesh("evidence report: a mesh has no vertex to draw.");
    }
    const Eigen::Matrix4d transform = transform_of(detect);
    const Eigen::Matrix3d aligned_linear = transform.topLeftCorner<3, 3>();
    const TriangleMesh aligned = transformed(suspect, transform);
    const double diagonal = bounding_box(original.V, referenced_vertices(original)).diagonal();
    const ViewFrame frame = view_frame(options.view, options.up);
    // Meshes with more triangles than the panel has pixels are drawn with one sample per pixel:
    // their triangles are smaller than a pixel already, and the work is the triangles'.
    const bool is_dense = suspect.F.rows() + original.F.rows() >
                          static_cast<Eigen::Index>(options.panel.width) * options.panel.height;
    const int ss = is_dense ? 1 : options.supersampling;
    EvidencePictures out;

    // The search structure over the original's surface is built on a thread of its own while
    // the alignment is drawn: its kd-tree is built serially.
    std::future<std::unique_ptr<SurfaceMatcher>> matcher = std::async(
        std::launch::async, [&original] { return std::make_unique<SurfaceMatcher>(original); });

    // The alignment: the suspect as received (left), then on the original (right).
    out.alignment = RgbImage(2 * options.panel.width, options.panel.height, kBackground);
    std::vector<Layer> received(1);
    received[0].mesh = &suspect;
    received[0].color = kSuspectColor;
    compose(out.alignment, 0, received,
            fit(suspect, frame, options.panel.width * ss, options.panel.height * ss), ss,
            options.threads);
    std::vector<Layer> laid(2);
    laid[0].mesh = &original;
    laid[0].color = kOriginalColor;
    laid[1].mesh = &aligned;
    laid[1].color = kSuspectColor;
    if (!suspect.is_point_cloud())
    {
        // The aligned suspect's normals are the received one's turned (shading uses directions
        // only).
        laid[1].normals = received[0].normals * aligned_linear.transpose();
    }
    received.clear();
    const Framing laid_framing =
        fit(original, frame, options.panel.width * ss, options.panel.height * ss);
    laid[1].depth_bias = kSuspectDepthBias * diagonal * laid_framing.scale;
    compose(out.alignment, options.panel.width, laid, laid_framing, ss, options.threads);
    laid.clear();
    // A thin rule between the panels.
    out.alignment.fill_rect(options.panel.width - 1, 0, options.panel.width + 1,
                            options.panel.height, Rgb8{190, 190, 190});

    // The difference: each aligned suspect vertex's distance to the original's surface.
    std::vector<SurfaceMatch> closest;
    matcher.get()->match_all(aligned.V, closest, options.threads);
    Eigen::VectorXd distances(aligned.V.rows());
    std::vector<double> referenced;
    referenced.reserve(suspect_rows.size());
    for (Eigen::Index i = 0; i < distances.size(); ++i)
    {
        distances[i] = closest[static_cast<std::size_t>(i)].distance;
    }
    for (const std::int32_t r : suspect_rows)
    {
        referenced.push_back(distances[r]);
    }
    // Red at the 99.5th percentile: a few stray vertices must not wash the picture out blue.
    const double red = percentile(referenced, 0.995);
    out.median_distance_rel = diagonal > 0.0 ? percentile(referenced, 0.5) / diagonal : 0.0;
    HeatmapImageOptions heatmap;
    heatmap.size = options.heatmap;
    heatmap.view = options.view;
    heatmap.up = options.up;
    heatmap.max_distance = red;
    heatmap.unit_length = diagonal;
    heatmap.supersampling = ss;
    heatmap.threads = options.threads;
    out.difference = render_heatmap(aligned, distances, heatmap);
    out.red_distance_rel = diagonal > 0.0 ? out.difference.max_distance / diagonal : 0.0;
    return out;
}

}  // namespace meshmark

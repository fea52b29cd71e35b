// SPDX-License-Identifier: MIT
#include "meshmark/metrics/distortion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Geometry>
#include <omp.h>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/rng.h"
#include "meshmark/core/threads.h"
#include "meshmark/metrics/surface_sampling.h"

namespace meshmark
{
namespace
{

/// Running statistics of sample distances. Combined strictly in sample order, so the sums (and
/// the first sample reaching the maximum) are the same for any thread count.
struct DistanceSums
{
    double max = -1.0;
    Eigen::Vector3d max_point = Eigen::Vector3d::Zero();
    double sum = 0.0;
    double sum_squares = 0.0;
    std::int64_t count = 0;

    void add(double distance, const Eigen::Vector3d& point)
    {
        if (distance > max)
        {
            max = distance;
            max_point = point;
        }
        sum += distance;
        sum_squares += distance * distance;
        ++count;
    }

    void add(const DistanceSums& other)
    {
        if (other.count > 0 && other.max > max)
        {
            max = other.max;
            max_point = other.max_point;
        }
        sum += other.sum;
        sum_squares += other.sum_squares;
        count += other.count;
    }
};

/// Distance of every vertex of \p mesh to the indexed surface.
Eigen::VectorXd all_vertex_distances(const TriangleMesh& mesh, const ClosestPointIndex& to,
                                     int threads)
{
    Eigen::VectorXd distances(mesh.V.rows());
#pragma omp parallel for schedule(dynamic, 1024) num_threads(resolve_threads(threads))
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    {
        distances[i] = to.closest(Eigen::Vector3d(mesh.V.row(i).transpose())).distance;
    }
    return distances;
}

/// Sums over the stratified area samples, block by block: samples are generated, measured and
/// reduced per block, so memory stays O(threads * block) however many samples are asked for.
DistanceSums area_sample_sums(const TriangleMesh& from, const Eigen::VectorXd& cumulative,
                              const ClosestPointIndex& to, std::int64_t count, std::uint64_t seed,
                              int threads)
{
    const std::int64_t blocks = (count + kSamplesPerBlock - 1) / kSamplesPerBlock;
    std::vector<DistanceSums> per_block(static_cast<std::size_t>(blocks));
#pragma omp parallel num_threads(resolve_threads(threads))
    {
        Positions samples;
#pragma omp for schedule(dynamic, 1)
        for (std::int64_t b = 0; b < blocks; ++b)
        {
            sample_surface_block(from, cumulative, count, seed, b, samples);
            DistanceSums& sums = per_block[static_cast<std::size_t>(b)];
            for (Eigen::Index i = 0; i < samples.rows(); ++i)
            {
                const Eigen::Vector3d p = samples.row(i).transpose();
                sums.add(to.closest(p).distance, p);
            }
        }
    }
    DistanceSums total;
    for (const auto& sums : per_block)
    {
        total.add(sums);
    }
    return total;
}

bool has_positive_area(const Eigen::VectorXd& cumulative_areas)
{
    return cumulative_areas.size() > 0 && cumulative_areas[cumulative_areas.size() - 1] > 0.0;
}

double seconds_since(std::chrono::steady_clock::time_point start)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void report_progress(const CompareOptions& options, std::string_view phase, double fraction)
{
    if (options.progress)
    {
        options.progress(phase, fraction);
    }
}

void require_vertices(const std::vector<std::int32_t>& rows, const char* name)
{
    if (rows.empty())
    {
        throw InvalidMesh(std::string("compare: mesh ") + name + " has no vertices to measure.");
    }
}

}  // namespace

void CompareOptions::validate() const
{
    if (samples < 0)
    {
        throw InvalidOption("compare: samples = " + std::to_string(samples) +
                            " must be >= 0 (0 = automatic).");
    }
    if (threads < 0)
    {
        throw InvalidOption("compare: threads = " + std::to_string(threads) +
                            " must be >= 0 (0 = all cores).");
    }
}

std::int64_t auto_sample_count(const TriangleMesh& mesh)
{
    if (mesh.is_point_cloud())
    {
        return 0;
    }
    return std::clamp(kAutoSamplesPerFace * static_cast<std::int64_t>(mesh.F.rows()),
                      kMinAutoSamples, kMaxAutoSamples);
}

OneSidedDistance one_sided_distance(const TriangleMesh& from, const ClosestPointIndex& to,
                                    std::int64_t area_samples, std::uint64_t seed, int threads,
                                    Eigen::VectorXd* vertex_distances)
{
    if (area_samples < 0)
    {
        throw InvalidOption("one_sided_distance: area_samples = " + std::to_string(area_samples) +
                            " must be >= 0.");
    }
    // Vertex samples: every referenced vertex, so the one-sided Hausdorff distance sees each one.
    const Eigen::VectorXd distances = all_vertex_distances(from, to, threads);
    DistanceSums vertex_sums;
    for (const std::int32_t v : referenced_vertices(from))
    {
        vertex_sums.add(distances[v], from.V.row(v).transpose());
    }
    // Area samples: stratified, so their plain mean is an area-weighted mean. A point cloud, or a
    // surface of zero area, has none; its vertices then carry the averages.
    const Eigen::VectorXd cumulative = cumulative_face_areas(from);
    const std::int64_t count = has_positive_area(cumulative) ? area_samples : 0;
    const DistanceSums area_sums =
        count > 0 ? area_sample_sums(from, cumulative, to, count, seed, threads) : DistanceSums{};
    const DistanceSums& averaged = area_sums.count > 0 ? area_sums : vertex_sums;

    OneSidedDistance result;
    DistanceSums all = vertex_sums;
    all.add(area_sums);
    result.max = std::max(all.max, 0.0);
    result.max_point = all.max_point;
    if (averaged.count > 0)
    {
        const auto n = static_cast<double>(averaged.count);
        result.mean = averaged.sum / n;
        result.rms = std::sqrt(averaged.sum_squares / n);
    }
    result.vertex_samples = vertex_sums.count;
    result.area_samples = area_sums.count;
    if (vertex_distances != nullptr)
    {
        *vertex_distances = distances;
    }
    return result;
}

bool has_same_connectivity(const TriangleMesh& a, const TriangleMesh& b)
{
    return a.V.rows() == b.V.rows() && a.F.rows() == b.F.rows() && a.F == b.F;
}

Displacement vertex_displacement(const TriangleMesh& a, const TriangleMesh& b)
{
    if (!has_same_connectivity(a, b))
    {
        throw InvalidMesh("vertex_displacement: the meshes do not share connectivity (" +
                          std::to_string(a.V.rows()) + " vs " + std::to_string(b.V.rows()) +
                          " vertices, " + std::to_string(a.F.rows()) + " vs " +
                          std::to_string(b.F.rows()) + " faces, or different face rows).");
    }
    Displacement result;
    double sum_squares = 0.0;
    const std::vector<std::int32_t> rows = referenced_vertices(a);
    for (const std::int32_t v : rows)
    {
        const double d = (b.V.row(v) - a.V.row(v)).norm();
        if (d > result.max || result.max_vertex < 0)
        {
            result.max = d;
            result.max_vertex = v;
        }
        sum_squares += d * d;
    }
    if (!rows.empty())
    {
        result.rms = std::sqrt(sum_squares / static_cast<double>(rows.size()));
    }
    return result;
}

namespace
{

// Mean over a triangle of the product of two linear functions with corner values a and b.
double mean_product(const double* a, const double* b)
{
    return (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] +
            0.5 * (a[0] * b[1] + a[1] * b[0] + a[1] * b[2] + a[2] * b[1] + a[2] * b[0] +
                   a[0] * b[2])) /
           6.0;
}

void check_field(const TriangleMesh& mesh, const Positions& field)
{
    if (field.rows() != mesh.V.rows())
    {
        throw InvalidMesh("surface_rms_displacement: the field has " +
                          std::to_string(field.rows()) + " rows for " +
                          std::to_string(mesh.V.rows()) + " vertices.");
    }
}

}  // namespace

double surface_rms_displacement(const TriangleMesh& mesh, const Positions& field, int threads)
{
    check_field(mesh, field);
    if (mesh.is_point_cloud())
    {
        return mesh.V.rows() > 0
                   ? std::sqrt(field.squaredNorm() / (3.0 * static_cast<double>(mesh.V.rows())))
                   : 0.0;
    }
    // Fixed blocks of faces, each summed in face order, the blocks then added in order: the
    // same bits for any thread count (65536 faces: chosen by hand; no study on record).
    constexpr Eigen::Index kBlock = 1 << 16;
    const Eigen::Index faces = mesh.F.rows();
    const Eigen::Index blocks = (faces + kBlock - 1) / kBlock;
    std::vector<std::pair<double, double>> sums(
        static_cast<std::size_t>(blocks));  // weighted, area
#pragma omp parallel for schedule(dynamic, 1) num_threads(resolve_threads(threads))
    for (Eigen::Index b = 0; b < blocks; ++b)
    {
        double weighted = 0.0;
        double area = 0.0;
        for (Eigen::Index f = b * kBlock; f < std::min(faces, (b + 1) * kBlock); ++f)
        {
            const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)).transpose();
            const Eigen::Vector3d e1 = mesh.V.row(mesh.F(f, 1)).transpose() - p0;
            const Eigen::Vector3d e2 = mesh.V.row(mesh.F(f, 2)).transpose() - p0;
            const Eigen::Vector3d cross = e1.cross(e2);
            const double twice_area = cross.norm();
            if (!(twice_area > 0.0))
            {
                continue;
            }
            const Eigen::Vector3d n = cross / twice_area;
            double a[3];
            for (int c = 0; c < 3; ++c)
            {
                a[c] = n.dot(field.row(mesh.F(f, c)).transpose());
            }
            weighted += twice_area * mean_product(a, a);
            area += twice_area;
        }
        sums[static_cast<std::size_t>(b)] = {weighted, area};
    }
    double weighted = 0.0;
    double area = 0.0;
    for (const auto& [w, a] : sums)
    {
        weighted += w;
        area += a;
    }
    return area > 0.0 ? std::sqrt(weighted / area) : 0.0;
}

SurfaceRmsOfSums::SurfaceRmsOfSums(const TriangleMesh& mesh, const Positions& base) : mesh_(&mesh)
{
    check_field(mesh, base);
    if (mesh.is_point_cloud())
    {
        bb_ = mesh.V.rows() > 0 ? base.squaredNorm() / (3.0 * static_cast<double>(mesh.V.rows()))
                                : 0.0;
        base_part_ = base;
        return;
    }
    const Eigen::Index faces = mesh.F.rows();
    normal_.setZero(faces, 3);
    weight_.setZero(faces);
    base_part_.resize(faces, 3);
    double area = 0.0;
    for (Eigen::Index f = 0; f < faces; ++f)
    {
        const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)).transpose();
        const Eigen::Vector3d e1 = mesh.V.row(mesh.F(f, 1)).transpose() - p0;
        const Eigen::Vector3d e2 = mesh.V.row(mesh.F(f, 2)).transpose() - p0;
        const Eigen::Vector3d cross = e1.cross(e2);
        const double twice_area = cross.norm();
        if (twice_area > 0.0)
        {
            normal_.row(f) = (cross / twice_area).transpose();
            weight_[f] = twice_area;
            area += twice_area;
        }
    }
    if (area > 0.0)
    {
        weight_ /= area;
    }
    for (Eigen::Index f = 0; f < faces; ++f)
    {
        double a[3];
        for (int c = 0; c < 3; ++c)
        {
            a[c] = base_part_(f, c) = normal_.row(f).dot(base.row(mesh.F(f, c)));
        }
        bb_ += weight_[f] * mean_product(a, a);
    }
}

SurfaceRmsOfSums::Terms SurfaceRmsOfSums::terms(const Positions& field) const
{
    check_field(*mesh_, field);
    Terms t;
    t.bb = bb_;
    if (mesh_->is_point_cloud())
    {
        const double n = 3.0 * static_cast<double>(std::max<Eigen::Index>(1, mesh_->V.rows()));
        t.bf = base_part_.cwiseProduct(field).sum() / n;
        t.ff = field.squaredNorm() / n;
        return t;
    }
    for (Eigen::Index f = 0; f < mesh_->F.rows(); ++f)
    {
        double a[3];
        double b[3];
        for (int c = 0; c < 3; ++c)
        {
            a[c] = base_part_(f, c);
            b[c] = normal_.row(f).dot(field.row(mesh_->F(f, c)));
        }
        t.bf += weight_[f] * mean_product(a, b);
        t.ff += weight_[f] * mean_product(b, b);
    }
    return t;
}

double SurfaceRmsOfSums::Terms::rms(double c) const noexcept
{
    return std::sqrt(std::max(0.0, bb + 2.0 * c * bf + c * c * ff));
}

double SurfaceRmsOfSums::Terms::scale_to(double target) const noexcept
{
    // bb + 2 c bf + c^2 ff = target^2: the larger root.
    const double rest = target * target - bb;
    if (!(ff > 0.0) || !(rest > 0.0))
    {
        return 1.0;
    }
    const double c = (-bf + std::sqrt(bf * bf + ff * rest)) / ff;
    return c > 0.0 ? c : 1.0;
}

DistortionReport compare_meshes(const TriangleMesh& a, const TriangleMesh& b,
                                const CompareOptions& options)
{
    options.validate();
    const auto start = std::chrono::steady_clock::now();
    DistortionReport report;

    // Unit: the bounding-box diagonal of A's measured vertices.
    const std::vector<std::int32_t> rows_a = referenced_vertices(a);
    require_vertices(rows_a, "A");
    require_vertices(referenced_vertices(b), "B");
    report.diagonal = bounding_box(a.V, rows_a).diagonal();
    if (!(report.diagonal > 0.0) || !std::isfinite(report.diagonal))
    {
        throw InvalidMesh(
            "compare: mesh A has a zero or non-finite bounding-box diagonal, so relative "
            "distances are undefined.");
    }

    // Indices: exact closest points on each surface (nearest points for a cloud).
    report_progress(options, "index", 0.0);
    auto phase = std::chrono::steady_clock::now();
    const ClosestPointIndex index_a(a);
    const ClosestPointIndex index_b(b);
    report.seconds.index = seconds_since(phase);
    report_progress(options, "index", 1.0);

    // A -> B, then B -> A, each with its own random stream.
    const std::int64_t samples_a = options.samples > 0 ? options.samples : auto_sample_count(a);
    const std::int64_t samples_b = options.samples > 0 ? options.samples : auto_sample_count(b);
    report_progress(options, "a_to_b", 0.0);
    phase = std::chrono::steady_clock::now();
    report.a_to_b = one_sided_distance(a, index_b, samples_a,
                                       derive_seed(options.seed, "compare:a"), options.threads);
    report.seconds.a_to_b = seconds_since(phase);
    report_progress(options, "a_to_b", 1.0);
    report_progress(options, "b_to_a", 0.0);
    phase = std::chrono::steady_clock::now();
    report.b_to_a = one_sided_distance(
        b, index_a, samples_b, derive_seed(options.seed, "compare:b"), options.threads,
        options.keep_vertex_distances ? &report.vertex_distances_ba : nullptr);
    report.seconds.b_to_a = seconds_since(phase);
    report_progress(options, "b_to_a", 1.0);

    // Relative figures, and the vertex displacement when the connectivity is shared.
    const double d = report.diagonal;
    report.hausdorff_ab_rel = report.a_to_b.max / d;
    report.hausdorff_ba_rel = report.b_to_a.max / d;
    report.hausdorff_rel = std::max(report.hausdorff_ab_rel, report.hausdorff_ba_rel);
    report.rms_ab_rel = report.a_to_b.rms / d;
    report.rms_ba_rel = report.b_to_a.rms / d;
    report.mrms_rel = std::max(report.rms_ab_rel, report.rms_ba_rel);
    if (has_same_connectivity(a, b))
    {
        report.displacement = vertex_displacement(a, b);
        report.max_displacement_rel = report.displacement->max / d;
        report.rms_displacement_rel = report.displacement->rms / d;
    }
    report.seconds.total = seconds_since(start);
    return report;
}

}  // namespace meshmark

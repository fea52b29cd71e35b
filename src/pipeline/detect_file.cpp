// SPDX-License-Identifier: MIT
#include "meshmark/pipeline/detect_file.h"

#include <algorithm>

#include <array>
#include <cmath>
#include <exception>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <optional>
#include <span>
#include <thread>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <string>

#include "meshmark/core/bounding_box.h"
#include "meshmark/core/error.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/adjacency.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/io/mesh_io.h"
#include "meshmark/meshmark.h"
#include "meshmark/pipeline/embed_file.h"
#include "meshmark/registration/point_to_plane.h"
#include "meshmark/registration/registration.h"
#include "meshmark/registration/resampling.h"
#include "meshmark/watermark/detector.h"
#include "timer.h"

namespace meshmark {
namespace {

// A same-count suspect whose vertices, after the best similarity, lie within this fraction of
// the diagonal of the original (RMS) is taken vertex for vertex. Attacks that keep the
// order stay far below (1% noise: ~0.6%); a reordered copy is far above (~30%).
constexpr double kCorrespondenceTolerance = 0.02;

void check_original(const TriangleMesh& original, const Key& key, const std::filesystem::path& path)
{
    const MeshFingerprint found = fingerprint(original);
    if (found.vertex_count != key.original.vertex_count || found.face_count != key.original.face_count)
    {
        throw IoError(path.string() + ": this is not the original the key was made for (it has " +
                      std::to_string(found.vertex_count) + " vertices and " +
                      std::to_string(found.face_count) + " faces, the key's original " +
                      std::to_string(key.original.vertex_count) + " and " +
                      std::to_string(key.original.face_count) + ").");
    }
    if (found.position_hash != key.original.position_hash)
    {
        throw IoError(path.string() + ": this is not the original the key was made for (same counts, "
                      "but its vertex positions differ from the fingerprint in the key).");
    }
}

// Next to a cut, the original's vertices that are just beyond the crop threshold get the closest
// point on the cut's border instead of their own: they carry no watermark, only a bias. Growing
// the cropped region by this many rings of neighbours drops that band (measured on half crops
// of rocker-arm.obj: R 0.29 with no growth, 0.71 with 2 rings, 0.79 with 4; see
// docs/robustness.md).
constexpr int kCropDilationRings = 4;

std::vector<std::uint8_t> kept_after_crop(const TriangleMesh& original, const std::vector<std::uint8_t>& is_cropped)
{
    std::vector<std::uint8_t> cropped = is_cropped;
    if (!original.is_point_cloud())
    {
        const VertexAdjacency adjacency = vertex_adjacency(original);
        for (int ring = 0; ring < kCropDilationRings; ++ring)
        {
            std::vector<std::uint8_t> grown = cropped;
            for (std::size_t v = 0; v < cropped.size(); ++v)
            {
                if (cropped[v] != 0)
                {
                    for (const auto u : adjacency.of(v))
                    {
                        grown[static_cast<std::size_t>(u)] = 1;
                    }
                }
            }
            cropped = std::move(grown);
        }
    }
    std::vector<std::uint8_t> kept(cropped.size());
    for (std::size_t i = 0; i < kept.size(); ++i)
    {
        kept[i] = cropped[i] == 0 ? 1 : 0;
    }
    return kept;
}

// Rows of the original whose resampled point is farther than this many times the median
// distance from it, and farther than kOutlierFloor times the mark's strength, are left out of
// the reading (no dilation, and they do not make the suspect "cropped"). A coarse resampling of
// the surface (a 25% remesh, a voxel remesh that merges thin walls, the band along a cut that
// the crop threshold misses) leaves some rows several mark amplitudes away from any surface
// that carries the mark: they measure the attack's error, not the mark, and in a least-squares
// reading they swamp it. The rule looks only at distances to the ORIGINAL, never at the key's
// signs, so the false-positive bound holds as for crops (docs/statistics.md). Measured on the
// robustness grid (docs/robustness.md, "Rows far from the suspect's surface").
constexpr double kOutlierMedianFactor = 3.0;
// In units of the mark's amplitude (mark_amplitude): 10 x 0.059% = 0.59% of the diagonal at
// the defaults. A copy that only carries the mark (distances of the order of the strength)
// loses no row.
constexpr double kOutlierFloor = 10.0;
// The amplitude of keys whose strength is not a distance (the paper's rule), as a fraction of
// the diagonal: the default mark's.
constexpr double kPaperRuleAmplitude = 0.00059;

/// The upper median of \p values (reordered in place; nearest rank, so the same on every run).
/// \pre \p values is not empty.
template <typename T>
T median_in_place(std::vector<T>& values)
{
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
}

/// The rows to read: \p kept_by_crop (null: all) minus the outliers above; \p outliers gets
/// their number. Serial nearest-rank median, so the result is the same on every run.
std::vector<std::uint8_t> kept_without_outliers(const Eigen::VectorXd& distance,
                                                const std::vector<std::uint8_t>* kept_by_crop, double floor,
                                                std::size_t& outliers)
{
    const auto n = static_cast<std::size_t>(distance.size());
    std::vector<double> sorted(distance.data(), distance.data() + n);
    const double threshold = std::max(kOutlierMedianFactor * median_in_place(sorted), floor);
    std::vector<std::uint8_t> kept = kept_by_crop != nullptr ? *kept_by_crop : std::vector<std::uint8_t>(n, 1);
    outliers = 0;
    for (std::size_t i = 0; i < n; ++i)
    {
        if (kept[i] != 0 && distance(static_cast<Eigen::Index>(i)) > threshold)
        {
            kept[i] = 0;
            ++outliers;
        }
    }
    return kept;
}

// The rows that are kept are weighted by how close the suspect's surface came to them
// (Detector::extract_resampled: w = 1 / (1 + (d / s)^2) for a row at distance d), with s this
// many times the mark's amplitude (0.18% of the diagonal at the defaults). The far-rows rule
// above is all or nothing at a large distance; an attack that refits the surface (remeshing,
// voxel remeshing, a cut) also leaves rows at a few mark amplitudes, and their error, not the
// mark, dominates their reading. A copy that only carries the mark loses almost nothing (w >=
// 0.9 at one amplitude). Like the far-rows rule the weights come from distances to the
// original only. Measured on the robustness grid (docs/robustness.md, "Rows weighted by their
// distance"): 3 gains the most claims after remeshing and loses none; 2 starts to lose
// simplified copies, 5 and 10 gain less.
constexpr double kWeightScale = 3.0;

// Rounds of the far-rows rule and the similarity refitted without them, for a suspect read
// vertex for vertex, until the rows left out stay the same.
constexpr int kMaxOutlierRefits = 10;

// The first reading of a resampled suspect ends the detection when its score alone would claim
// at the price of this many statistics, more than the 7 the two readings' verdict pays (the
// damped readings of each, 2 + 2, and the three joined, add_further_reading): a copy
// the first reading claims only narrowly is read again, so its reported score and R are the
// better reading's (ogre's 5% remesh: 5.38 and R 0.71 from the first reading, 9.51 and R 1.0
// from the second). 10 is the level of the early stop before the verdict scored the damped
// readings alone, so clear copies stop where they did.
constexpr int kEarlyStopStatistics = 10;

// A registered suspect is read vertex for vertex (match_vertices) when at least 10% of the
// original's vertices find a suspect vertex standing for them (the others are left out as
// cropped), and only on a mesh whose mean edge is at least kMatchSpacing mark amplitudes.
// Until the sixth session of 2026-11-26 this was 99%, and a crop stayed with the resampling,
// which keeps only each row's normal component: a copy cut or bisected by deleting faces, or
// a faceted asset decimated by Blender (which deletes its lone triangles and moves no vertex),
// keeps the original's vertices where they were, and read vertex for vertex it reads the whole
// change (the suite's half crops of fandisk 7.99 -> 10.22 mean z, Blender's 20% of a faceted
// creature 5.69 -> 10.82: docs/robustness.md, "Two more game-like assets"). The spacing and
// ambiguity rules below still send simplified and remeshed copies to the resampling.
constexpr double kMaxUnmatched = 0.9;
// Up to this share unmatched the copy is taken as the original's vertices as it stands (a
// writer's seams, a weld, a midpoint subdivision); beyond it, only when at least
// kMinOriginalTriangles of its triangles between matched vertices are the original's.
constexpr double kMaxNearlyAll = 0.01;
constexpr double kMinOriginalTriangles = 0.9;
constexpr double kMatchSpacing = 10.0;
// ... and when its vertices stand for the original's unambiguously: the median, over the
// matched vertices, of the distance to the matched suspect vertex over the distance to the
// next suspect position is at most this. A copy of the original's vertices puts one suspect
// vertex where each original vertex was and the next one an edge or half an edge away (median
// 0.08-0.16 for reorders, seam splits and midpoint subdivisions of fandisk and a game-like
// asset); a surface sampled afresh (a voxel remesh) has its vertices where the grid put them,
// the nearest and the next at similar distances (0.63-0.67 at 1/150 and 1/300 of the
// diagonal), and read vertex for vertex it would take their offsets along the surface for a
// change (fandisk at 1/300: z 7.54 against 9.37 resampled).
constexpr double kMaxMatchAmbiguity = 0.4;
// Neighbours looked at for the next suspect position (a writer's duplicates at one position
// come first).
constexpr std::size_t kMatchNeighbours = 8;

/// The mark's RMS displacement in reference units: the additive rule's strength (a fraction
/// of the diagonal) or, for the paper's rule, the default mark's.
double mark_amplitude(const EmbedOptions& options, double diagonal)
{
    return (options.rule == EmbeddingRule::Additive ? options.resolved_strength() : kPaperRuleAmplitude) * diagonal;
}

// The similarity taking a suspect with the original's vertex order onto the original, over
// the rows \p kept (null: all) [Umeyama 1991]. Fitted from the original onto the suspect and
// inverted: noise in the suspect then averages out, whereas a fit from the noisy suspect
// shrinks its scale (errors in the fitted-from variable; measured on rocker-arm.obj with 1%
// noise: low-mode errors of 20-30 modulation steps that way).
Eigen::Matrix4d similarity_onto_original(const Positions& original, const Positions& suspect,
                                         const std::vector<std::uint8_t>* kept)
{
    if (kept == nullptr)
    {
        return Eigen::umeyama(original.transpose(), suspect.transpose(), true).inverse();
    }
    const auto count = static_cast<Eigen::Index>(std::count_if(kept->begin(), kept->end(), [](std::uint8_t k) { return k != 0; }));
    Eigen::Matrix3Xd from(3, count);
    Eigen::Matrix3Xd to(3, count);
    for (Eigen::Index i = 0, k = 0; i < original.rows(); ++i)
    {
        if ((*kept)[static_cast<std::size_t>(i)] != 0)
        {
            from.col(k) = original.row(i).transpose();
            to.col(k) = suspect.row(i).transpose();
            ++k;
        }
    }
    return Eigen::umeyama(from, to, true).inverse();
}

// A suspect whose vertices are the original's again, in another order, split where a writer
// duplicates them (UV seams, hard edges: Blender's PLY and OBJ writers), welded where a tool
// joins the original's duplicates, or with vertices added between them (midpoint
// subdivision), is read vertex for vertex rather than through its surface: each original
// vertex takes the suspect vertex nearest to it after registration, when that one lies within
// \p tolerance and the original vertex nearest to it is at the same position (mutual nearest
// neighbours; original vertices at one position count as one). Mutual pairs can still be
// wrong where the mark moves a vertex nearer a neighbour's place than its own: the caller
// tries this only on meshes whose spacing is large against the mark (kMatchSpacing). \p match
// gets, per original vertex, the suspect vertex or -1; \p ambiguity the median over the
// matched vertices of the distance to their suspect vertex over the distance to the next
// suspect position (kMaxMatchAmbiguity; 1 when none matched). Distances to the original only,
// never the key: the bound holds as for any correspondence. Returns the number matched.
std::size_t match_vertices(const Positions& original, const Positions& registered, double tolerance,
                           std::vector<std::int32_t>& match, double& ambiguity, int threads)
{
    const Eigen::Index n = original.rows();
    match.assign(static_cast<std::size_t>(n), -1);
    ambiguity = 1.0;
    if (registered.rows() == 0 || n == 0)
    {
        return 0;
    }
    const PointKdTree suspect_tree(registered);
    const PointKdTree original_tree(original);
    const double squared_tolerance = tolerance * tolerance;
    // Positions closer than this to the matched one are its duplicates, not the next position.
    const double squared_same = 1e-12 * squared_tolerance;
    std::vector<float> ratio(static_cast<std::size_t>(n), -1.0F);
    std::size_t matched = 0;
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads)) reduction(+ : matched)
    for (Eigen::Index i = 0; i < n; ++i)
    {
        std::array<std::uint32_t, kMatchNeighbours> index{};
        std::array<double, kMatchNeighbours> squared{};
        const std::size_t found =
            suspect_tree.nearest(original.row(i).transpose(), kMatchNeighbours, index.data(), squared.data());
        const std::uint32_t j = index[0];
        if (squared[0] > squared_tolerance)
        {
            continue;
        }
        double back_squared = 0.0;
        const std::uint32_t back = original_tree.nearest(registered.row(j).transpose(), back_squared);
        if (original.row(back) != original.row(i))
        {
            continue;
        }
        match[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(j);
        ++matched;
        double next = 0.0;  // 0: no other position among the neighbours (ratio 0, unambiguous)
        for (std::size_t t = 1; t < found; ++t)
        {
            if ((registered.row(index[t]) - registered.row(j)).squaredNorm() > squared_same)
            {
                next = squared[t];
                break;
            }
        }
        ratio[static_cast<std::size_t>(i)] = next > 0.0 ? static_cast<float>(std::sqrt(squared[0] / next)) : 0.0F;
    }
    ratio.erase(std::remove(ratio.begin(), ratio.end(), -1.0F), ratio.end());
    if (!ratio.empty())
    {
        ambiguity = median_in_place(ratio);
    }
    return matched;
}

// Of the suspect's triangles whose three corners stand for original vertices (\p match, from
// match_vertices), the share that are triangles of the original (corners compared by
// position, so that a writer's duplicates count as one vertex); -1 when they are fewer than
// half of the suspect's triangles. A copy that deletes faces and moves no vertex (a crop, a
// bisection, Blender's decimation of a faceted asset) keeps the original's triangles; a
// simplification builds new ones between the vertices it keeps and moves, and read vertex for
// vertex its moved vertices would be taken for the change (a 50% simplification of a 10K
// ellipsoid: claimed resampled, lost so).
double original_triangle_share(const TriangleMesh& original, const TriangleMesh& suspect, const Positions& registered,
                               const std::vector<std::int32_t>& match)
{
    using Key = std::array<std::int32_t, 3>;
    // One id per original position: the lowest index there.
    const auto n = static_cast<std::size_t>(original.V.rows());
    const std::vector<std::int32_t> id = position_ids(original.V);
    auto key = [](std::array<std::int32_t, 3> k) {
        std::sort(k.begin(), k.end());
        return k;
    };
    std::vector<Key> faces(static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        faces[static_cast<std::size_t>(f)] = key({id[static_cast<std::size_t>(original.F(f, 0))],
                                                  id[static_cast<std::size_t>(original.F(f, 1))],
                                                  id[static_cast<std::size_t>(original.F(f, 2))]});
    }
    std::sort(faces.begin(), faces.end());
    // Each suspect vertex at the position of a matched one stands for that original vertex.
    std::vector<std::pair<std::array<double, 3>, std::int32_t>> matched;
    for (std::size_t i = 0; i < n; ++i)
    {
        if (match[i] >= 0)
        {
            const auto j = static_cast<Eigen::Index>(match[i]);
            matched.push_back({{registered(j, 0), registered(j, 1), registered(j, 2)}, id[i]});
        }
    }
    std::sort(matched.begin(), matched.end());
    auto stands_for = [&](std::int32_t s) {
        const std::array<double, 3> p{registered(s, 0), registered(s, 1), registered(s, 2)};
        const auto it = std::lower_bound(matched.begin(), matched.end(), std::pair(p, std::int32_t{-1}));
        return it != matched.end() && it->first == p ? it->second : -1;
    };
    std::size_t whole = 0;
    std::size_t kept = 0;
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        Key k{};
        bool all = true;
        for (int c = 0; c < 3 && all; ++c)
        {
            k[static_cast<std::size_t>(c)] = stands_for(suspect.F(f, c));
            all = k[static_cast<std::size_t>(c)] >= 0;
        }
        if (!all)
        {
            continue;
        }
        ++whole;
        kept += std::binary_search(faces.begin(), faces.end(), key(k)) ? 1U : 0U;
    }
    // Too few such triangles say nothing (a sqrt(3) subdivision keeps a few at a border).
    if (2 * whole < static_cast<std::size_t>(suspect.F.rows()) || whole == 0)
    {
        return -1.0;
    }
    return static_cast<double>(kept) / static_cast<double>(whole);
}

// A vertex starts the renumbering below when the suspect vertex nearest to it is at most this
// share of the distance to the next one, and it is as clearly the nearest back; a triangle's
// third corner is taken as clearly. Closer calls are left to the triangles.
constexpr double kMaxStartRatio = 0.5;

namespace renumbering {

// The original's triangles by edge: (edge key, third corner), sorted.
using EdgeThirds = std::vector<std::pair<std::uint64_t, std::int32_t>>;

std::uint64_t edge_key(std::int32_t a, std::int32_t b)
{
    return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(std::min(a, b))) << 32U) |
           static_cast<std::uint32_t>(std::max(a, b));
}

EdgeThirds edge_thirds(const TriangleMesh& original)
{
    EdgeThirds by_edge;
    by_edge.reserve(3 * static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            by_edge.emplace_back(edge_key(original.F(f, c), original.F(f, (c + 1) % 3)), original.F(f, (c + 2) % 3));
        }
    }
    std::sort(by_edge.begin(), by_edge.end());
    return by_edge;
}

// The vertices that stand for an original vertex beyond doubt: mutual nearest in place, within
// \p tolerance, the next vertex at least twice as far either way (kMaxStartRatio). Per suspect
// vertex: its original vertex or -1.
std::vector<std::int32_t> beyond_doubt(const TriangleMesh& original, const TriangleMesh& suspect,
                                       const PointKdTree& original_tree, double tolerance, int threads)
{
    const auto n = static_cast<std::size_t>(original.V.rows());
    const double squared_tolerance = tolerance * tolerance;
    const PointKdTree suspect_tree(suspect.V);
    std::vector<std::int32_t> start(n, -1);  // per original vertex: its suspect vertex, if beyond doubt
#pragma omp parallel for schedule(static) num_threads(resolve_threads(threads))
    for (Eigen::Index i = 0; i < original.V.rows(); ++i)
    {
        std::array<std::uint32_t, 2> index{};
        std::array<double, 2> squared{};
        if (suspect_tree.nearest(original.V.row(i).transpose(), 2, index.data(), squared.data()) < 2 ||
            squared[0] > squared_tolerance || squared[0] >= kMaxStartRatio * kMaxStartRatio * squared[1])
        {
            continue;
        }
        std::array<std::uint32_t, 2> back{};
        std::array<double, 2> back_squared{};
        if (original_tree.nearest(suspect.V.row(index[0]).transpose(), 2, back.data(), back_squared.data()) == 2 &&
            back[0] == static_cast<std::uint32_t>(i) &&
            back_squared[0] < kMaxStartRatio * kMaxStartRatio * back_squared[1])  // (two at one place: left)
        {
            start[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(index[0]);
        }
    }
    std::vector<std::int32_t> to_original(n, -1);
    for (std::size_t i = 0; i < n; ++i)
    {
        if (start[i] >= 0 && to_original[static_cast<std::size_t>(start[i])] < 0)
        {
            to_original[static_cast<std::size_t>(start[i])] = static_cast<std::int32_t>(i);
        }
    }
    return to_original;
}

// For each suspect vertex, its kCandidates nearest original vertices, nearest first, with their
// squared distances: the choices left_no_choice narrows, found once for every reach.
constexpr std::size_t kCandidates = 32;
struct NearestOriginals
{
    std::vector<std::uint32_t> index;  // kCandidates per suspect vertex
    std::vector<double> squared;
    std::vector<std::size_t> found;  // how many of them there are
};

NearestOriginals nearest_originals(const TriangleMesh& suspect, const PointKdTree& original_tree)
{
    const auto n = static_cast<std::size_t>(suspect.V.rows());
    NearestOriginals nearest{std::vector<std::uint32_t>(n * kCandidates), std::vector<double>(n * kCandidates),
                             std::vector<std::size_t>(n)};
    for (std::size_t j = 0; j < n; ++j)
    {
        nearest.found[j] = original_tree.nearest(suspect.V.row(static_cast<Eigen::Index>(j)).transpose(), kCandidates,
                                                 nearest.index.data() + j * kCandidates,
                                                 nearest.squared.data() + j * kCandidates);
    }
    return nearest;
}

// The vertices whose original vertex the triangles leave no choice for, when the positions
// alone do not tell (vertices nearer each other than the mark moves them, everywhere: a CAD
// plate whose vertices crowd on its outline's arcs). Each suspect vertex may stand for the
// original vertices within \p tolerance of it; a candidate goes when some neighbour of the
// vertex has no candidate it is a neighbour of in the original (arc consistency), until nothing
// changes; the kCandidates nearest within reach are a vertex's choices (one moved further than
// that many others only makes this fail). Per suspect vertex: its original vertex when one
// candidate is left, else -1; nullopt when a vertex has none left or two claim one original
// vertex (the copy is not the original renumbered, or not one this can follow).
std::optional<std::vector<std::int32_t>> left_no_choice(const NearestOriginals& nearest,
                                                        const VertexAdjacency& original_adjacency,
                                                        const VertexAdjacency& suspect_adjacency, double tolerance)
{
    const std::size_t n = nearest.found.size();
    const double squared_tolerance = tolerance * tolerance;
    std::vector<std::vector<std::int32_t>> candidates(n);
    for (std::size_t j = 0; j < n; ++j)
    {
        for (std::size_t t = 0; t < nearest.found[j] && nearest.squared[j * kCandidates + t] <= squared_tolerance; ++t)
        {
            candidates[j].push_back(static_cast<std::int32_t>(nearest.index[j * kCandidates + t]));
        }
        if (candidates[j].empty())
        {
            return std::nullopt;
        }
    }
    auto adjacent = [&](std::int32_t x, std::int32_t y) {
        const auto around = original_adjacency.of(static_cast<std::size_t>(x));
        return std::binary_search(around.begin(), around.end(), y);
    };
    std::vector<std::size_t> queue(n);
    std::iota(queue.begin(), queue.end(), std::size_t{0});
    std::vector<char> queued(n, 1);
    while (!queue.empty())
    {
        const std::size_t a = queue.back();
        queue.pop_back();
        queued[a] = 0;
        for (const auto neighbour : suspect_adjacency.of(a))
        {
            const auto b = static_cast<std::size_t>(neighbour);
            auto& of_b = candidates[b];
            const auto kept_end = std::remove_if(of_b.begin(), of_b.end(), [&](std::int32_t y) {
                return std::none_of(candidates[a].begin(), candidates[a].end(),
                                    [&](std::int32_t x) { return adjacent(x, y); });
            });
            if (kept_end == of_b.end())
            {
                continue;
            }
            of_b.erase(kept_end, of_b.end());
            if (of_b.empty())
            {
                return std::nullopt;
            }
            if (queued[b] == 0)
            {
                queued[b] = 1;
                queue.push_back(b);
            }
        }
    }
    std::vector<std::int32_t> to_original(n, -1);
    std::vector<char> taken(original_adjacency.vertex_count(), 0);
    for (std::size_t j = 0; j < n; ++j)
    {
        if (candidates[j].size() == 1)
        {
            const auto x = static_cast<std::size_t>(candidates[j].front());
            if (taken[x] != 0)
            {
                return std::nullopt;
            }
            taken[x] = 1;
            to_original[j] = candidates[j].front();
        }
    }
    return to_original;
}

// From the suspect vertices known in \p to_original, through the triangles to the others (a
// suspect triangle with two corners known is the original's triangle on their edge whose third
// corner is clearly the nearest untaken one); the suspect's positions in the original's order
// when every vertex is reached, each original vertex once, and every suspect triangle is a
// triangle of the original.
std::optional<Positions> propagated(const TriangleMesh& original, const TriangleMesh& suspect,
                                    const EdgeThirds& by_edge, const VertexFaces& faces_of,
                                    std::vector<std::int32_t> to_original, double tolerance)
{
    const auto n = static_cast<std::size_t>(original.V.rows());
    const double squared_tolerance = tolerance * tolerance;
    std::vector<char> taken(n, 0);  // per original vertex
    for (const auto x : to_original)
    {
        if (x >= 0)
        {
            taken[static_cast<std::size_t>(x)] = 1;
        }
    }
    // A triangle with two corners known is the original's triangle on their edge whose third
    // corner is the nearest untaken one, when the next is at least twice as far (else another
    // of its triangles decides later).
    std::vector<Eigen::Index> queue(static_cast<std::size_t>(suspect.F.rows()));
    std::iota(queue.begin(), queue.end(), Eigen::Index{0});
    while (!queue.empty())
    {
        const Eigen::Index f = queue.back();
        queue.pop_back();
        int unknown = -1;
        int known = 0;
        for (int c = 0; c < 3; ++c)
        {
            if (to_original[static_cast<std::size_t>(suspect.F(f, c))] >= 0)
            {
                ++known;
            }
            else
            {
                unknown = c;
            }
        }
        if (known != 2)
        {
            continue;
        }
        const std::int32_t v = suspect.F(f, unknown);
        const std::uint64_t key = edge_key(to_original[static_cast<std::size_t>(suspect.F(f, (unknown + 1) % 3))],
                                           to_original[static_cast<std::size_t>(suspect.F(f, (unknown + 2) % 3))]);
        std::int32_t best = -1;
        double best_squared = std::numeric_limits<double>::infinity();
        double next_squared = std::numeric_limits<double>::infinity();
        for (auto it = std::lower_bound(by_edge.begin(), by_edge.end(), std::pair(key, std::int32_t{-1}));
             it != by_edge.end() && it->first == key; ++it)
        {
            if (taken[static_cast<std::size_t>(it->second)] != 0 || it->second == best)
            {
                continue;
            }
            const double squared = (original.V.row(it->second) - suspect.V.row(v)).squaredNorm();
            if (squared < best_squared)
            {
                next_squared = best_squared;
                best = it->second;
                best_squared = squared;
            }
            else
            {
                next_squared = std::min(next_squared, squared);
            }
        }
        if (best >= 0 && best_squared <= squared_tolerance &&
            best_squared <= kMaxStartRatio * kMaxStartRatio * next_squared)
        {
            to_original[static_cast<std::size_t>(v)] = best;
            taken[static_cast<std::size_t>(best)] = 1;
            const auto around = faces_of.of(static_cast<std::size_t>(v));
            queue.insert(queue.end(), around.begin(), around.end());
        }
    }
    // Every vertex reached, and every triangle the original's.
    Positions in_order(original.V.rows(), 3);
    for (std::size_t j = 0; j < n; ++j)
    {
        if (to_original[j] < 0)
        {
            return std::nullopt;
        }
        in_order.row(to_original[j]) = suspect.V.row(static_cast<Eigen::Index>(j));
    }
    std::vector<std::array<std::int32_t, 3>> triangles(static_cast<std::size_t>(original.F.rows()));
    for (Eigen::Index f = 0; f < original.F.rows(); ++f)
    {
        auto& t = triangles[static_cast<std::size_t>(f)];
        t = {original.F(f, 0), original.F(f, 1), original.F(f, 2)};
        std::sort(t.begin(), t.end());
    }
    std::sort(triangles.begin(), triangles.end());
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        std::array<std::int32_t, 3> t{to_original[static_cast<std::size_t>(suspect.F(f, 0))],
                                      to_original[static_cast<std::size_t>(suspect.F(f, 1))],
                                      to_original[static_cast<std::size_t>(suspect.F(f, 2))]};
        std::sort(t.begin(), t.end());
        if (!std::binary_search(triangles.begin(), triangles.end(), t))
        {
            return std::nullopt;
        }
    }
    return in_order;
}

}  // namespace renumbering

// Up to this many vertices, a copy whose vertices the positions alone do not tell apart is
// tried again with the vertices its triangles leave no choice for (renumbering::left_no_choice;
// a printer bed's reorder: 0.01-0.09 s in all; where it fails, about 13 microseconds per vertex:
// a reorder of dragon_vrip_res3.ply, 23K vertices, 0.44 -> 0.74 s); a larger one goes to the
// registration as before.
constexpr Eigen::Index kMaxConsistencyVertices = 10'000;
// ... as far from its original vertex as these shares of the tolerance, tried in turn: the
// triangles, not the distances, decide.
constexpr std::array<double, 4> kConsistencyReaches{0.2, 0.4, 0.8, 2.0};

// The suspect's positions in the original's vertex order, when it is the original's mesh
// renumbered where it stands: a writer that numbers the vertices its own way and moves nothing
// but the mark (a Draco re-encoding, whose edgebreaker numbers the points in its traversal
// order: every marked Draco file) keeps every triangle between the same vertices. Such a copy
// read through registration depended on the registration finding the one right pose, which an
// assembly of like parts (a Collada grid of 64 cubes: its marked Draco file z 2.18, reordered
// copies 4.47 in 2 of 5 orders) or an instanced mesh (registered onto its other instance, z
// 0.41) can miss, and it cost a registration (the converted DirectX character's marked Draco
// file: 0.19 s, now 0.02 s). The vertices that stand for an original vertex beyond doubt
// (mutual nearest in place, within \p tolerance, the next vertex at least twice as far either
// way: kMaxStartRatio) start the correspondence; through the triangles it reaches the others
// (a suspect triangle with two corners known is the original's triangle on their edge whose
// third corner is clearly the nearest), so vertices nearer each other than the mark moves them
// (the character's: 0.02% of the diagonal apart) are told apart. It holds when every vertex is
// reached, each original vertex once, and every suspect triangle is a triangle of the
// original. Where no vertex is beyond doubt (a CAD plate whose vertices crowd on the arcs of its
// outline, 0.2 mm apart where the mark moves them 0.3 mm), the vertices the triangles leave no
// choice for start it instead (renumbering::left_no_choice; a reordered printer bed: z 2.61 ->
// 9.8). Else the copy is registered as before (a dense scan, whose vertices the mark moves by a
// good part of their spacing, is). Positions and triangles only, never the key.
std::optional<Positions> renumbered_in_place(const TriangleMesh& original, const TriangleMesh& suspect, double tolerance,
                                             int threads)
{
    if (suspect.V.rows() != original.V.rows() || suspect.F.rows() != original.F.rows() || original.F.rows() == 0)
    {
        return std::nullopt;
    }
    // No vertex moves further than \p tolerance, so no side of the bounding box does: a copy
    // moved elsewhere is turned away before the kd-trees and the queries (the generated 1M
    // mesh moved and reordered: 4.2 s of its 7.4 s detection went here).
    const BoundingBox in_original = bounding_box(original.V);
    const BoundingBox in_suspect = bounding_box(suspect.V);
    if ((in_original.min - in_suspect.min).cwiseAbs().maxCoeff() > tolerance ||
        (in_original.max - in_suspect.max).cwiseAbs().maxCoeff() > tolerance)
    {
        return std::nullopt;
    }
    const PointKdTree original_tree(original.V);
    const renumbering::EdgeThirds by_edge = renumbering::edge_thirds(original);
    const VertexFaces faces_of = vertex_faces(suspect);  // the suspect's triangles by vertex
    if (auto in_order = renumbering::propagated(
            original, suspect, by_edge, faces_of,
            renumbering::beyond_doubt(original, suspect, original_tree, tolerance, threads), tolerance))
    {
        return in_order;
    }
    if (original.V.rows() > kMaxConsistencyVertices)
    {
        return std::nullopt;
    }
    const renumbering::NearestOriginals nearest = renumbering::nearest_originals(suspect, original_tree);
    const VertexAdjacency original_adjacency = vertex_adjacency(original);
    const VertexAdjacency suspect_adjacency = vertex_adjacency(suspect);
    // The reach grows until the triangles leave some vertices no choice: a small one keeps
    // few choices per vertex (the arcs of a printer bed put 25 vertices within 5 mm), a vertex
    // the mark moved beyond it has none, and where vertices crowd the mark moves some far (13
    // amplitudes on PrusaSlicer's Ender 2 bed: its 200 vertices carry a mark whose surface
    // distance is what the plate's faces show).
    for (const double reach : kConsistencyReaches)
    {
        const double r = reach * tolerance;
        if (const auto starts = renumbering::left_no_choice(nearest, original_adjacency, suspect_adjacency, r))
        {
            if (std::none_of(starts->begin(), starts->end(), [](std::int32_t x) { return x >= 0; }))
            {
                break;  // a larger reach leaves more choices, never fewer
            }
            if (auto in_order = renumbering::propagated(original, suspect, by_edge, faces_of, *starts, r))
            {
                return in_order;
            }
        }
    }
    return std::nullopt;
}

// Original triangles a writer may leave out and still be taken as numbering the others its own
// way: Blender drops an original's repeated and degenerate triangles on import (24 of the 13,502
// of OpenCASCADE's motor).
constexpr double kMaxDroppedTriangles = 0.01;

// The suspect's positions in the original's vertex order, when its triangles are the original's,
// in the original's order and each with its corners in the same turn, over vertices numbered
// another way: Blender's PLY writer numbers the vertices in the order its triangles first use
// them, and its import drops repeated and degenerate triangles (at most kMaxDroppedTriangles of
// them are skipped). Unlike renumbered_in_place it looks at no position, so it holds however far
// a tool moved the vertices (Blender's Smooth modifier, 0.5 x 10, on OpenCASCADE's motor, 6,635
// vertices: read through registration at z 4.15, in the original's order 10.77). Each suspect
// triangle is the next original triangle whose corners are still free or already the same
// vertices; it holds when every suspect vertex stands for one original vertex and each
// original vertex for one suspect vertex. Triangles only, never the key.
std::optional<Positions> renumbered_by_triangles(const TriangleMesh& original, const TriangleMesh& suspect)
{
    const Eigen::Index n = original.V.rows();
    const Eigen::Index faces = original.F.rows();
    const auto droppable = static_cast<Eigen::Index>(kMaxDroppedTriangles * static_cast<double>(faces));
    if (suspect.V.rows() != n || faces == 0 || suspect.F.rows() > faces || suspect.F.rows() < faces - droppable)
    {
        return std::nullopt;
    }
    std::vector<std::int32_t> original_of(static_cast<std::size_t>(n), -1);  // suspect vertex -> original
    std::vector<std::int32_t> suspect_of(static_cast<std::size_t>(n), -1);   // original vertex -> suspect
    Eigen::Index next = 0;  // the next original triangle
    for (Eigen::Index f = 0; f < suspect.F.rows(); ++f)
    {
        if (suspect.F(f, 0) == suspect.F(f, 1) || suspect.F(f, 1) == suspect.F(f, 2) ||
            suspect.F(f, 2) == suspect.F(f, 0))
        {
            return std::nullopt;  // a triangle with a repeated corner is no triangle of a copy
        }
        for (;; ++next)
        {
            if (next >= faces || next - f > droppable)
            {
                return std::nullopt;
            }
            bool fits = true;
            for (Eigen::Index k = 0; k < 3 && fits; ++k)
            {
                const auto s = static_cast<std::size_t>(suspect.F(f, k));
                const auto o = static_cast<std::size_t>(original.F(next, k));
                fits = original_of[s] == static_cast<std::int32_t>(o) ||
                       (original_of[s] < 0 && suspect_of[o] < 0);
            }
            if (fits)
            {
                for (Eigen::Index k = 0; k < 3; ++k)
                {
                    original_of[static_cast<std::size_t>(suspect.F(f, k))] = original.F(next, k);
                    suspect_of[static_cast<std::size_t>(original.F(next, k))] = suspect.F(f, k);
                }
                ++next;
                break;
            }
        }
    }
    if (std::any_of(suspect_of.begin(), suspect_of.end(), [](std::int32_t s) { return s < 0; }))
    {
        return std::nullopt;  // an original vertex no suspect triangle uses: not the same numbering
    }
    Positions in_order(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        in_order.row(i) = suspect.V.row(suspect_of[static_cast<std::size_t>(i)]);
    }
    return in_order;
}

// The original followed by its other instances, as one mesh (the registration's reference).
TriangleMesh with_instances(const TriangleMesh& original, const TriangleMesh& instances)
{
    TriangleMesh shown;
    shown.V.resize(original.V.rows() + instances.V.rows(), 3);
    shown.V << original.V, instances.V;
    shown.F.resize(original.F.rows() + instances.F.rows(), 3);
    shown.F << original.F, (instances.F.array() + static_cast<std::int32_t>(original.V.rows())).matrix();
    return shown;
}

// Steps 6-10 for a suspect in memory, appending phases to \p timer.
// \p instances: geometry of the original that is shown but not watermarked (other instances
// of instanced glTF meshes); registration matches the suspect against it too.
// The same triangles over the same vertex numbers: a copy in the original's vertex order.
bool has_same_triangles(const TriangleMesh& a, const TriangleMesh& b)
{
    return a.F.rows() == b.F.rows() && (a.F.array() == b.F.array()).all();
}

// A traced report's accused (from report.traced) and ownership (report.decision and the
// joint readings): what its probabilities conclude at the level of \p decision.
void conclude_trace(DetectReport& report, const DetectOptions& decision)
{
    std::vector<RecipientScore> scores = report.traced;
    std::erase_if(scores, [](const RecipientScore& s) { return !s.is_accused; });
    // Strongest evidence first: the smallest false-positive probability (whichever reading,
    // whole model or regions, gave it), then the larger score.
    std::sort(scores.begin(), scores.end(), [](const RecipientScore& a, const RecipientScore& b) {
        if (a.false_positive_probability != b.false_positive_probability)
        {
            return a.false_positive_probability < b.false_positive_probability;
        }
        return a.score > b.score;
    });
    report.accused = std::move(scores);
    // Ownership: the owner's verdict or the best joint reading of the owner's mark with a
    // recipient's code, each with half the level (a union bound over both tests).
    double joint = 1.0;
    for (const RecipientScore& r : report.traced)
    {
        joint = std::min(joint, r.joint_false_positive_probability);
    }
    report.owner_false_positive_probability =
        std::min({1.0, 2.0 * report.decision.false_positive_probability, 2.0 * joint});
    report.owner_detected = report.owner_false_positive_probability <= decision.max_false_positive;
}

std::vector<Eigen::Matrix4d> self_symmetries(const TriangleMesh& original, double amplitude, int threads,
                                             const SurfaceMatcher* given_surface = nullptr);

// What the first reading of a copy learns for the others (read_other_poses): the
// registration's fit of the other handedness, and the original's symmetries when they were
// searched right after the registration, over its closest-point structure (kept for that, and
// dropped before the correspondence: about 150 MB of arrays on a 1M-vertex original).
struct PoseHints
{
    std::optional<Eigen::Matrix4d> other_handedness;
    std::optional<std::vector<Eigen::Matrix4d>> symmetries;
    // The copy's vertices were put in the original's order by its triangles alone
    // (renumbered_by_triangles): like a copy in that order, it has no other pose.
    bool is_numbered_by_triangles = false;
};

void detect_into(DetectReport& report, detail::PhaseTimer& timer, const SpectralWatermark& mark,
                 const TriangleMesh& original, const TriangleMesh& instances,
                 const TriangleMesh& suspect, const std::filesystem::path& suspect_path,
                 const DetectFileOptions& options, const Eigen::Matrix4d* pose = nullptr,
                 PoseHints* hints = nullptr)
{
    report.suspect_vertices = suspect.vertex_count();
    report.original_vertices = original.vertex_count();

    // Everything geometric (pose, correspondence, crop) is decided against the ORIGINAL, never
    // against the watermarked mesh: that keeps every step before the correlation independent of
    // the key's signs, which is what makes the false-positive bound of the verdict hold for an
    // unmarked suspect (docs/statistics.md). What the pose fit absorbs of a marked suspect's
    // watermark (its similarity component) is recovered by the nuisance fit of the extraction.
    const double diagonal = bounding_box(original.V).diagonal();
    Positions aligned;
    const std::vector<std::uint8_t>* kept = nullptr;
    std::vector<std::uint8_t> kept_rows;
    double weight_scale = 0.0;  // resampled suspects: the rows' weights (kWeightScale)
    Resampling sampled;         // resampled suspects: the suspect's surface at the original's vertices
    Eigen::Matrix4d to_original = Eigen::Matrix4d::Identity();

    // Same vertex count: try the vertices in order, after the closed-form similarity onto the
    // original [Umeyama 1991].
    bool is_corresponding = false;
    bool is_resampled = false;
    bool is_cropped = false;
    const double amplitude = mark_amplitude(mark.key().options, diagonal);
    report.mark_strength = amplitude / diagonal;
    // RMS distance of suspect rows in the original's order to the original, over the diagonal.
    auto relative_rms = [&](const Positions& in_frame) {
        return std::sqrt((in_frame - original.V).rowwise().squaredNorm().mean()) / diagonal;
    };
    // A suspect in the original's vertex order (\p in_order, suspect frame; \p left_out: rows
    // no suspect vertex stands for, null: none), taken onto the original by the similarity \p T
    // fitted over all its rows: the rows a tool threw far away (the far-rows rule of resampled
    // suspects, on the vertices' own distances) are left out too, and the similarity is fitted
    // again without them, since the closed form has no defence against them.
    auto take_in_order = [&](const Positions& in_order, const Eigen::Matrix4d& T,
                             const std::vector<std::uint8_t>* left_out, std::size_t left_out_count) {
        aligned = transform_points(T, in_order);
        report.transform = T;
        const Eigen::VectorXd distance = (aligned - original.V).rowwise().norm();
        std::size_t outliers = 0;
        kept_rows = kept_without_outliers(distance, left_out, kOutlierFloor * amplitude, outliers);
        // Refitted without the far rows until they stay the same: a fit over every row is
        // pulled by the far ones, and so are the distances that tell them (Blender's Smooth
        // crushing a fifth of a mesh: the first refit still left out the wrong rows).
        for (int round = 0; outliers > 0 && round < kMaxOutlierRefits; ++round)
        {
            const Eigen::Matrix4d refit = similarity_onto_original(original.V, in_order, &kept_rows);
            aligned = transform_points(refit, in_order);
            report.transform = refit;
            std::vector<std::uint8_t> again = kept_without_outliers((aligned - original.V).rowwise().norm(), left_out,
                                                                    kOutlierFloor * amplitude, outliers);
            if (again == kept_rows)
            {
                break;
            }
            kept_rows = std::move(again);
        }
        if (outliers + left_out_count > 0)
        {
            // Rows no suspect vertex stands for are what the copy no longer covers: cropped.
            kept = &kept_rows;
            report.outlier_fraction = static_cast<double>(outliers) / static_cast<double>(original.V.rows());
            report.cropped_fraction = static_cast<double>(left_out_count) / static_cast<double>(original.V.rows());
        }
    };
    timer.begin("correspondence");
    // (A given pose is the caller's: the vertices are not taken in order without it.)
    if (suspect.vertex_count() == original.vertex_count() && options.pairs.empty() && pose == nullptr)
    {
        // Other triangles over as many vertices: perhaps the same mesh numbered another way,
        // by its triangles (Blender's PLY writer: renumbered_by_triangles) or where it stands
        // (a re-encoded Draco primitive: renumbered_in_place), then read in the original's
        // order without registration.
        const bool same_triangles = has_same_triangles(suspect, original);
        std::optional<Positions> renumbered;
        if (!same_triangles)
        {
            renumbered = renumbered_by_triangles(original, suspect);
            if (renumbered && hints != nullptr)
            {
                hints->is_numbered_by_triangles = true;
            }
        }
        if (!same_triangles && !renumbered)
        {
            renumbered = renumbered_in_place(original, suspect, kOutlierFloor * amplitude, options.threads);
        }
        const Positions& in_order = renumbered ? *renumbered : suspect.V;
        const Eigen::Matrix4d T = similarity_onto_original(original.V, in_order, nullptr);
        aligned = transform_points(T, in_order);
        report.registration_rms = relative_rms(aligned);
        report.transform = T;
        // Triangles that are the original's tell which vertex is which however far a tool
        // moved them (a strong smoothing of a CAD part: 2.4% of the diagonal RMS, whose far
        // rows the reading leaves out); otherwise (a point cloud has none) the positions must
        // say so.
        const bool has_triangles = original.F.rows() > 0;
        is_corresponding = (same_triangles && has_triangles) || renumbered.has_value() ||
                           report.registration_rms <= kCorrespondenceTolerance;
        report.alignment = "same-connectivity";
        if (is_corresponding)
        {
            take_in_order(in_order, T, nullptr, 0);
        }
    }
    RegistrationResult registered_to;  // suspects that do not correspond as they are
    if (!is_corresponding)
    {
        if (!options.allow_registration)
        {
            throw InvalidOption(
                suspect_path.string() + ": the suspect's vertices do not correspond to the "
                "original's (" + std::to_string(suspect.vertex_count()) + " vertices against " +
                std::to_string(original.vertex_count()) +
                ", or the same count in another order or shape), and registration is off "
                "(--no-register).");
        }
        // Any pose, connectivity or cropping: register onto the original, then take for every
        // vertex of it the closest point of the suspect's surface.
        timer.begin("register");
        RegistrationOptions registration;
        registration.threads = options.threads;
        // The poses read_other_poses will read need the original's symmetries.
        const bool wants_symmetries = hints != nullptr && pose == nullptr && instances.vertex_count() == 0 &&
                                      options.decision.verdict != VerdictRule::Bits;
        registration.keep_reference_surface = wants_symmetries;
        // A tool that flattens instanced meshes (gltf-transform optimize joins them) leaves a
        // copy that shows every instance: registered against the first instances alone, the
        // others are unexplained geometry that can pull the fit away.
        const bool has_instances =
            instances.vertex_count() > 0 && instances.is_point_cloud() == original.is_point_cloud();
        const TriangleMesh shown = has_instances ? with_instances(original, instances) : TriangleMesh{};
        const TriangleMesh& reference = has_instances ? shown : original;
        if (pose != nullptr)  // another pose of a symmetric original (read_other_poses)
        {
            registered_to.transform = *pose;
            registered_to.converged = true;
        }
        else
        {
            registered_to = options.pairs.empty()
                                ? register_to_reference(suspect, reference, registration)
                                : register_to_reference(suspect, reference, options.pairs, registration);
        }
        const RegistrationResult& r = registered_to;
        timer.lap("register");
        if (hints != nullptr)
        {
            hints->other_handedness = r.other_handedness;
        }
        if (wants_symmetries)
        {
            timer.begin("symmetry");
            hints->symmetries = self_symmetries(original, amplitude, options.threads, r.reference_surface.get());
            registered_to.reference_surface.reset();
            timer.lap("symmetry");
        }
        timer.begin("correspondence");
        // The original's vertices again, reordered, split, welded or with vertices added
        // between them: read vertex for vertex (match_vertices), every component of the change
        // instead of its normal one. Only where the mark moves a vertex by a small part of the
        // spacing (mean edge >= kMatchSpacing amplitudes): on a denser mesh a marked vertex can come closer to a
        // neighbour's place than to its own, and the pairs mislead (a reordered 1M-vertex
        // copy, mean edge about 3 amplitudes: 97.5% matched, z 7.9 against 9.7 resampled).
        // The mean edge (a pass over the faces) only once the cheap conditions hold. The
        // registration need not have met its stopping tolerance: the pairs below are their own
        // test of the pose (mutual nearest within a small part of an edge, nearly all of them or
        // whole original triangles), and a small thin mesh whose residual is the mark itself can
        // keep jittering between trimmed sets (Blender's glTF copy of a 762-vertex spider).
        const bool may_match = options.match_vertices && !has_instances &&
                               2 * suspect.vertex_count() >= original.vertex_count() && original.F.rows() > 0;
        const double spacing = may_match ? mean_edge_length(original) : 0.0;
        if (may_match && spacing >= kMatchSpacing * amplitude)
        {
            std::vector<std::int32_t> match;
            const Positions registered = transform_points(r.transform, suspect.V);
            double ambiguity = 1.0;
            const std::size_t matched = match_vertices(original.V, registered,
                                                       std::min(kOutlierFloor * amplitude, 0.5 * spacing), match,
                                                       ambiguity, options.threads);
            const auto n = static_cast<std::size_t>(original.V.rows());
            // Nearly every vertex found, or, for a copy that lost some (a crop), the triangles
            // between the vertices found are the original's (original_triangle_share).
            const bool kept_in_place =
                static_cast<double>(matched) >= (1.0 - kMaxNearlyAll) * static_cast<double>(n) ||
                (static_cast<double>(matched) >= (1.0 - kMaxUnmatched) * static_cast<double>(n) &&
                 original_triangle_share(original, suspect, registered, match) >= kMinOriginalTriangles);
            if (kept_in_place && ambiguity <= kMaxMatchAmbiguity)
            {
                // In the registered frame (a mirrored copy is already unmirrored there, which
                // the closed-form similarity could not do); rows without a suspect vertex stand
                // at the original's own position, left out of the fit and of the reading.
                Positions in_order = original.V;
                std::vector<std::uint8_t> matched_rows(n, 1);
                for (std::size_t i = 0; i < n; ++i)
                {
                    if (match[i] >= 0)
                    {
                        in_order.row(static_cast<Eigen::Index>(i)) = registered.row(match[i]);
                    }
                    else
                    {
                        matched_rows[i] = 0;
                    }
                }
                const std::vector<std::uint8_t>* left_out = matched < n ? &matched_rows : nullptr;
                take_in_order(in_order, similarity_onto_original(original.V, in_order, left_out), left_out,
                              n - matched);
                report.transform = report.transform * r.transform;  // suspect -> original
                report.alignment = "registration (vertices matched)";
                report.registration_rms = relative_rms(aligned);
                is_corresponding = true;
            }
        }
    }
    if (!is_corresponding)
    {
        const RegistrationResult& r = registered_to;
        ResamplingOptions resampling;
        resampling.threads = options.threads;
        // Resample at the original's vertices: resampling at the watermarked mesh's vertices would
        // copy the watermark's tangential component onto any unmarked surface (measured: a
        // reordered unmarked bunny read R = 1.0 that way).
        sampled = resample(original, suspect, r.transform, resampling);
        to_original = r.transform;
        report.alignment = r.converged ? "registration" : "registration (not converged)";
        report.transform = r.transform;
        report.registration_rms = r.rms_error;
        report.cropped_fraction = sampled.cropped_fraction;
        is_cropped = sampled.cropped_fraction > 0.0;
        if (is_cropped)
        {
            kept_rows = kept_after_crop(original, sampled.is_cropped);
        }
        std::size_t outliers = 0;
        kept_rows =
            kept_without_outliers(sampled.distance, is_cropped ? &kept_rows : nullptr, kOutlierFloor * amplitude, outliers);
        weight_scale = kWeightScale * amplitude;
        report.outlier_fraction = static_cast<double>(outliers) / static_cast<double>(kept_rows.size());
        if (is_cropped || outliers > 0)
        {
            kept = &kept_rows;
        }
        is_resampled = true;
        // Only the points and, for the second reading, the triangles they lie on are needed
        // from here on: the rest goes before the extraction's allocations.
        sampled.distance = Eigen::VectorXd();
        sampled.is_cropped = std::vector<std::uint8_t>();
    }
    timer.lap("correspondence");

    timer.begin("extract");
    const Detector detector(mark, original);
    const Positions& at = is_resampled ? sampled.points : aligned;
    // A family key's code is read jointly with the owner's mark unless the suspect is cropped
    // (Detector::extract_resampled); rows left out as outliers alone do not make it cropped.
    auto read = [&] {
        return !is_resampled ? (kept != nullptr ? detector.extract_kept(at, options.decision, *kept)
                                                : detector.extract(at, options.decision))
               : is_cropped  ? detector.extract_resampled(at, options.decision, kept, weight_scale)
                             : detector.extract_resampled_with_code(at, options.decision, kept, weight_scale);
    };
    const bool is_tracing = options.trace && mark.key().recipients && !mark.key().recipients->recipients.empty();
    report.extraction = read();
    std::vector<std::vector<double>> plain_regions;  // a family code's regions, first reading
    std::optional<Extraction> plain_code;            // a cropped suspect's code, first reading
    // The second reading is skipped when the first alone, paying for the statistics of both,
    // already claims by its score (not by its bit count, which the second reading would not
    // repeat): the claim is then one the two readings make too, and a clear copy is read at
    // the cost of one reading (docs/algorithms/detection.md).
    bool is_conclusive = false;
    if (is_resampled && options.match_surface && !is_tracing)
    {
        // The second reading would bring as many statistics as the first has and the joined
        // ones; the stop asks for more (kEarlyStopStatistics), which implies the claim. It asks
        // it of the formula bound, not of the tail counted for the first reading's weights: that one claims
        // copies from z ~ 5 whose second reading scores 9-10, and a clear copy should report
        // the score it has (the claim is the same either way).
        const Decision first = mark.decide(report.extraction, options.decision);
        // Unread: the second reading's own statistics and the two readings joined.
        const int unread = first.statistic_count +
                           joined_reading_count(static_cast<int>(report.extraction.further_changes.size()));
        const int paid = std::max(first.statistic_count + unread, kEarlyStopStatistics);
        const double both = std::min(1.0, paid * rademacher_tail_bound(first.score));
        const double factor = score_level_factor(options.decision.verdict);
        is_conclusive = factor > 0.0 && both * factor <= options.decision.max_false_positive;
        if (is_conclusive)
        {
            report.extraction.unread_statistics = unread;
        }
    }
    if (is_conclusive)
    {
        sampled.element = std::vector<std::int32_t>();
    }
    if (is_resampled && options.match_surface && !is_conclusive)
    {
        // Read again against the original's surface under the suspect's triangles
        // (match_reference_surface): a coarse copy's triangles cut under a curved surface by
        // many times the mark's amplitude even where they carry nothing, and the same
        // triangles laid through the closest points of their corners on the ORIGINAL cut the
        // same way, so the difference keeps what the corners carry. That second reading is
        // the primary one (bits, R, the family code); the first's statistics stay in the
        // verdict, because a simplifier that places its vertices off the surface (quadric
        // placement) leaves an error that the chord partly cancels in the first reading and
        // that the second sees whole (docs/algorithms/detection.md, "General suspects"). Only
        // the original and the suspect enter either reading, so the bound holds, paying for
        // the statistics of both.
        Extraction plain = std::move(report.extraction);
        if (is_tracing)
        {
            // The code's regions are read both ways too; the trace's union bound counts them.
            if (is_cropped)
            {
                plain_code = detector.extract_resampled_with_code(at, options.decision, kept, weight_scale);
            }
            plain_regions = detector.region_changes(at, is_resampled, kept, weight_scale,
                                                    plain_code ? plain_code->code_sampling : plain.code_sampling);
        }
        timer.lap("extract");
        timer.begin("match surface");
        match_reference_surface(sampled, original, suspect, to_original, options.threads);
        timer.lap("match surface");
        timer.begin("extract");
        report.extraction = read();
        add_further_reading(report.extraction, plain);
    }
    report.decision = mark.decide(report.extraction, options.decision);
    report.owner_detected = report.decision.is_present;
    report.owner_false_positive_probability = report.decision.false_positive_probability;
    if (is_tracing)
    {
        std::vector<double> cropped_sampling;  // the code's sampling, where the code is read apart
        if (is_cropped)
        {
            // The owner's coefficients were read alone (cropped suspect); the code's, read
            // jointly with them, still serve a slightly cropped one (remeshing, simplification).
            Extraction with_code = detector.extract_resampled_with_code(at, options.decision, kept, weight_scale);
            cropped_sampling = std::move(with_code.code_sampling);
            report.extraction.recipient_change = std::move(with_code.recipient_change);
            report.extraction.recipient_weights = std::move(with_code.recipient_weights);
            if (plain_code)
            {
                // Both readings of the code, as for the owner's coefficients: the code's
                // further readings (its damped ones, then the first reading's statistics).
                Extraction code;
                code.normalized_change = std::move(with_code.normalized_change);
                code.weights = std::move(with_code.weights);
                code.recipient_change = report.extraction.recipient_change;
                code.further_changes = std::move(with_code.further_changes);
                code.further_recipient_changes = std::move(with_code.further_recipient_changes);
                add_further_reading(code, *plain_code);
                report.extraction.further_recipient_changes = std::move(code.further_recipient_changes);
            }
        }
        report.extraction.region_changes =
            detector.region_changes(at, is_resampled, kept, weight_scale,
                                    is_cropped ? cropped_sampling : report.extraction.code_sampling);
        std::move(plain_regions.begin(), plain_regions.end(), std::back_inserter(report.extraction.region_changes));
        report.traced = mark.trace(report.extraction, options.decision);
        report.recipients_traced = report.traced.size();
        conclude_trace(report, options.decision);
    }
    timer.lap("extract");
}

// Rotations and mirror images S about the original's centroid that map its surface onto
// itself: among the 23 other coordinate-axis rotations and the 24 coordinate-axis mirror maps
// of its principal frame and of the file's axes, and the turns described below, those that
// keep its second and third moments (a cheap test that rejects an asymmetric mesh at once)
// and lay a sample of its vertices on its own surface within kSymmetryTolerance mark
// amplitudes RMS, or, for a plane's mirror image, nearly (near_mirror). Returned as 4x4
// transforms in the original's frame.
constexpr double kSymmetryTolerance = 2.0;
constexpr double kSymmetryOnVertices = 0.25;  // mark amplitudes RMS, vertex to nearest vertex
// Orders of the turns tried about each axis (2 pi j / k), and the most poses read besides the
// registered one (the false-positive probability is multiplied by the poses read).
constexpr std::array<int, 10> kSymmetryOrders = {3, 5, 6, 8, 10, 12, 16, 20, 24, 32};
constexpr std::size_t kMaxSymmetries = 47;
constexpr double kSymmetryMoments = 0.02;   // of the RMS radius squared / cubed
constexpr Eigen::Index kSymmetrySample = 2048;
constexpr std::size_t kSymmetryMomentRows = 65536;
// A map this close to one already found (Frobenius norm of the difference, about 4 degrees) is
// the same symmetry seen from the other frame: the registration from either pose lands in the
// same place, so it is not read (nor paid for) twice.
constexpr double kSameSymmetry = 0.1;

// The 24 orthogonal maps of determinant \p sign (+1: rotations, -1: mirror images) that map
// the coordinate axes onto signed coordinate axes.
std::vector<Eigen::Matrix3d> signed_axis_maps(double sign)
{
    std::vector<Eigen::Matrix3d> out;
    std::array<int, 3> order = {0, 1, 2};
    do
    {
        for (int signs = 0; signs < 8; ++signs)
        {
            Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
            for (int row = 0; row < 3; ++row)
            {
                R(row, order[static_cast<std::size_t>(row)]) = (signs >> row & 1) != 0 ? -1.0 : 1.0;
            }
            if (R.determinant() * sign > 0.0)
            {
                out.push_back(R);
            }
        }
    } while (std::next_permutation(order.begin(), order.end()));
    return out;
}

// A mirror image that lays most of the original on its own surface but not all of it: a
// character or vehicle modelled with a Mirror modifier and then given a part on one side only
// (Blender's creature of "Two more game-like assets": 98% of its vertices within 2 mark
// amplitudes of their mirror image, RMS 14 amplitudes for the part left). That part also moves
// the centroid and tilts the principal frame, so the mirror \p R about the centroid is refitted:
// rounds of a rigid point-to-plane step (rigid_step) of the mirrored \p sample onto its
// closest points on the original, on the kNearMirrorShare of pairs nearest, while the
// farthest of those pairs shrinks each round to less than kNearMirrorStall of the last (an
// asymmetric shape stalls at once: fertility 11.5 -> 10.7 amplitudes, and the search
// stops) and is not yet settled (within kNearMirrorSettled of the tolerance: a twin pose that
// close matches vertices as the exact one would), for at most kNearMirrorRounds. The refitted
// map counts when that share of the sample then lies within kSymmetryTolerance amplitudes of
// the surface (the creature from 1.9 to 0.03 in one round, Blender's vehicle from 7.1 to 0.04
// in two, the boxy walker of the held-out assets from 24.6 to 0.22 in six). Point to point
// (Umeyama), as first written, slides along flat parts a little each round: the vehicle took
// ten rounds, and the walker stalled at 6.3 (its rounds shrank the farthest pair by 8%) and
// was not found. \p sample is centred on \p centroid.
constexpr double kNearMirrorShare = 0.9;
constexpr double kNearMirrorStall = 0.9;
constexpr double kNearMirrorSettled = 0.25;  // of kSymmetryTolerance
constexpr int kNearMirrorRounds = 12;

// The map x -> R (x - centroid) + centroid of the original's frame, as a 4x4 transform.
Eigen::Matrix4d about_centroid(const Eigen::Matrix3d& R, const Eigen::RowVector3d& centroid)
{
    Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
    S.topLeftCorner<3, 3>() = R;
    S.topRightCorner<3, 1>() = centroid.transpose() - R * centroid.transpose();
    return S;
}

// One Gauss-Newton step of the rigid map that lays the rows of \p moved listed in \p kept onto
// the planes of their closest triangles of the original (\p closest, by row of \p moved), as
// the registration's fine stage steps without its scale (point_to_plane_step), as a 4x4
// transform. Nullopt when the step is not finite.
std::optional<Eigen::Matrix4d> rigid_step(const Positions& moved, const std::vector<SurfaceMatch>& closest,
                                          std::span<const Eigen::Index> kept)
{
    const std::optional<PointToPlaneStep<6>> update = point_to_plane_step<6>(moved, closest, kept);
    if (!update)
    {
        return std::nullopt;
    }
    const Eigen::Vector3d omega = update->delta.head<3>() / update->radius;
    const double angle = omega.norm();
    const Eigen::Matrix3d dR =
        angle > 0.0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
    // y' = c + dR (y - c) + tau
    const Eigen::Vector3d& c = update->centre;
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topLeftCorner<3, 3>() = dR;
    step.topRightCorner<3, 1>() = c - dR * c + update->delta.tail<3>();
    return step;
}

// \p moved and \p closest: the sample mirrored by \p R and its closest points, as the surface
// test found them (the first round's).
std::optional<Eigen::Matrix4d> near_mirror(const SurfaceMatcher& surface, const Positions& sample,
                                           const Eigen::RowVector3d& centroid, const Eigen::Matrix3d& R,
                                           Positions moved, std::vector<SurfaceMatch> closest, double amplitude,
                                           int threads)
{
    Eigen::Matrix4d S = about_centroid(R, centroid);  // original -> original
    const Positions points = sample.rowwise() + centroid;
    const auto kept_count = static_cast<Eigen::Index>(kNearMirrorShare * static_cast<double>(points.rows()));
    if (kept_count < 6)
    {
        return std::nullopt;
    }
    const double tolerance = kSymmetryTolerance * amplitude;
    std::vector<Eigen::Index> order(static_cast<std::size_t>(points.rows()));
    double previous = std::numeric_limits<double>::infinity();
    for (int round = 0;; ++round)
    {
        if (round > 0)
        {
            moved = transform_points(S, points);
            surface.match_all(moved, closest, threads);
        }
        std::iota(order.begin(), order.end(), Eigen::Index{0});
        const auto kth = order.begin() + kept_count - 1;
        std::nth_element(order.begin(), kth, order.end(), [&](Eigen::Index a, Eigen::Index b) {
            return closest[static_cast<std::size_t>(a)].distance < closest[static_cast<std::size_t>(b)].distance;
        });
        const double farthest = closest[static_cast<std::size_t>(*kth)].distance;
        if (farthest <= kNearMirrorSettled * tolerance || farthest > kNearMirrorStall * previous ||
            round == kNearMirrorRounds)
        {
            return farthest <= tolerance ? std::optional<Eigen::Matrix4d>(S) : std::nullopt;
        }
        previous = farthest;
        const std::optional<Eigen::Matrix4d> step =
            rigid_step(moved, closest, std::span<const Eigen::Index>(order.data(), static_cast<std::size_t>(kept_count)));
        if (!step)
        {
            return std::nullopt;
        }
        S = *step * S;
    }
}

std::vector<Eigen::Matrix4d> self_symmetries(const TriangleMesh& original, double amplitude, int threads,
                                             const SurfaceMatcher* given_surface)
{
    std::vector<Eigen::Matrix4d> found;
    if (original.is_point_cloud() || original.V.rows() < 4)
    {
        return found;
    }
    // The moments from at most kSymmetryMomentRows evenly spaced vertices (their sampling error,
    // about 1/sqrt(rows) of the radius' powers, stays well inside kSymmetryMoments): a large
    // asymmetric original is turned away in a few milliseconds.
    const std::vector<std::int32_t> rows = referenced_vertices(original);
    const auto stride = std::max<std::size_t>(1, rows.size() / kSymmetryMomentRows);
    const auto n = static_cast<Eigen::Index>((rows.size() + stride - 1) / stride);
    Eigen::MatrixX3d X(n, 3);
    for (Eigen::Index i = 0; i < n; ++i)
    {
        X.row(i) = original.V.row(rows[static_cast<std::size_t>(i) * stride]);
    }
    const Eigen::RowVector3d centroid = X.colwise().mean();
    X.rowwise() -= centroid;
    const Eigen::Matrix3d C = X.transpose() * X / static_cast<double>(n);
    const double radius = std::sqrt(C.trace());
    if (!(radius > 0.0))
    {
        return found;
    }
    std::array<double, 27> third{};
    for (Eigen::Index i = 0; i < n; ++i)
    {
        for (int a = 0; a < 3; ++a)
        {
            for (int b = 0; b < 3; ++b)
            {
                for (int c = 0; c < 3; ++c)
                {
                    third[static_cast<std::size_t>(9 * a + 3 * b + c)] += X(i, a) * X(i, b) * X(i, c);
                }
            }
        }
    }
    for (double& t : third)
    {
        t /= static_cast<double>(n);
    }
    const auto keeps_moments = [&](const Eigen::Matrix3d& R) {
        if ((R * C * R.transpose() - C).norm() > kSymmetryMoments * radius * radius)
        {
            return false;
        }
        double difference = 0.0;
        for (int a = 0; a < 3; ++a)
        {
            for (int b = 0; b < 3; ++b)
            {
                for (int c = 0; c < 3; ++c)
                {
                    double rotated = 0.0;  // (R . R . R third)_abc
                    for (int i = 0; i < 3; ++i)
                    {
                        for (int j = 0; j < 3; ++j)
                        {
                            for (int k = 0; k < 3; ++k)
                            {
                                rotated += R(a, i) * R(b, j) * R(c, k) * third[static_cast<std::size_t>(9 * i + 3 * j + k)];
                            }
                        }
                    }
                    const double d = rotated - third[static_cast<std::size_t>(9 * a + 3 * b + c)];
                    difference += d * d;
                }
            }
        }
        return std::sqrt(difference) <= kSymmetryMoments * radius * radius * radius;
    };
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> principal(C);
    Eigen::Matrix3d P = principal.eigenvectors();
    if (P.determinant() < 0.0)
    {
        P.col(0) = -P.col(0);
    }
    // The coordinate-axis rotations (tested against the surface), and the turns by 2 pi j / k
    // about each axis (tested vertex on vertex: a surface of revolution fits its own surface at
    // any angle, but a registration settles only where its vertices land on vertices, as a UV
    // sphere's 12 meridians do every 30 degrees).
    struct Candidate
    {
        Eigen::Matrix3d R;
        bool on_vertices = false;
    };
    std::vector<Candidate> candidates;  // rotations, then mirror images
    const auto add = [&](const Eigen::Matrix3d& R, bool on_vertices) {
        const bool is_new = !R.isIdentity(1e-9) && std::none_of(candidates.begin(), candidates.end(), [&](const auto& Q) {
            return (Q.R - R).norm() < 1e-6;
        });
        if (is_new && keeps_moments(R))
        {
            candidates.push_back({R, on_vertices});
        }
    };
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (const Eigen::Matrix3d& A : signed_axis_maps(1.0))
        {
            add(frame * A * frame.transpose(), false);
        }
    }
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (int axis = 0; axis < 3; ++axis)
        {
            for (const int k : kSymmetryOrders)
            {
                for (int j = 1; j < k; ++j)
                {
                    const double angle = 2.0 * std::numbers::pi * static_cast<double>(j) / static_cast<double>(k);
                    add(Eigen::AngleAxisd(angle, frame.col(axis)).toRotationMatrix(), true);
                }
            }
        }
    }
    // Last the mirror images (a plane of symmetry, as most animals, vehicles and teapots have):
    // after the rotations, so a shape with many of those keeps them within kMaxSymmetries.
    for (const Eigen::Matrix3d& frame : {Eigen::Matrix3d(Eigen::Matrix3d::Identity()), P})
    {
        for (const Eigen::Matrix3d& A : signed_axis_maps(-1.0))
        {
            add(frame * A * frame.transpose(), false);
        }
    }
    if (candidates.empty())
    {
        return found;
    }
    // The original's surface: the registration's own when it kept it (no second structure over
    // the original: on the generated 1M-vertex mesh, whose mirror maps keep its moments, a
    // bounding-volume hierarchy of its 2M triangles took 0.18 s of a 3 s detection).
    std::unique_ptr<SurfaceMatcher> built;
    if (given_surface == nullptr)
    {
        built = std::make_unique<SurfaceMatcher>(original);
    }
    const SurfaceMatcher& surface = given_surface != nullptr ? *given_surface : *built;
    std::optional<PointKdTree> vertices;
    const Eigen::Index step = std::max<Eigen::Index>(1, n / kSymmetrySample);
    Positions sample((n + step - 1) / step, 3);
    for (Eigen::Index i = 0; i < sample.rows(); ++i)
    {
        sample.row(i) = X.row(i * step);
    }
    for (const auto& [R, on_vertices] : candidates)
    {
        if (found.size() >= kMaxSymmetries)
        {
            break;
        }
        if (std::any_of(found.begin(), found.end(), [&](const Eigen::Matrix4d& S) {
                return (S.topLeftCorner<3, 3>() - R).norm() < kSameSymmetry;
            }))
        {
            continue;
        }
        Positions moved = (sample * R.transpose()).rowwise() + centroid;
        std::vector<SurfaceMatch> closest;  // on the surface (not on_vertices)
        double squares = 0.0;
        if (on_vertices)
        {
            if (!vertices)
            {
                Positions all(static_cast<Eigen::Index>(rows.size()), 3);
                for (std::size_t i = 0; i < rows.size(); ++i)
                {
                    all.row(static_cast<Eigen::Index>(i)) = original.V.row(rows[i]);
                }
                vertices.emplace(std::move(all));
            }
            for (Eigen::Index i = 0; i < moved.rows(); ++i)
            {
                double squared = 0.0;
                (void)vertices->nearest(moved.row(i).transpose(), squared);
                squares += squared;
            }
        }
        else
        {
            surface.match_all(moved, closest, threads);
            for (const SurfaceMatch& c : closest)
            {
                squares += c.distance * c.distance;
            }
        }
        const double tolerance = on_vertices ? kSymmetryOnVertices : kSymmetryTolerance;
        if (std::sqrt(squares / static_cast<double>(sample.rows())) <= tolerance * amplitude)
        {
            found.push_back(about_centroid(R, centroid));
        }
        else if (R.determinant() < 0.0 && std::abs(R.trace() - 1.0) < 1e-6)  // a plane's mirror image
        {
            if (const std::optional<Eigen::Matrix4d> S = near_mirror(surface, sample, centroid, R, std::move(moved),
                                                                     std::move(closest), amplitude, threads))
            {
                found.push_back(*S);
            }
        }
    }
    return found;
}

// One of k readings of a copy (several poses): each of its false-positive probabilities times
// k (a union bound over the k, docs/statistics.md, "Several poses"), and the verdict again.
void charge_readings(Decision& d, double readings, const DetectOptions& decision)
{
    d.score_false_positive_probability = std::min(1.0, readings * d.score_false_positive_probability);
    d.bits_false_positive_probability = std::min(1.0, readings * d.bits_false_positive_probability);
    d.false_positive_probability = std::min(1.0, readings * d.false_positive_probability);
    d.is_present = d.false_positive_probability <= decision.max_false_positive;
}

// The same for a whole report: with a family key traced, every recipient's probabilities too,
// and the accused and the ownership again.
void charge_readings(DetectReport& report, double readings, const DetectOptions& decision)
{
    charge_readings(report.decision, readings, decision);
    if (report.recipients_traced == 0)
    {
        return;
    }
    for (RecipientScore& r : report.traced)
    {
        r.false_positive_probability = std::min(1.0, readings * r.false_positive_probability);
        r.joint_false_positive_probability = std::min(1.0, readings * r.joint_false_positive_probability);
        r.is_accused = r.false_positive_probability <= decision.max_false_positive;
    }
    conclude_trace(report, decision);
}

// The smallest false-positive probability a report rests on: its verdict's, or with a family key
// traced, the ownership's or the first accused recipient's.
double strongest_evidence(const DetectReport& report)
{
    if (report.recipients_traced == 0)
    {
        return report.decision.false_positive_probability;
    }
    double p = report.owner_false_positive_probability;
    for (const RecipientScore& r : report.traced)
    {
        p = std::min(p, r.false_positive_probability);
    }
    return p;
}

// \p report becomes \p other when that reading is the more significant; the phase times stay
// (the timer writes into the first report's).
void keep_more_significant(DetectReport& report, DetectReport& other)
{
    if (strongest_evidence(other) < strongest_evidence(report))
    {
        other.seconds = std::move(report.seconds);
        report = std::move(other);
    }
}

// Whether two suspect -> original maps are one pose found twice (a symmetry's twin pose that
// the registration's other handedness already is): within kSameSymmetry in their linear parts
// (over the scale) and in where they take the suspect's bounding-box centre \p centre (over the
// original's \p diagonal).
bool same_pose(const Eigen::Matrix4d& A, const Eigen::Matrix4d& B, const Eigen::Vector3d& centre, double diagonal)
{
    const double scale = std::cbrt(std::abs(A.topLeftCorner<3, 3>().determinant()));
    const Eigen::Vector4d c(centre.x(), centre.y(), centre.z(), 1.0);
    return (A.topLeftCorner<3, 3>() - B.topLeftCorner<3, 3>()).norm() <= kSameSymmetry * scale &&
           ((A - B) * c).norm() <= kSameSymmetry * diagonal;
}

// A registered copy of a symmetric original (an egg, a sphere, a torus, a vase, a teapot, most
// animals and vehicles) fits it as well in every pose the original's symmetries relate, and
// registration picks one of them: the mark is read only in the right one (Blender's PLY copy
// of an egg registered turned half a turn about its axis: z 0.71; a 5% remesh of the teapot
// registered as its mirror image: z 3.37). A copy whose vertices were matched where they stand
// without registration (renumbered_in_place) can be matched the same wrong way: a mirrored
// copy of a mirror-symmetric mesh puts each vertex where its mirror partner was. A nearly
// mirror-symmetric original whose near mirror self_symmetries does not find (a small part on
// one side can change its third moments by more than kSymmetryMoments) fits a mirrored copy
// about as well both ways too: the registration then gives its fit of the other handedness
// (\p hints), read first. Every such pose is read, and the verdict takes the best
// reading at k times its false-positive probability for k readings (a union bound: each
// reading alone keeps the bound, docs/statistics.md), so the poses cost nothing in validity.
// A family key's copy is traced in each pose, every recipient's probabilities charged the same
// way (a buyer's mirrored copy of a symmetric asset accuses the buyer).
void read_other_poses(DetectReport& report, detail::PhaseTimer& timer, const SpectralWatermark& mark,
                      const TriangleMesh& original, const TriangleMesh& instances, const TriangleMesh& suspect,
                      const std::filesystem::path& suspect_path, const DetectFileOptions& options,
                      const PoseHints& hints)
{
    const std::optional<Eigen::Matrix4d>& other_handedness = hints.other_handedness;
    // A copy in the original's vertex order, or put in it by its triangles, is read by index:
    // it has no other pose.
    const bool in_order = report.alignment == "same-connectivity" &&
                          (hints.is_numbered_by_triangles || has_same_triangles(suspect, original));
    const bool placed = report.alignment.rfind("registration", 0) == 0 || report.alignment == "same-connectivity";
    if (!placed || in_order || options.decision.verdict == VerdictRule::Bits)
    {
        return;
    }
    std::vector<Eigen::Matrix4d> poses;  // suspect -> original
    if (other_handedness)
    {
        poses.push_back(*other_handedness);
    }
    if (instances.vertex_count() == 0)
    {
        const double diagonal = bounding_box(original.V).diagonal();
        std::vector<Eigen::Matrix4d> searched;  // unless searched after the registration already
        if (!hints.symmetries)                   // a copy matched without registration (renumbered_in_place)
        {
            timer.begin("symmetry");
            searched = self_symmetries(original, mark_amplitude(mark.key().options, diagonal), options.threads);
            timer.lap("symmetry");
        }
        const std::vector<Eigen::Matrix4d>& symmetries = hints.symmetries ? *hints.symmetries : searched;
        const Eigen::Vector3d centre = other_handedness && !symmetries.empty() ? bounding_box(suspect.V).center()
                                                                                : Eigen::Vector3d::Zero();
        for (const Eigen::Matrix4d& S : symmetries)
        {
            const Eigen::Matrix4d pose = S.inverse() * report.transform;
            if (!other_handedness || !same_pose(pose, *other_handedness, centre, diagonal))
            {
                poses.push_back(pose);
            }
        }
    }
    if (poses.empty())
    {
        return;
    }
    const double readings = static_cast<double>(poses.size() + 1);
    const auto bounded = [&](DetectReport& r) { charge_readings(r, readings, options.decision); };
    bounded(report);
    for (const Eigen::Matrix4d& pose : poses)
    {
        // Settled: someone accused, or a single-owner mark found (ownership alone may still
        // find whose copy it is in another pose).
        if (report.recipients_traced > 0 ? !report.accused.empty() : report.decision.is_present)
        {
            break;
        }
        DetectReport other;
        detect_into(other, timer, mark, original, instances, suspect, suspect_path, options, &pose);
        bounded(other);
        keep_more_significant(report, other);
    }
}

// The animations of an animated original, where detection may read a copy through their poses.
struct AnimatedOriginal
{
    std::filesystem::path path;               // the original's file, read again at other times
    std::vector<AnimationSpan> animations;   // those that may bend the mesh, the file's first first
};

// The frames of each animation a re-posed copy is compared with: Blender's frames (t = F/24 s)
// over its span, frame 1 (what Blender shows after importing, in the first) always among them;
// at most kMaxAnimationFrames, spread evenly over a longer span, and fewer when there are many
// animations (kMaxFramesInAll over all of them, but never fewer than kMinAnimationFrames each).
constexpr int kMaxAnimationFrames = 120;
constexpr int kMaxFramesInAll = 480;
constexpr int kMinAnimationFrames = 24;
// How a frame is compared with the copy: the copy registered onto the original posed there,
// with these samples and iterations (a quarter to a half of a detection's registration), and
// the trimmed RMS residual of the fit. Registered in full (the coarse stage too): frame 1 and
// the kSpreadFrames frames whose principal spread is the copy's closest; then, started from the
// best kPoseCells of those, the frames within kPoseWindow of them (register_from).
constexpr int kPoseRefineSamples = 512;
constexpr int kPoseFineSamples = 1024;
constexpr int kPoseFinalSamples = 2048;
constexpr int kPoseIterations = 15;
constexpr std::size_t kSpreadFrames = 3;
constexpr std::size_t kPoseCells = 2;
constexpr std::size_t kPoseWindow = 2;
constexpr double kBlenderFrameOne = 1.0 / 24.0;

std::vector<double> animation_frame_times(const AnimationSpan& span, int max_frames)
{
    const auto first = static_cast<long long>(std::floor(span.first_key * 24.0));
    const auto last = static_cast<long long>(std::ceil(span.last_key * 24.0));
    std::vector<long long> frames;
    const long long count = last - first + 1;
    if (count <= max_frames)
    {
        for (long long f = first; f <= last; ++f)
        {
            frames.push_back(f);
        }
    }
    else
    {
        for (int k = 0; k < max_frames; ++k)
        {
            frames.push_back(first + (count - 1) * k / (max_frames - 1));
        }
    }
    frames.push_back(1);
    std::vector<double> times;
    for (const long long f : frames)
    {
        times.push_back(std::clamp(static_cast<double>(f) / 24.0, span.first_key, span.last_key));
    }
    std::sort(times.begin(), times.end());
    times.erase(std::unique(times.begin(), times.end()), times.end());
    return times;
}

// One frame of one animation (AnimationSpan::index).
struct AnimationFrame
{
    std::size_t animation = 0;
    double time = 0.0;
};

// Every animation's frames (animation_frame_times), animation after animation, in time order.
std::vector<AnimationFrame> animation_frames(const std::vector<AnimationSpan>& animations)
{
    const int per_animation = std::clamp(kMaxFramesInAll / std::max(1, static_cast<int>(animations.size())),
                                         kMinAnimationFrames, kMaxAnimationFrames);
    std::vector<AnimationFrame> frames;
    for (const AnimationSpan& span : animations)
    {
        for (const double t : animation_frame_times(span, per_animation))
        {
            frames.push_back({span.index, t});
        }
    }
    return frames;
}

// \p visit(pose, k) for each k of \p which: frames[k] posed, the frames of one animation from
// one parse of the file (for_each_animation_pose), animation after animation.
void for_each_frame(const std::filesystem::path& path, const std::vector<AnimationFrame>& frames,
                    const std::vector<std::size_t>& which, const std::function<void(ShownPose&&, std::size_t)>& visit)
{
    std::vector<std::size_t> order = which;
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return frames[a].animation < frames[b].animation; });
    for (std::size_t begin = 0; begin < order.size();)
    {
        std::size_t end = begin;
        std::vector<double> times;
        while (end < order.size() && frames[order[end]].animation == frames[order[begin]].animation)
        {
            times.push_back(frames[order[end++]].time);
        }
        std::size_t at = begin;
        for_each_animation_pose(path, times, [&](ShownPose&& pose) { visit(std::move(pose), order[at++]); },
                                frames[order[begin]].animation);
        begin = end;
    }
}

// An animated original (a rigged glTF character, a machine whose parts move) is shown by
// Blender in the pose of its first animation at frame 1, and every copy made from that import
// (its PLY and OBJ writers, its modifiers) carries the pose; a user may also export it at
// another frame, or of another animation (Blender keeps the others as actions; a character
// posed for a print or a render). A rigid registration can fit only part of such a copy, and the
// mark reads noise (assimp's BVH and FBX samples: z -0.2 to 1.8). The frames of the animations
// are compared with the copy (animation_frames: by principal spread, then registration) and the
// one it fits best is taken: the copy is registered onto the
// original in that pose, each of its vertices taken back to the stored frame through the pose of
// the original's vertex nearest to it (for_each_animation_pose; everything from the original
// and the copy, nothing from the key: the choice is the same for every key), and read again.
// Two readings: each is claimed at twice its false-positive probabilities (a union bound, as
// for the symmetric poses), unless no frame bends the mesh (then there is no second reading;
// an animation the reader sees only moves the whole, a turntable, never comes here).
void read_animation_pose(DetectReport& report, detail::PhaseTimer& timer, const SpectralWatermark& mark,
                         const TriangleMesh& original, const TriangleMesh& instances, const AnimatedOriginal& animated,
                         const TriangleMesh& suspect, const std::filesystem::path& suspect_path,
                         const DetectFileOptions& options)
{
    if ((report.alignment.rfind("registration", 0) != 0 && report.alignment != "same-connectivity") ||
        (mark.key().recipients && !mark.key().recipients->recipients.empty()) ||
        options.decision.verdict == VerdictRule::Bits || !options.pairs.empty())
    {
        return;
    }
    // Whether the animation bends the mesh at any of its frames (the reader gives no pose where
    // it only moves the whole, which the stored pose's registration already read): frame 1, the
    // middle frame and the last first, the others only when none of those does. Which frames bend
    // the mesh depends on the original alone, so the charge below is the same for every key and
    // every copy; an animation that bends none (an animated camera, a skinned turntable) gives no
    // second reading, and nothing is charged for one.
    timer.begin("poses");
    const auto mesh_in = [&](const Positions& V) {
        TriangleMesh posed;
        posed.V = V;
        posed.F = original.F;
        return posed;
    };
    const std::vector<AnimationFrame> frames = animation_frames(animated.animations);
    if (frames.empty())
    {
        timer.lap("poses");
        return;
    }
    // (the first animation's frames come first; frame 1 of it is what Blender shows)
    const AnimationSpan& shown = animated.animations.front();
    const std::size_t shown_frames = static_cast<std::size_t>(
        std::count_if(frames.begin(), frames.end(), [&](const AnimationFrame& f) { return f.animation == shown.index; }));
    const auto frame_one = static_cast<std::size_t>(
        std::lower_bound(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(shown_frames),
                         std::clamp(kBlenderFrameOne, shown.first_key, shown.last_key),
                         [](const AnimationFrame& f, double t) { return f.time < t; }) -
        frames.begin());
    {
        std::vector<std::size_t> probe{std::min(frame_one, shown_frames - 1), shown_frames / 2, shown_frames - 1};
        std::sort(probe.begin(), probe.end());
        probe.erase(std::unique(probe.begin(), probe.end()), probe.end());
        bool bends = false;
        const auto bent = [&](ShownPose&& pose, std::size_t) { bends = bends || pose.V.rows() == original.V.rows(); };
        for_each_frame(animated.path, frames, probe, bent);
        if (!bends)
        {
            std::vector<std::size_t> others;
            for (std::size_t k = 0; k < frames.size(); ++k)
            {
                if (std::find(probe.begin(), probe.end(), k) == probe.end())
                {
                    others.push_back(k);
                }
            }
            for_each_frame(animated.path, frames, others, bent);
        }
        timer.lap("poses");
        if (!bends)
        {
            return;
        }
    }
    const auto bounded = [&](DetectReport& r) { charge_readings(r.decision, 2.0, options.decision); };
    bounded(report);
    if (report.decision.is_present)
    {
        return;
    }
    timer.begin("register");
    // Each bending frame's distance from the copy in principal spread (the eigenvalues of the
    // surface's second moments over their sum); the frames registered in full: Blender's frame 1
    // (what a copy of its import shows unless the user moved the timeline) and the kSpreadFrames
    // frames whose spread is closest to the copy's (a copy exported at another frame; exact on
    // the copies measured, a shaking animation's included).
    std::vector<std::pair<double, std::size_t>> by_spread;  // (distance to the copy's spread, frame)
    {
        const Eigen::Vector3d copy_spread = principal_spread(suspect);
        std::vector<std::size_t> every(frames.size());
        std::iota(every.begin(), every.end(), std::size_t{0});
        for_each_frame(animated.path, frames, every, [&](ShownPose&& pose, std::size_t index) {
            if (pose.V.rows() == original.V.rows())
            {
                by_spread.emplace_back((principal_spread(mesh_in(pose.V)) - copy_spread).norm(), index);
            }
        });
    }
    std::vector<std::size_t> first{frame_one};
    const auto closest = by_spread.begin() + static_cast<std::ptrdiff_t>(std::min(by_spread.size(), kSpreadFrames));
    std::partial_sort(by_spread.begin(), closest, by_spread.end());
    std::for_each(by_spread.begin(), closest, [&](const auto& f) { first.push_back(f.second); });
    RegistrationOptions registration;
    registration.threads = options.threads;
    RegistrationOptions quick = registration;
    quick.refine_samples = kPoseRefineSamples;
    quick.fine_samples = kPoseFineSamples;
    quick.final_samples = kPoseFinalSamples;
    quick.max_iterations = kPoseIterations;
    // The whole's motion from the stored pose into \p V (a walk carries the character forward).
    const auto whole_into = [&](const Positions& V) -> Eigen::Matrix4d {
        return Eigen::umeyama(original.V.transpose(), V.transpose(), true);
    };
    std::sort(first.begin(), first.end());
    first.erase(std::unique(first.begin(), first.end()), first.end());
    // Their fits, then the frames within kPoseWindow of the best kPoseCells, started from those.
    struct Fit
    {
        double residual = std::numeric_limits<double>::infinity();
        std::size_t index = 0;
        Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
        Eigen::Matrix4d whole = Eigen::Matrix4d::Identity();
    };
    std::vector<Fit> fits;
    Fit chosen;
    ShownPose best;
    const auto keep = [&](const RegistrationResult& fit, ShownPose& pose, std::size_t index) {
        const Fit f{fit.rms_error, index, fit.transform, whole_into(pose.V)};
        fits.push_back(f);
        if (f.residual < chosen.residual)
        {
            chosen = f;
            best = std::move(pose);
        }
    };
    for_each_frame(animated.path, frames, first, [&](ShownPose&& pose, std::size_t index) {
        if (pose.V.rows() == original.V.rows())  // (else the stored pose, already read, or none)
        {
            keep(register_to_reference(suspect, mesh_in(pose.V), quick), pose, index);
        }
    });
    if (best.V.rows() == 0)
    {
        timer.lap("register");
        return;
    }
    std::sort(fits.begin(), fits.end(), [](const Fit& a, const Fit& b) { return a.residual < b.residual; });
    const std::vector<Fit> cells(fits.begin(), fits.begin() + static_cast<std::ptrdiff_t>(std::min(fits.size(), kPoseCells)));
    // (the frames of the same animation within kPoseWindow of each cell, each started from its cell)
    std::vector<std::size_t> window;
    std::map<std::size_t, const Fit*> window_start;
    for (const Fit& cell : cells)
    {
        const std::size_t from = cell.index >= kPoseWindow ? cell.index - kPoseWindow : 0;
        const std::size_t to = std::min(frames.size(), cell.index + kPoseWindow + 1);
        for (std::size_t k = from; k < to; ++k)
        {
            if (frames[k].animation == frames[cell.index].animation &&
                std::find(first.begin(), first.end(), k) == first.end() && window_start.count(k) == 0)
            {
                window.push_back(k);
                window_start[k] = &cell;
            }
        }
    }
    for_each_frame(animated.path, frames, window, [&](ShownPose&& pose, std::size_t index) {
        const Fit& start = *window_start.at(index);
        if (pose.V.rows() == original.V.rows())
        {
            keep(register_from(suspect, mesh_in(pose.V), whole_into(pose.V) * start.whole.inverse() * start.transform,
                               quick),
                 pose, index);
        }
    });
    const Eigen::Matrix4d to_pose = register_from(suspect, mesh_in(best.V), chosen.transform, registration).transform;
    timer.lap("register");
    timer.begin("unpose");
    const PointKdTree tree(best.V);
    TriangleMesh unposed;
    unposed.V = transform_points(to_pose, suspect.V);
    unposed.F = suspect.F;
    for (Eigen::Index j = 0; j < unposed.V.rows(); ++j)
    {
        double squared = 0.0;
        const Eigen::Vector3d s = unposed.V.row(j).transpose();
        const auto i = static_cast<Eigen::Index>(tree.nearest(s, squared));
        unposed.V.row(j) = (original.V.row(i).transpose() +
                            best.to_rest[static_cast<std::size_t>(i)] * (s - best.V.row(i).transpose()))
                               .transpose();
    }
    timer.lap("unpose");
    DetectReport other;
    const Eigen::Matrix4d in_place = Eigen::Matrix4d::Identity();
    detect_into(other, timer, mark, original, instances, unposed, suspect_path, options, &in_place);
    bounded(other);
    other.transform = other.transform * to_pose;
    other.alignment = "registration (" + best.name + ")";
    keep_more_significant(report, other);
}

// The watermark of \p key regenerated from \p original (phase "basis"), then steps 6-10.
void detect_with_key(DetectReport& report, detail::PhaseTimer& timer, const Key& key, const TriangleMesh& original,
                     const TriangleMesh& instances, const TriangleMesh& suspect,
                     const std::filesystem::path& suspect_path, const DetectFileOptions& options,
                     const AnimatedOriginal* animated = nullptr)
{
    timer.begin("basis");
    const SpectralWatermark mark(original, key, options.threads);
    timer.lap("basis");
    PoseHints hints;
    detect_into(report, timer, mark, original, instances, suspect, suspect_path, options, nullptr, &hints);
    read_other_poses(report, timer, mark, original, instances, suspect, suspect_path, options, hints);
    if (animated != nullptr)
    {
        read_animation_pose(report, timer, mark, original, instances, *animated, suspect, suspect_path, options);
    }
}

}  // namespace

DetectReport detect(const TriangleMesh& suspect, const TriangleMesh& original, const Key& key,
                    const DetectFileOptions& options)
{
    options.decision.validate();
    DetectReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);
    check_original(original, key, "original");
    check_basis_input(original, key.options, "original");
    detect_with_key(report, timer, key, original, TriangleMesh{}, suspect, "suspect", options);
    return report;
}

DetectReport detect_mesh(const SpectralWatermark& mark, const TriangleMesh& original, const TriangleMesh& suspect,
                         const DetectFileOptions& options)
{
    options.decision.validate();
    DetectReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);
    PoseHints hints;
    detect_into(report, timer, mark, original, TriangleMesh{}, suspect, "suspect", options, nullptr, &hints);
    read_other_poses(report, timer, mark, original, TriangleMesh{}, suspect, "suspect", options, hints);
    return report;
}

namespace {

// What detect_file and detect_against_file share: the key and the original read and checked,
// the suspect read from \p suspect_path beside them unless \p given holds it, the detection.
DetectReport detect_with_files(const TriangleMesh* given, const std::filesystem::path& suspect_path,
                               const std::filesystem::path& original_path, const std::filesystem::path& key_path,
                               const DetectFileOptions& options, const Key* given_key = nullptr)
{
    options.decision.validate();
    DetectReport report;
    detail::PhaseTimer timer(report.seconds, options.progress);

    timer.begin("read");
    const Key key = given_key != nullptr ? *given_key : read_key(key_path);
    // Both meshes are read side by side (each reader is serial); errors are still reported in
    // the order of a serial run: the key, the original, its checks, then the suspect.
    TriangleMesh original;
    TriangleMesh instances;
    std::vector<AnimationSpan> animations;
    std::array<std::exception_ptr, 2> failures;
    const auto read_original = [&] {
        try
        {
            MeshFile file = read_mesh_file(original_path);
            original = std::move(file.mesh);
            instances = std::move(file.instances);
            animations = std::move(file.animations);
        }
        catch (...)
        {
            failures[0] = std::current_exception();
        }
    };
    TriangleMesh read;
    const auto read_copy = [&] {
        try
        {
            if (given == nullptr)
            {
                read = read_mesh(suspect_path);
            }
        }
        catch (...)
        {
            failures[1] = std::current_exception();
        }
    };
    if (options.threads == 1 || given != nullptr)
    {
        read_original();
        read_copy();
    }
    else
    {
        std::thread reader(read_original);
        read_copy();
        reader.join();
    }
    if (failures[0])
    {
        std::rethrow_exception(failures[0]);
    }
    check_original(original, key, original_path);
    check_basis_input(original, key.options, original_path);
    if (failures[1])
    {
        std::rethrow_exception(failures[1]);
    }
    timer.lap("read");
    // (an animation that only moves the whole asset, a turntable, shows no other pose to read through)
    AnimatedOriginal animated{original_path, {}};
    std::copy_if(animations.begin(), animations.end(), std::back_inserter(animated.animations),
                 [](const AnimationSpan& a) { return !a.moves_only_as_a_whole; });
    detect_with_key(report, timer, key, original, instances, given != nullptr ? *given : read, suspect_path, options,
                    animated.animations.empty() ? nullptr : &animated);
    return report;
}

}  // namespace

DetectReport detect_file(const std::filesystem::path& suspect_path, const std::filesystem::path& original_path,
                         const std::filesystem::path& key_path, const DetectFileOptions& options)
{
    return detect_with_files(nullptr, suspect_path, original_path, key_path, options);
}

DetectReport detect_against_file(const TriangleMesh& suspect, const std::filesystem::path& original_path,
                                 const std::filesystem::path& key_path, const DetectFileOptions& options)
{
    validate(suspect, "suspect");
    return detect_with_files(&suspect, "suspect", original_path, key_path, options);
}

DetectReport detect_against_original(const TriangleMesh& suspect, const std::filesystem::path& original_path,
                                     const Key& key, const DetectFileOptions& options)
{
    validate(suspect, "suspect");
    return detect_with_files(&suspect, "suspect", original_path, {}, options, &key);
}

}  // namespace meshmark

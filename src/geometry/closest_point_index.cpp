// SPDX-License-Identifier: MIT
#include "meshmark/geometry/closest_point_index.h"

#include <algorithm>
#include <array>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <omp.h>

#include "meshmark/core/error.h"
#include "meshmark/core/morton.h"
#include "meshmark/core/threads.h"
#include "meshmark/geometry/point_kd_tree.h"
#include "meshmark/geometry/point_triangle.h"

// Surfaces: a hand-written bounding-volume hierarchy, not CGAL's AABB_tree, because CGAL was
// measured to be about twice as slow on the queries the metrics, ICP and resampling make. On the
// 437K-vertex dragon (871K triangles), 437K queries about 0.1% of the diagonal off the surface,
// same machine and load: CGAL 5.5 (Simple_cartesian<double>, shared-data primitive,
// accelerate_distance_queries) built in 0.63-0.65 s and answered in 1.36-1.44 s; this BVH builds
// in 0.32-0.35 s and answers in 0.63-0.68 s (docs/algorithms/metrics.md). `meshmark compare`
// makes about 5 million such queries on that mesh, so this factor is seconds per comparison.
// Where the time goes: triangles copied into leaf order (no indirection), both child boxes in
// one 64-byte node and measured together in SIMD lanes, nearer child first, and no Plane_3
// construction per triangle.
// Point clouds: PointKdTree (nanoflann's kd-tree: packaged, fast, exact nearest neighbour).

namespace meshmark
{
namespace
{

using Vec3 = Eigen::Vector3d;

// Triangles per leaf. 8 against 4 (measured side by side, docs/performance.md): the 1M-vertex
// detect's resampling (BVH build + 1M queries) 1.08-1.10 s against 1.11-1.22 s and 16 MB less
// memory; `compare` on the dragon 1-2% slower (3.07-3.13 s against 3.03-3.05 s). 16 was slower
// again. Answers do not depend on it (see TriangleBvh::closest).
constexpr std::int32_t kLeafSize = 8;
// Subtrees smaller than this are built by the thread that reached them (no new task); chosen
// by hand; no study on record.
constexpr std::int32_t kTaskGrain = 1 << 14;

/// A triangle as stored in a leaf: its corner a, its edges from a, and its face index.
/// No default member initializers: the leaf array is allocated uninitialized and filled by the
/// parallel build (value-initializing 2M triangles took 54 ms, serially, on a 1M-vertex suspect).
struct Triangle
{
    TriangleEdges shape;
    std::int32_t face;
    bool is_sliver;  ///< Zero or tiny area: see closest_point_on_triangle.
};

/// Axis-aligned box in single precision, rounded outwards so it contains its triangles exactly:
/// box distances stay lower bounds and the search stays exact, with half the memory traffic.
struct Box
{
    std::array<float, 3> lo{};
    std::array<float, 3> hi{};
};

/// Inner BVH node holding the boxes of both children, so one cache line decides which child to
/// visit first; the boxes are stored axis by axis ({child 0, child 1} pairs) so that both
/// distances are computed together in SIMD lanes. A child is an inner node (`count < 0`, index
/// `child`) or a leaf (triangles [child, child + count), possibly empty).
struct alignas(64) Node
{
    std::array<std::array<float, 2>, 3> lo{};
    std::array<std::array<float, 2>, 3> hi{};
    std::array<std::int32_t, 2> child{};
    std::array<std::int32_t, 2> count{};

    void set_box(std::size_t c, const Box& box)
    {
        for (std::size_t k = 0; k < 3; ++k)
        {
            lo[k][c] = box.lo[k];
            hi[k][c] = box.hi[k];
        }
    }
};

/// Squared distances from \p p to the boxes of both children of \p node.
Eigen::Array2d child_squared_distances(const Node& node, const Vec3& p)
{
    Eigen::Array2d d2 = Eigen::Array2d::Zero();
    for (std::size_t k = 0; k < 3; ++k)
    {
        const Eigen::Array2d x = Eigen::Array2d::Constant(p[static_cast<Eigen::Index>(k)]);
        const Eigen::Array2d lo =
            Eigen::Map<const Eigen::Array2f>(node.lo[k].data()).cast<double>();
        const Eigen::Array2d hi =
            Eigen::Map<const Eigen::Array2f>(node.hi[k].data()).cast<double>();
        const Eigen::Array2d d = (lo - x).max(x - hi).max(0.0);
        d2 += d * d;
    }
    return d2;
}

float round_down(double x)
{
    const auto f = static_cast<float>(x);
    return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                      : f;
}

float round_up(double x)
{
    const auto f = static_cast<float>(x);
    return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity())
                                      : f;
}

/// Inner nodes of a subtree over n triangles. Splits are at the median, so the layout is known in
/// advance: subtrees can be built in parallel into fixed slots, deterministically.
std::int32_t inner_nodes(std::int32_t n)
{
    if (n <= kLeafSize)
    {
        return 0;
    }
    return 1 + inner_nodes(n / 2) + inner_nodes(n - n / 2);
}

/// Median-split BVH over triangles, built once, queried concurrently.
class TriangleBvh
{
public:
    TriangleBvh(const Positions& V, const Faces& F) : V_(&V), F_(&F)
    {
        const auto face_count = static_cast<std::int32_t>(F.rows());
        items_.resize(static_cast<std::size_t>(face_count));
        // Parallel: each face writes only its own item.
#pragma omp parallel for schedule(static) num_threads(resolve_threads(0))
        for (std::int32_t f = 0; f < face_count; ++f)
        {
            const Vec3 sum = V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2));
            items_[static_cast<std::size_t>(f)] = {(sum / 3.0).cast<float>(), f};
        }
        triangles_ =
            std::make_unique_for_overwrite<Triangle[]>(static_cast<std::size_t>(face_count));
        // The root is always an inner node (a child may be an empty leaf) so queries need no
        // special case for tiny meshes.
        nodes_.resize(static_cast<std::size_t>(std::max(inner_nodes(face_count), 1)));
        Box root_box;
#pragma omp parallel num_threads(resolve_threads(0))
#pragma omp single
        build_inner(0, 0, face_count, root_box);
        items_ = {};
        V_ = nullptr;
        F_ = nullptr;
    }

    /// \brief Closest point to \p p.
    /// \details The answer is the smallest (squared distance, face index) pair over all
    /// triangles: ties between triangles at exactly the same distance (a vertex or an edge shared
    /// by several) go to the lowest face index. That rule makes the answer a function of the
    /// query and the mesh alone, whatever the tree's layout (so the build may change freely).
    [[nodiscard]] ClosestPoint closest(const Vec3& p) const
    {
        Search search{p};
        // Depth-first, nearer child first; a subtree is skipped when its box is farther than the
        // best triangle so far (a box exactly as far may still hold a lower face index). The
        // median split bounds the depth by log2(#F) < 32.
        std::array<StackEntry, 64> stack;  // deliberately not zeroed: 1 KB per query
        std::size_t top = 0;
        stack[top++] = {0, 0.0};
        while (top > 0)
        {
            const auto [index, d2] = stack[--top];
            if (d2 > search.best_d2)
            {
                continue;
            }
            const Node& node = nodes_[static_cast<std::size_t>(index)];
            const Eigen::Array2d d = child_squared_distances(node, p);
            const Eigen::Index near = d[1] < d[0] ? 1 : 0;
            const Eigen::Index far = 1 - near;
            // Leaves are searched at once (nearer first); inner children are pushed, the farther
            // one first so that the nearer one is popped next.
            for (const Eigen::Index c : {near, far})
            {
                const auto i = static_cast<std::size_t>(c);
                if (node.count[i] >= 0 && d[c] <= search.best_d2)
                {
                    search_leaf(search, node.child[i], node.count[i]);
                }
            }
            for (const Eigen::Index c : {far, near})
            {
                const auto i = static_cast<std::size_t>(c);
                if (node.count[i] < 0 && d[c] <= search.best_d2)
                {
                    stack[top++] = {node.child[i], d[c]};
                }
            }
        }
        ClosestPoint result;
        result.point = search.best_point;
        result.distance = (search.best_point - p).norm();
        result.face = search.best_face;
        return result;
    }

private:
    /// A subtree waiting to be visited, with the squared distance to its box.
    struct StackEntry
    {
        std::int32_t node;
        double d2;
    };

    struct Search
    {
        Vec3 p;
        double best_d2 = std::numeric_limits<double>::infinity();
        Vec3 best_point = Vec3::Zero();
        std::int32_t best_face = -1;
    };

    void search_leaf(Search& search, std::int32_t first, std::int32_t count) const
    {
        for (std::int32_t i = first; i < first + count; ++i)
        {
            const Triangle& t = triangles_[static_cast<std::size_t>(i)];
            const Vec3 q = closest_point_on_triangle(search.p, t.shape, t.is_sliver);
            const double q2 = (q - search.p).squaredNorm();
            // The smallest (distance, face) pair: see closest().
            if (search.best_face < 0 || q2 < search.best_d2 ||
                (q2 == search.best_d2 && t.face < search.best_face))
            {
                search.best_d2 = q2;
                search.best_point = q;
                search.best_face = t.face;
            }
        }
    }

    // Builds the inner node `index` over items [begin, end) and its inner descendants, which take
    // the slots after it (left subtree first), lays out the triangles of its leaves, and stores
    // the subtree's box in `box` (boxes are merged bottom-up, so each triangle is read once).
    void build_inner(std::int32_t index, std::int32_t begin, std::int32_t end, Box& box)
    {
        const std::int32_t n = end - begin;
        const std::int32_t middle = begin + n / 2;
        split_at_median(begin, middle, end);
        Node& node = nodes_[static_cast<std::size_t>(index)];
        const std::array<std::int32_t, 3> bounds = {begin, middle, end};
        const std::array<std::int32_t, 2> slot = {index + 1,
                                                  index + 1 + inner_nodes(middle - begin)};
        for (std::size_t c = 0; c < 2; ++c)
        {
            const std::int32_t size = bounds[c + 1] - bounds[c];
            const bool is_leaf = size <= kLeafSize;
            node.child[c] = is_leaf ? bounds[c] : slot[c];
            node.count[c] = is_leaf ? size : -1;
        }
        std::array<Box, 2> boxes;
        if (node.count[0] >= 0)
        {
            boxes[0] = build_leaf(begin, middle);
        }
        else if (n >= kTaskGrain)
        {
#pragma omp task default(shared) firstprivate(slot, begin, middle)
            build_inner(slot[0], begin, middle, boxes[0]);
        }
        else
        {
            build_inner(slot[0], begin, middle, boxes[0]);
        }
        if (node.count[1] >= 0)
        {
            boxes[1] = build_leaf(middle, end);
        }
        else
        {
            build_inner(slot[1], middle, end, boxes[1]);
        }
#pragma omp taskwait
        for (std::size_t c = 0; c < 2; ++c)
        {
            node.set_box(c, boxes[c]);
        }
        for (std::size_t k = 0; k < 3; ++k)
        {
            box.lo[k] = std::min(boxes[0].lo[k], boxes[1].lo[k]);
            box.hi[k] = std::max(boxes[0].hi[k], boxes[1].hi[k]);
        }
    }

    // Copies the triangles of items [begin, end) into leaf order and returns their box, rounded
    // outwards to single precision (an empty leaf gets an empty box, infinitely far away).
    Box build_leaf(std::int32_t begin, std::int32_t end)
    {
        Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
        Vec3 hi = -lo;
        for (std::int32_t i = begin; i < end; ++i)
        {
            const std::int32_t f = items_[static_cast<std::size_t>(i)].face;
            const Vec3 a = V_->row((*F_)(f, 0)).transpose();
            const Vec3 b = V_->row((*F_)(f, 1)).transpose();
            const Vec3 c = V_->row((*F_)(f, 2)).transpose();
            triangles_[static_cast<std::size_t>(i)] = {
                {a, b - a, c - a}, f, is_sliver_triangle(a, b, c)};
            lo = lo.cwiseMin(a).cwiseMin(b).cwiseMin(c);
            hi = hi.cwiseMax(a).cwiseMax(b).cwiseMax(c);
        }
        Box box;
        for (std::size_t k = 0; k < 3; ++k)
        {
            box.lo[k] = round_down(lo[static_cast<Eigen::Index>(k)]);
            box.hi[k] = round_up(hi[static_cast<Eigen::Index>(k)]);
        }
        return box;
    }

    // Partitions items [begin, end) around the median centroid along the longest axis of their
    // centroids' extent; ties are broken by face index, so the split is a total order.
    void split_at_median(std::int32_t begin, std::int32_t middle, std::int32_t end)
    {
        const auto first = items_.begin() + begin;
        const auto last = items_.begin() + end;
        Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::infinity());
        Eigen::Vector3f hi = -lo;
        for (auto it = first; it != last; ++it)
        {
            lo = lo.cwiseMin(it->centroid);
            hi = hi.cwiseMax(it->centroid);
        }
        Eigen::Index axis = 0;
        (hi - lo).maxCoeff(&axis);
        std::nth_element(
            first, items_.begin() + middle, last,
            [axis](const BuildItem& x, const BuildItem& y) {
                return std::pair{x.centroid[axis], x.face} < std::pair{y.centroid[axis], y.face};
            });
    }

    /// A face during the build: its centroid (the split key) and index. Single precision halves
    /// the bytes the median splits move; the split only shapes the tree (the queries' answers do
    /// not depend on it, see closest()).
    struct BuildItem
    {
        Eigen::Vector3f centroid;
        std::int32_t face = -1;
    };

    std::unique_ptr<Triangle[]> triangles_;  // In leaf order.
    std::vector<Node> nodes_;                // Inner nodes, root first, depth-first order.
    std::vector<BuildItem> items_;           // Only during the build, as are V_ and F_.
    const Positions* V_ = nullptr;
    const Faces* F_ = nullptr;
};

}  // namespace

struct ClosestPointIndex::Impl
{
    std::unique_ptr<PointKdTree> cloud;
    std::unique_ptr<TriangleBvh> surface;

    explicit Impl(const TriangleMesh& mesh)
    {
        if (mesh.F.rows() > 0)
        {
            surface = std::make_unique<TriangleBvh>(mesh.V, mesh.F);
            return;
        }
        cloud = std::make_unique<PointKdTree>(mesh.V);
    }

    [[nodiscard]] ClosestPoint closest_in_cloud(const Vec3& query) const
    {
        double squared = 0.0;
        const std::uint32_t index = cloud->nearest(query, squared);
        ClosestPoint result;
        result.point = cloud->points().row(static_cast<Eigen::Index>(index)).transpose();
        result.distance = (result.point - query).norm();
        result.vertex = static_cast<std::int32_t>(index);
        return result;
    }
};

ClosestPointIndex::ClosestPointIndex(const TriangleMesh& mesh)
{
    if (mesh.V.rows() == 0)
    {
        throw InvalidMesh("ClosestPointIndex: the mesh has no vertices.");
    }
    if (mesh.F.rows() > std::numeric_limits<std::int32_t>::max() / 2)
    {
        throw InvalidMesh(
            "ClosestPointIndex: the mesh has too many faces for 32-bit node indices.");
    }
    impl_ = std::make_unique<Impl>(mesh);
}

ClosestPointIndex::~ClosestPointIndex() = default;
ClosestPointIndex::ClosestPointIndex(ClosestPointIndex&&) noexcept = default;
ClosestPointIndex& ClosestPointIndex::operator=(ClosestPointIndex&&) noexcept = default;

ClosestPoint ClosestPointIndex::closest(const Eigen::Vector3d& query) const
{
    return impl_->surface ? impl_->surface->closest(query) : impl_->closest_in_cloud(query);
}

namespace
{

// Batches smaller than this keep their order: the Z-order sort pays off on large shuffled
// batches (1.7M: 6.4 -> 3.7 s, commit 6113c79); the 65536 itself chosen by hand; no study on
// record.
constexpr std::int64_t kScatteredMinimum = 65536;
// Mean step between consecutive queries, as a fraction of the bbox diagonal, above which a batch
// is scattered: far above a file's coherent step (0.1-0.3%), far below a shuffle's (about 50%).
constexpr double kScatteredStep = 0.02;
// Bits per axis of the Z-order key: chosen by hand; no study on record.
constexpr int kZOrderBits = 10;

// True when consecutive queries are far apart on average: over 4096 evenly spread pairs
// (i, i + 1), a mean step above 2% of the bounding-box diagonal. A mesh file in scan or
// subdivision order steps by about an edge length (0.1-0.3% of the diagonal at 1M vertices,
// with a jump per strip); a shuffled one by about half the diagonal.
bool is_scattered(const Positions& P)
{
    const Eigen::Index n = P.rows();
    constexpr Eigen::Index kPairs = 4096;
    const double diagonal = (P.colwise().maxCoeff() - P.colwise().minCoeff()).norm();
    if (n < 2 || !(diagonal > 0.0))
    {
        return false;
    }
    double steps = 0.0;
    Eigen::Index pairs = 0;
    for (Eigen::Index j = 0; j < kPairs; ++j)
    {
        const Eigen::Index i = j * (n - 1) / kPairs;
        steps += (P.row(i + 1) - P.row(i)).norm();
        ++pairs;
    }
    return steps / static_cast<double>(pairs) > kScatteredStep * diagonal;
}

}  // namespace

std::vector<ClosestPoint> ClosestPointIndex::closest(const Positions& queries, int threads) const
{
    const auto count = static_cast<std::int64_t>(queries.rows());
    std::vector<ClosestPoint> results(static_cast<std::size_t>(count));
    // Queries in a scattered order (a shuffled file) make every search start cold: answer them
    // in Z order instead (the answers are the same: ties go to the lowest face index whatever
    // the traversal). Measured on a 1.7M-vertex shuffled original: 6.4 -> 3.7 s; an already
    // coherent order keeps its own (the sort would cost 5-8% of the queries at 1M).
    const std::vector<std::size_t> order = count >= kScatteredMinimum && is_scattered(queries)
                                               ? morton_order(queries, kZOrderBits)
                                               : std::vector<std::size_t>{};
    // Each query writes only its own slot, so the output does not depend on the schedule.
#pragma omp parallel for schedule(dynamic, 256) num_threads(resolve_threads(threads))
    for (std::int64_t k = 0; k < count; ++k)
    {
        const auto i =
            order.empty() ? static_cast<std::size_t>(k) : order[static_cast<std::size_t>(k)];
        results[i] = closest(Vec3(queries.row(static_cast<Eigen::Index>(i)).transpose()));
    }
    return results;
}

bool ClosestPointIndex::is_point_cloud() const noexcept
{
    return impl_->cloud != nullptr;
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// Awkward geometry made from a real mesh by the test itself (issue 52): non-manifold edges
// (fins: a third face on 200 edges) and vertices (the mesh and its mirror image pinched at one
// vertex), an open thin shell (half the mesh doubled 1e-4 of the diagonal apart), duplicated
// and reversed faces, degenerate faces (repeated corners and collinear needles), isolated
// vertices, many disconnected parts, a part collapsed to a point (zero area), coincident
// vertices (a triangle soup), and all of these at once. Fixed seed: the same variants every run.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "meshmark/core/rng.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark::test
{

using Variant = std::pair<std::string, TriangleMesh>;

inline Eigen::RowVector3d face_normal(const TriangleMesh& m, Eigen::Index f)
{
    const Eigen::RowVector3d a = m.V.row(m.F(f, 0));
    const Eigen::RowVector3d n = (m.V.row(m.F(f, 1)) - a).cross(m.V.row(m.F(f, 2)) - a);
    return n.norm() > 0.0 ? Eigen::RowVector3d(n / n.norm()) : Eigen::RowVector3d::Zero();
}

// \p a with \p b appended (b's indices shifted).
inline TriangleMesh joined(const TriangleMesh& a, const TriangleMesh& b)
{
    TriangleMesh m;
    m.V.resize(a.V.rows() + b.V.rows(), 3);
    m.V << a.V, b.V;
    m.F.resize(a.F.rows() + b.F.rows(), 3);
    m.F << a.F, (b.F.array() + static_cast<int>(a.V.rows())).matrix();
    return m;
}

inline void add_faces(TriangleMesh& m, const std::vector<Eigen::RowVector3i>& faces)
{
    const Eigen::Index first = m.F.rows();
    m.F.conservativeResize(first + static_cast<Eigen::Index>(faces.size()), 3);
    for (std::size_t k = 0; k < faces.size(); ++k)
    {
        m.F.row(first + static_cast<Eigen::Index>(k)) = faces[k];
    }
}

/// The awkward variants of \p scan, each with its name (see the file comment).
inline std::vector<Variant> awkward_variants(const TriangleMesh& scan)
{
    Rng rng(52);
    const double diagonal = (scan.V.colwise().maxCoeff() - scan.V.colwise().minCoeff()).norm();
    const Eigen::RowVector3d centre = scan.V.colwise().mean();
    const auto faces = scan.F.rows();
    const auto vertices = scan.V.rows();
    const auto pick = [&](Eigen::Index n)
    { return static_cast<Eigen::Index>(rng.uniform(0.0, 1.0) * static_cast<double>(n)) % n; };
    std::vector<Variant> out;

    TriangleMesh fins = scan;  // a third face on 200 edges: non-manifold edges
    std::vector<Eigen::RowVector3i> fin_faces;
    for (int k = 0; k < 200; ++k)
    {
        const Eigen::Index f = pick(faces);
        const Eigen::RowVector3d tip = 0.5 * (scan.V.row(scan.F(f, 0)) + scan.V.row(scan.F(f, 1))) +
                                       0.01 * diagonal * face_normal(scan, f);
        fins.V.conservativeResize(fins.V.rows() + 1, 3);
        fins.V.row(fins.V.rows() - 1) = tip;
        fin_faces.emplace_back(scan.F(f, 0), scan.F(f, 1), static_cast<int>(fins.V.rows() - 1));
    }
    add_faces(fins, fin_faces);
    out.emplace_back("fins", fins);

    TriangleMesh mirrored = scan;  // the scan mirrored through vertex 0, sharing that vertex
    for (Eigen::Index i = 0; i < vertices; ++i)
    {
        mirrored.V.row(i) = 2.0 * scan.V.row(0) - scan.V.row(i);
    }
    TriangleMesh pinched = joined(scan, mirrored);
    for (Eigen::Index f = faces; f < pinched.F.rows(); ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            pinched.F(f, c) = pinched.F(f, c) == vertices ? 0 : pinched.F(f, c);
        }
    }
    out.emplace_back("pinched", pinched);

    TriangleMesh half;  // the half of the scan on one side, doubled 1e-4 of the diagonal apart
    half.V = scan.V;
    std::vector<Eigen::RowVector3i> kept;
    for (Eigen::Index f = 0; f < faces; ++f)
    {
        if (scan.V.row(scan.F(f, 0)).x() < centre.x())
        {
            kept.emplace_back(scan.F.row(f));
        }
    }
    add_faces(half, kept);
    TriangleMesh inner = half;
    inner.V.array() += 1e-4 * diagonal;
    inner.F.col(1).swap(inner.F.col(2));
    out.emplace_back("thin_shell", joined(half, inner));

    TriangleMesh duplicated = scan;  // 5% of the faces twice, half of them reversed
    std::vector<Eigen::RowVector3i> again;
    for (Eigen::Index k = 0; k < faces / 20; ++k)
    {
        Eigen::RowVector3i t = scan.F.row(pick(faces));
        if (k % 2 == 1)
        {
            std::swap(t(1), t(2));
        }
        again.push_back(t);
    }
    add_faces(duplicated, again);
    out.emplace_back("duplicated", duplicated);

    // 1% repeated corners, 1% needles (a corner on the opposite edge).
    TriangleMesh degenerate = scan;
    for (Eigen::Index k = 0; k < faces / 100; ++k)
    {
        degenerate.F(pick(faces), 2) = degenerate.F(pick(faces), 0);
        const Eigen::Index f = pick(faces);
        degenerate.V.row(degenerate.F(f, 2)) =
            0.5 * (degenerate.V.row(degenerate.F(f, 0)) + degenerate.V.row(degenerate.F(f, 1)));
    }
    out.emplace_back("degenerate", degenerate);

    TriangleMesh isolated = scan;  // 300 vertices no face uses
    isolated.V.conservativeResize(vertices + 300, 3);
    for (Eigen::Index i = vertices; i < isolated.V.rows(); ++i)
    {
        isolated.V.row(i) =
            centre + diagonal * Eigen::RowVector3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5),
                                                   rng.uniform(-0.5, 0.5));
    }
    out.emplace_back("isolated", isolated);

    TriangleMesh parts = scan;  // 20 small copies scattered around
    for (int k = 0; k < 20; ++k)
    {
        TriangleMesh small = scan;
        const Eigen::RowVector3d offset(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0),
                                        rng.uniform(-1.0, 1.0));
        for (Eigen::Index i = 0; i < vertices; ++i)
        {
            small.V.row(i) = centre + 0.1 * (scan.V.row(i) - centre) + diagonal * offset;
        }
        parts = joined(parts, small);
    }
    out.emplace_back("many_parts", parts);

    TriangleMesh collapsed = scan;  // a second copy with every vertex at one point
    collapsed.V.rowwise() = scan.V.row(0);
    out.emplace_back("zero_area_part", joined(scan, collapsed));

    TriangleMesh soup;  // every face with corners of its own: coincident vertices everywhere
    soup.V.resize(3 * faces, 3);
    soup.F.resize(faces, 3);
    for (Eigen::Index f = 0; f < faces; ++f)
    {
        for (int c = 0; c < 3; ++c)
        {
            soup.V.row(3 * f + c) = scan.V.row(scan.F(f, c));
            soup.F(f, c) = static_cast<int>(3 * f + c);
        }
    }
    out.emplace_back("soup", soup);

    TriangleMesh everything = joined(joined(degenerate, collapsed), fins);
    add_faces(everything, again);
    out.emplace_back("everything", everything);
    return out;
}

}  // namespace meshmark::test

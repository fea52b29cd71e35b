// SPDX-License-Identifier: MIT
#include "meshmark/geometry/normals.h"

#include <Eigen/Geometry>

namespace meshmark
{
namespace
{

// Unnormalized normal of face f: twice its area times its unit normal.
Eigen::Vector3d face_cross(const TriangleMesh& mesh, Eigen::Index f)
{
    const Eigen::Vector3d a = mesh.V.row(mesh.F(f, 0)).transpose();
    const Eigen::Vector3d b = mesh.V.row(mesh.F(f, 1)).transpose();
    const Eigen::Vector3d c = mesh.V.row(mesh.F(f, 2)).transpose();
    return (b - a).cross(c - a);
}

// Normalize the rows in place; rows of zero length stay zero instead of becoming NaN.
void normalize_rows(Positions& N)
{
    for (Eigen::Index i = 0; i < N.rows(); ++i)
    {
        const double length = N.row(i).norm();
        if (length > 0.0)
        {
            N.row(i) /= length;
        }
    }
}

}  // namespace

Positions face_normals(const TriangleMesh& mesh)
{
    Positions N(mesh.F.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        N.row(f) = face_cross(mesh, f).transpose();
    }
    normalize_rows(N);
    return N;
}

Eigen::VectorXd face_areas(const TriangleMesh& mesh)
{
    Eigen::VectorXd areas(mesh.F.rows());
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        areas(f) = 0.5 * face_cross(mesh, f).norm();
    }
    return areas;
}

double surface_area(const TriangleMesh& mesh)
{
    double total = 0.0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        total += 0.5 * face_cross(mesh, f).norm();
    }
    return total;
}

Positions vertex_normals(const TriangleMesh& mesh)
{
    // Scatter each face's cross product (length = twice its area) to its corners, in face order.
    Positions N = Positions::Zero(mesh.V.rows(), 3);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    {
        const Eigen::RowVector3d n = face_cross(mesh, f).transpose();
        for (int c = 0; c < 3; ++c)
        {
            N.row(mesh.F(f, c)) += n;
        }
    }
    normalize_rows(N);
    return N;
}

}  // namespace meshmark

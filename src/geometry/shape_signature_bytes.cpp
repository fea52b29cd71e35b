// SPDX-License-Identifier: MIT
// A shape signature's stored form: the views' features as bytes, then the points' section.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>

#include "meshmark/core/error.h"
#include "meshmark/geometry/shape_signature.h"

namespace meshmark
{

std::vector<std::uint8_t> ShapeSignature::to_bytes() const
{
    std::vector<std::uint8_t> bytes;
    bytes.reserve(views.size() * kShapeFeatures + kShapePointBytes);
    for (const ShapeFeatures& view : views)
    {
        for (const float x : view)
        {
            bytes.push_back(
                static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0F, 1.0F) * 255.0F)));
        }
    }
    if (points.rows() != kShapePoints || normals.rows() != kShapePoints)
    {
        return bytes;  // no points (a mesh without area draws none), or an older signature
    }
    // The box in single precision, each point as 16-bit fractions of it: 1/65,535 of the box,
    // far below the draw's spacing.
    const Eigen::Vector3f low = points.colwise().minCoeff().cast<float>().transpose();
    const Eigen::Vector3f size =
        (points.colwise().maxCoeff().cast<float>().transpose() - low).cwiseMax(1e-30F);
    const auto put_float = [&](float x)
    {
        std::array<std::uint8_t, sizeof(float)> raw{};
        std::memcpy(raw.data(), &x, sizeof(float));
        bytes.insert(bytes.end(), raw.begin(), raw.end());  // the machine's order: little-endian
    };
    for (int k = 0; k < 3; ++k)
    {
        put_float(low[k]);
    }
    for (int k = 0; k < 3; ++k)
    {
        put_float(size[k]);
    }
    for (Eigen::Index i = 0; i < points.rows(); ++i)
    {
        for (int k = 0; k < 3; ++k)
        {
            const double t = (points(i, k) - static_cast<double>(low[k])) / size[k];
            const auto q =
                static_cast<std::uint16_t>(std::lround(std::clamp(t, 0.0, 1.0) * 65535.0));
            bytes.push_back(static_cast<std::uint8_t>(q & 0xFFU));
            bytes.push_back(static_cast<std::uint8_t>(q >> 8U));
        }
        for (int k = 0; k < 3; ++k)
        {
            const auto q =
                static_cast<std::int8_t>(std::lround(std::clamp(normals(i, k), -1.0, 1.0) * 127.0));
            bytes.push_back(static_cast<std::uint8_t>(q));
        }
    }
    return bytes;
}

void ShapeSignature::points_from_bytes(std::span<const std::uint8_t> bytes, Positions& points,
                                       Positions& normals)
{
    if (bytes.size() != kShapePointBytes)
    {
        throw InvalidOption("a shape signature's points of " + std::to_string(bytes.size()) +
                            " bytes, not " + std::to_string(kShapePointBytes) + ".");
    }
    std::array<float, 6> box{};
    std::memcpy(box.data(), bytes.data(), sizeof(box));
    const std::uint8_t* at = bytes.data() + sizeof(box);
    points.resize(kShapePoints, 3);
    normals.resize(kShapePoints, 3);
    for (Eigen::Index i = 0; i < kShapePoints; ++i)
    {
        for (int k = 0; k < 3; ++k, at += 2)
        {
            const auto q = static_cast<unsigned>(at[0]) | (static_cast<unsigned>(at[1]) << 8U);
            points(i, k) = static_cast<double>(box[static_cast<std::size_t>(k)]) +
                           static_cast<double>(q) / 65535.0 *
                               static_cast<double>(box[static_cast<std::size_t>(k) + 3]);
        }
        Eigen::Vector3d n;
        for (int k = 0; k < 3; ++k, ++at)
        {
            n[k] = static_cast<double>(static_cast<std::int8_t>(*at)) / 127.0;
        }
        const double length = n.norm();
        normals.row(i) = (length > 0.0 ? Eigen::Vector3d(n / length) : n).transpose();
    }
}

ShapeSignature ShapeSignature::from_bytes(std::span<const std::uint8_t> bytes)
{
    constexpr std::size_t kViewBytes = kShapeFeatures;
    constexpr std::size_t kWithPoints = kShapeViews * kViewBytes + kShapePointBytes;
    ShapeSignature signature;
    if (bytes.size() == kWithPoints)
    {
        points_from_bytes(bytes.subspan(kShapeViews * kViewBytes), signature.points,
                          signature.normals);
        bytes = bytes.first(kShapeViews * kViewBytes);
    }
    if (bytes.size() % kViewBytes != 0)
    {
        throw InvalidOption("a shape signature of " + std::to_string(bytes.size()) +
                            " bytes is not a whole number of views.");
    }
    signature.views.resize(bytes.size() / kViewBytes);
    for (std::size_t v = 0; v < signature.views.size(); ++v)
    {
        for (std::size_t i = 0; i < kShapeFeatures; ++i)
        {
            signature.views[v][i] = static_cast<float>(bytes[v * kViewBytes + i]) / 255.0F;
        }
    }
    return signature;
}

}  // namespace meshmark

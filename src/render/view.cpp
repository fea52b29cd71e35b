// SPDX-License-Identifier: MIT
#include "meshmark/render/view.h"

#include <charconv>
#include <cmath>
#include <numbers>
#include <optional>
#include <utility>

#include <Eigen/Geometry>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

template <class Number>
std::optional<Number> parse_number(std::string_view text)
{
    Number value{};
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || text.empty())
    {
        return std::nullopt;
    }
    return value;
}

}  // namespace

ViewAngles parse_view(const std::string& text)
{
    struct Named
    {
        const char* name;
        ViewAngles view;
    };
    // Elevation of the cube's diagonal: atan(1 / sqrt(2)).
    const double iso_elevation = std::atan(1.0 / std::sqrt(2.0)) * 180.0 / std::numbers::pi;
    const Named named[] = {{"front34", kDefaultView}, {"front", {0.0, 0.0}},
                           {"back", {180.0, 0.0}},    {"left", {-90.0, 0.0}},
                           {"right", {90.0, 0.0}},    {"top", {0.0, 90.0}},
                           {"bottom", {0.0, -90.0}},  {"iso", {45.0, iso_elevation}}};
    for (const Named& n : named)
    {
        if (text == n.name)
        {
            return n.view;
        }
    }
    const std::size_t comma = text.find(',');
    if (comma != std::string::npos)
    {
        const auto azimuth = parse_number<double>(std::string_view(text).substr(0, comma));
        const auto elevation = parse_number<double>(std::string_view(text).substr(comma + 1));
        if (azimuth && elevation && std::isfinite(*azimuth) && std::isfinite(*elevation))
        {
            if (std::abs(*elevation) > 90.0)
            {
                throw InvalidOption("view '" + text +
                                    "' has an elevation outside [-90, 90] degrees.");
            }
            return {*azimuth, *elevation};
        }
    }
    throw InvalidOption("unknown view '" + text + "' (expected " + std::string(kViewNames) +
                        ", or AZIMUTH,ELEVATION in degrees such as 30,20).");
}

UpAxis parse_up_axis(const std::string& text)
{
    const std::string axis = !text.empty() && text.front() == '+' ? text.substr(1) : text;
    const std::pair<const char*, UpAxis> names[] = {{"y", UpAxis::PosY},  {"z", UpAxis::PosZ},
                                                    {"x", UpAxis::PosX},  {"-y", UpAxis::NegY},
                                                    {"-z", UpAxis::NegZ}, {"-x", UpAxis::NegX}};
    for (const auto& [name, value] : names)
    {
        if (axis == name)
        {
            return value;
        }
    }
    throw InvalidOption("up axis '" + text + "' is not one of y, z, x, -y, -z, -x.");
}

namespace
{

// The rotation taking the +Y-up, +Z-front convention to \p up and its front: its columns are
// the images of X (up x front), Y (up) and Z (front).
Eigen::Matrix3d up_rotation(UpAxis up)
{
    Eigen::Vector3d u = Eigen::Vector3d::UnitY();
    Eigen::Vector3d f = Eigen::Vector3d::UnitZ();
    switch (up)
    {
        case UpAxis::PosY:
            break;
        case UpAxis::PosZ:
            u = Eigen::Vector3d::UnitZ();
            f = -Eigen::Vector3d::UnitY();
            break;
        case UpAxis::PosX:
            u = Eigen::Vector3d::UnitX();
            f = Eigen::Vector3d::UnitZ();
            break;
        case UpAxis::NegY:
            u = -Eigen::Vector3d::UnitY();
            f = -Eigen::Vector3d::UnitZ();
            break;
        case UpAxis::NegZ:
            u = -Eigen::Vector3d::UnitZ();
            f = Eigen::Vector3d::UnitY();
            break;
        case UpAxis::NegX:
            u = -Eigen::Vector3d::UnitX();
            f = Eigen::Vector3d::UnitZ();
            break;
    }
    Eigen::Matrix3d rotation;
    rotation << u.cross(f), u, f;
    return rotation;
}

}  // namespace

ViewFrame view_frame(const ViewAngles& view, UpAxis up)
{
    const double az = view.azimuth_deg * std::numbers::pi / 180.0;
    const double el = view.elevation_deg * std::numbers::pi / 180.0;
    ViewFrame frame;
    frame.toward =
        Eigen::Vector3d(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));
    frame.right = Eigen::Vector3d(std::cos(az), 0.0, -std::sin(az));
    frame.up = frame.toward.cross(frame.right);
    if (up != UpAxis::PosY)
    {
        const Eigen::Matrix3d rotation = up_rotation(up);
        frame.toward = rotation * frame.toward;
        frame.right = rotation * frame.right;
        frame.up = rotation * frame.up;
    }
    return frame;
}

ImageSize parse_image_size(const std::string& text)
{
    const std::size_t x = text.find_first_of("xX");
    if (x != std::string::npos)
    {
        const auto width = parse_number<int>(std::string_view(text).substr(0, x));
        const auto height = parse_number<int>(std::string_view(text).substr(x + 1));
        if (width && height)
        {
            if (*width < kMinImageSide || *height < kMinImageSide || *width > kMaxImageSide ||
                *height > kMaxImageSide)
            {
                throw InvalidOption("image size '" + text + "' is outside " +
                                    std::to_string(kMinImageSide) + " to " +
                                    std::to_string(kMaxImageSide) + " pixels per side.");
            }
            return {*width, *height};
        }
    }
    throw InvalidOption("image size '" + text + "' is not WIDTHxHEIGHT in pixels (e.g. 1024x768).");
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <string>

#include <Eigen/Core>

namespace meshmark
{

/// \brief Direction a model is seen from, with +Y up and the front facing +Z (the convention of
/// the Stanford scans and most OBJ/PLY models).
/// \details The camera sits at azimuth \p azimuth_deg around the Y axis, measured from the front
/// (+Z) towards the right (+X), and \p elevation_deg above the XZ plane (90 looks straight down).
struct ViewAngles
{
    double azimuth_deg = 30.0;
    double elevation_deg = 20.0;
};

/// The default view: the front, turned 30 degrees to the right and 20 degrees from above.
inline constexpr ViewAngles kDefaultView{30.0, 20.0};

/// The names parse_view accepts, for help texts.
inline constexpr const char* kViewNames =
    "front34 (the default), front, back, left, right, top, bottom, iso";

/// \brief A view by name (kViewNames) or as "AZIMUTH,ELEVATION" in degrees (e.g. "30,20").
/// \details front = 0,0; back = 180,0; left = -90,0; right = 90,0; top = 0,90; bottom = 0,-90;
/// iso = 45,35.26 (the cube diagonal); front34 = 30,20.
/// \throws InvalidOption with one sentence naming \p text when it is neither, or when the
/// elevation is outside [-90, 90] or a number is not finite.
[[nodiscard]] ViewAngles parse_view(const std::string& text);

/// \brief The orthonormal camera frame of a view: \p right and \p up span the image plane
/// (right to the right, up to the top of the image); \p toward points from the model to the
/// camera. Well defined at the poles (top, bottom): right stays horizontal.
struct ViewFrame
{
    Eigen::Vector3d right;
    Eigen::Vector3d up;
    Eigen::Vector3d toward;
};
/// \brief The model's up axis; the views above are then taken about it. Each axis comes with
/// the front the usual tools give it: +Y up, front +Z (the default: Stanford scans, most OBJ
/// and PLY, glTF); +Z up, front -Y (Blender, CAD, 3D printing: STL, 3MF); +X up, front +Z;
/// -Y up, front -Z; -Z up, front +Y; -X up, front +Z.
enum class UpAxis
{
    PosY,
    PosZ,
    PosX,
    NegY,
    NegZ,
    NegX,
};

/// \brief "y", "z", "x", "-y", "-z" or "-x" (also with a leading '+').
/// \throws InvalidOption with one sentence naming \p text for anything else.
[[nodiscard]] UpAxis parse_up_axis(const std::string& text);

/// \brief The camera frame of \p view for a model whose up axis is \p up.
[[nodiscard]] ViewFrame view_frame(const ViewAngles& view, UpAxis up = UpAxis::PosY);

/// An image size in pixels.
struct ImageSize
{
    int width = 1024;
    int height = 768;
};

/// Smallest and largest accepted image sides (the largest bounds the buffers at 8192^2
/// pixels); chosen by hand; no study on record.
inline constexpr int kMinImageSide = 160;
inline constexpr int kMaxImageSide = 8192;

/// \brief An image size written "WIDTHxHEIGHT" (e.g. "1024x768").
/// \throws InvalidOption naming \p text unless both sides are integers in
/// [kMinImageSide, kMaxImageSide].
[[nodiscard]] ImageSize parse_image_size(const std::string& text);

}  // namespace meshmark

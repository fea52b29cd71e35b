// SPDX-License-Identifier: MIT
#pragma once

#include <Eigen/Core>

#include "meshmark/core/triangle_mesh.h"
#include "meshmark/render/image.h"
#include "meshmark/render/view.h"

namespace meshmark
{

/// Options of render_heatmap.
struct HeatmapImageOptions
{
    ImageSize size;                  ///< Of the whole picture, colour bar included.
    ViewAngles view = kDefaultView;  ///< Direction the model is seen from (parse_view).
    UpAxis up = UpAxis::PosY;        ///< The model's up axis (parse_up_axis).
    /// Distance drawn in red (the top of the colour bar); 0 = the largest distance of a drawn
    /// vertex.
    double max_distance = 0.0;
    /// Length the colour bar's labels count as 100% (e.g. the bounding-box diagonal of the
    /// reference mesh); 0 = the bounding-box diagonal of the drawn vertices.
    double unit_length = 0.0;
    int supersampling =
        2;            ///< Samples per pixel along each axis (1 to 4), averaged: anti-aliasing.
    int threads = 0;  ///< Worker threads (0 = all cores); the picture does not depend on it.

    /// \throws InvalidOption naming the field when a value is out of range.
    void validate() const;
};

/// Where the parts of a heatmap picture are, in pixels of the final image.
struct HeatmapLayout
{
    int model_width = 0;  ///< The model is drawn in columns [0, model_width).
    int bar_x0 = 0;       ///< The colour bar fills [bar_x0, bar_x1) x [bar_y0, bar_y1):
    int bar_x1 = 0;       ///< red at the top, blue at the bottom.
    int bar_y0 = 0;
    int bar_y1 = 0;
    int text_scale = 1;  ///< Font pixels are text_scale x text_scale image pixels.
};

/// \brief The layout of a picture of \p size.
[[nodiscard]] HeatmapLayout heatmap_layout(const ImageSize& size);

/// What render_heatmap drew.
struct HeatmapPicture
{
    RgbImage image;
    HeatmapLayout layout;
    double max_distance = 0.0;  ///< The distance drawn in red, in the mesh's units.
    double unit_length = 0.0;   ///< The length the labels count as 100%.
};

/// \brief A picture of \p mesh coloured by \p distances, as in the distance figures of mesh
/// watermarking papers: the surface with headlight Lambert shading (two-sided), coloured by
/// heat_color(distance / max_distance) interpolated across each triangle, on a white
/// background, seen orthographically from \p options.view and fitted to the model area, with a
/// colour bar labelled in % of \p options.unit_length.
/// \details Drawn by the software rasterizer (rasterize_triangles), \p options.supersampling
/// squared samples per pixel. A point cloud is drawn as discs shaded as little spheres, sized
/// from the median spacing of its points. Only referenced vertices (referenced_vertices) count
/// for the framing and the default maximum. The same inputs give the same pixels for any
/// thread count.
/// \param distances One non-negative distance per vertex of \p mesh.
/// \throws InvalidOption for bad options or a distance count that is not the vertex count,
/// InvalidMesh for a mesh with nothing to draw.
[[nodiscard]] HeatmapPicture render_heatmap(const TriangleMesh& mesh,
                                            const Eigen::VectorXd& distances,
                                            const HeatmapImageOptions& options = {});

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#pragma once

#include <string>

#include "meshmark/render/image.h"

namespace meshmark::detail
{

/// \brief Width and height in pixels of \p text drawn by draw_text at \p scale.
[[nodiscard]] int text_width(const std::string& text, int scale);
[[nodiscard]] int text_height(const std::string& text, int scale);

/// \brief Draw ASCII \p text with its top-left corner at (\p x, \p y), each font pixel a
/// \p scale x \p scale square, clipped to the image (stb_easy_font's bitmap font).
void draw_text(RgbImage& image, int x, int y, const std::string& text, int scale, Rgb8 color);

}  // namespace meshmark::detail

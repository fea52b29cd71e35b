// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "meshmark/metrics/heatmap.h"

namespace meshmark
{

/// \brief An 8-bit RGB image, rows top to bottom, three bytes per pixel.
struct RgbImage
{
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> pixels;  ///< width * height * 3 bytes.

    RgbImage() = default;
    /// A \p width x \p height image filled with \p fill.
    RgbImage(int width, int height, Rgb8 fill);

    [[nodiscard]] Rgb8 at(int x, int y) const
    {
        const std::size_t i = index(x, y);
        return {pixels[i], pixels[i + 1], pixels[i + 2]};
    }
    void set(int x, int y, Rgb8 color)
    {
        const std::size_t i = index(x, y);
        pixels[i] = color[0];
        pixels[i + 1] = color[1];
        pixels[i + 2] = color[2];
    }
    /// Fills the rectangle [x0, x1) x [y0, y1), clipped to the image.
    void fill_rect(int x0, int y0, int x1, int y1, Rgb8 color);

private:
    [[nodiscard]] std::size_t index(int x, int y) const
    {
        return 3 * (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                    static_cast<std::size_t>(x));
    }
};

/// \brief The PNG encoding of \p image (stb_image_write, 8-bit RGB, deterministic bytes).
/// \throws IoError if the encoder fails.
[[nodiscard]] std::string encode_png(const RgbImage& image);

/// \brief Write \p image as a PNG file, atomically (write_file_atomically: complete or absent).
/// \throws IoError naming \p path when it cannot be written.
void write_png(const std::filesystem::path& path, const RgbImage& image);

}  // namespace meshmark

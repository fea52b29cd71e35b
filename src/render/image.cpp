// SPDX-License-Identifier: MIT
#include "meshmark/render/image.h"

#include <algorithm>

#include <stb_image_write.h>

#include "meshmark/core/atomic_file.h"
#include "meshmark/core/error.h"

namespace meshmark
{

RgbImage::RgbImage(int width_, int height_, Rgb8 fill)
    : width(width_),
      height(height_),
      pixels(3 * static_cast<std::size_t>(std::max(width_, 0)) *
             static_cast<std::size_t>(std::max(height_, 0)))
{
    for (std::size_t i = 0; i < pixels.size(); i += 3)
    {
        pixels[i] = fill[0];
        pixels[i + 1] = fill[1];
        pixels[i + 2] = fill[2];
    }
}

void RgbImage::fill_rect(int x0, int y0, int x1, int y1, Rgb8 color)
{
    x0 = std::max(x0, 0);
    y0 = std::max(y0, 0);
    x1 = std::min(x1, width);
    y1 = std::min(y1, height);
    for (int y = y0; y < y1; ++y)
    {
        for (int x = x0; x < x1; ++x)
        {
            set(x, y, color);
        }
    }
}

namespace
{

extern "C" void append_bytes(void* context, void* data, int size)
{
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
}

}  // namespace

std::string encode_png(const RgbImage& image)
{
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() !=
            3 * static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height))
    {
        throw IoError("cannot encode an empty or inconsistent image as PNG.");
    }
    std::string bytes;
    if (stbi_write_png_to_func(append_bytes, &bytes, image.width, image.height, 3,
                               image.pixels.data(), 3 * image.width) == 0)
    {
        throw IoError("the PNG encoder failed on a " + std::to_string(image.width) + "x" +
                      std::to_string(image.height) + " image.");
    }
    return bytes;
}

void write_png(const std::filesystem::path& path, const RgbImage& image)
{
    const std::string bytes = encode_png(image);
    write_file_atomically(path, [&](std::ostream& out)
                          { out.write(bytes.data(), static_cast<std::streamsize>(bytes.size())); });
}

}  // namespace meshmark

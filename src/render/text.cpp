// SPDX-License-Identifier: MIT
// Labels through stb_easy_font (libstb-dev): it describes each glyph as axis-aligned quads,
// which are filled here as rectangles.
#include "render/detail/text.h"

#include <cmath>
#include <vector>

#include <stb_easy_font.h>

namespace meshmark::detail
{
namespace
{

// stb_easy_font takes a mutable string.
std::vector<char> c_string(const std::string& text)
{
    std::vector<char> s(text.begin(), text.end());
    s.push_back('\0');
    return s;
}

}  // namespace

int text_width(const std::string& text, int scale)
{
    std::vector<char> s = c_string(text);
    return scale * stb_easy_font_width(s.data());
}

int text_height(const std::string& text, int scale)
{
    std::vector<char> s = c_string(text);
    return scale * stb_easy_font_height(s.data());
}

void draw_text(RgbImage& image, int x, int y, const std::string& text, int scale, Rgb8 color)
{
    std::vector<char> s = c_string(text);
    // Four vertices of 16 bytes (x, y, z floats and 4 color bytes) per quad; ~270 bytes per
    // character according to the header, 4x that for safety.
    struct Vertex
    {
        float x, y, z;
        unsigned char rgba[4];
    };
    std::vector<Vertex> quads(16 * (text.size() + 1) * 4);
    const int count = stb_easy_font_print(0.0f, 0.0f, s.data(), nullptr, quads.data(),
                                          static_cast<int>(quads.size() * sizeof(Vertex)));
    for (int q = 0; q < count; ++q)
    {
        const Vertex& a = quads[4 * static_cast<std::size_t>(q)];
        const Vertex& c = quads[4 * static_cast<std::size_t>(q) + 2];  // opposite corner
        const int x0 = x + scale * static_cast<int>(std::lround(std::min(a.x, c.x)));
        const int y0 = y + scale * static_cast<int>(std::lround(std::min(a.y, c.y)));
        const int x1 = x + scale * static_cast<int>(std::lround(std::max(a.x, c.x)));
        const int y1 = y + scale * static_cast<int>(std::lround(std::max(a.y, c.y)));
        image.fill_rect(x0, y0, x1, y1, color);
    }
}

}  // namespace meshmark::detail

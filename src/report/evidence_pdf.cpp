// SPDX-License-Identifier: MIT
// The report as a PDF: A4 pages through cairo's PDF surface, text set with its toy text API
// (words wrapped here, "10^N" raised as a power), the pictures scaled to the text width.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <cairo-pdf.h>
#include <cairo.h>

#include "meshmark/core/error.h"
#include "meshmark/report/evidence_report.h"

namespace meshmark
{
namespace
{

constexpr double kPageWidth = 595.276;  // A4 in points
constexpr double kPageHeight = 841.89;
constexpr double kMargin = 45.0;
constexpr double kTextWidth = kPageWidth - 2.0 * kMargin;
constexpr double kBody = 9.0;  // font sizes in points
constexpr double kSmall = 7.5;
constexpr double kHeading = 11.5;
constexpr double kLabelWidth = 150.0;
constexpr const char* kSans = "DejaVu Sans";
constexpr const char* kMono = "DejaVu Sans Mono";

struct Font
{
    const char* family = kSans;
    double size = kBody;
    bool is_bold = false;
};

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length)
{
    static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
    return CAIRO_STATUS_SUCCESS;
}

/// Sets text on pages top to bottom, starting a new page when the next block does not fit.
class PageWriter
{
public:
    explicit PageWriter(std::string& out)
        : surface_(cairo_pdf_surface_create_for_stream(append_bytes, &out, kPageWidth, kPageHeight),
                   &cairo_surface_destroy),
          cr_(cairo_create(surface_.get()), &cairo_destroy)
    {
        cairo_pdf_surface_set_metadata(surface_.get(), CAIRO_PDF_METADATA_CREATOR, "meshmark");
    }

    void finish()
    {
        cairo_show_page(cr_.get());
        cairo_surface_finish(surface_.get());
        if (cairo_surface_status(surface_.get()) != CAIRO_STATUS_SUCCESS)
        {
            throw IoError(std::string("evidence report: cairo failed to write the PDF: ") +
                          cairo_status_to_string(cairo_surface_status(surface_.get())));
        }
    }

    void set_title(const std::string& title)
    {
        cairo_pdf_surface_set_metadata(surface_.get(), CAIRO_PDF_METADATA_TITLE, title.c_str());
    }

    /// Room for \p height more points on this page, or a new page.
    void need(double height)
    {
        if (y_ + height > kPageHeight - kMargin && y_ > kMargin)
        {
            cairo_show_page(cr_.get());
            y_ = kMargin;
        }
    }
    void skip(double height) { y_ += height; }

    /// Wrapped text in [x, x + width), its lines kept on one page; returns the height used.
    double text(const std::string& words, const Font& font, double x, double width,
                bool is_draft = false)
    {
        const std::vector<std::string> lines = wrap(words, font, width);
        const double leading = 1.3 * font.size;
        if (!is_draft)
        {
            need(leading * static_cast<double>(lines.size()));
            double baseline = y_ + font.size;
            for (const std::string& line : lines)
            {
                draw_line(line, font, x, baseline);
                baseline += leading;
            }
        }
        return leading * static_cast<double>(lines.size());
    }
    void paragraph(const std::string& text_, const Font& font, double after = 4.0)
    {
        y_ += text(text_, font, kMargin, kTextWidth) + after;
    }

    /// A label and a wrapped value on one row.
    void row(const std::string& label, const std::string& value, bool is_code)
    {
        const Font label_font{kSans, kBody, false};
        const Font value_font{is_code ? kMono : kSans, is_code ? kSmall + 0.5 : kBody, false};
        const double height = std::max(
            text(label, label_font, kMargin, kLabelWidth - 6.0, true),
            text(value, value_font, kMargin + kLabelWidth, kTextWidth - kLabelWidth, true));
        need(height);
        cairo_set_source_rgb(cr_.get(), 0.35, 0.35, 0.35);
        text(label, label_font, kMargin, kLabelWidth - 6.0);
        cairo_set_source_rgb(cr_.get(), 0.1, 0.1, 0.1);
        text(value, value_font, kMargin + kLabelWidth, kTextWidth - kLabelWidth);
        y_ += height + 1.0;
    }

    /// A filled band behind the next \p height points (the verdict's box).
    void band(double height, double r, double g, double b)
    {
        need(height);
        cairo_save(cr_.get());
        cairo_set_source_rgb(cr_.get(), r, g, b);
        cairo_rectangle(cr_.get(), kMargin - 6.0, y_ - 4.0, kTextWidth + 12.0, height + 8.0);
        cairo_fill(cr_.get());
        cairo_restore(cr_.get());
    }

    /// \p picture scaled to the text width and at most \p max_height points high, centred.
    void image(const RgbImage& picture, double max_height)
    {
        const double scale = std::min(kTextWidth / picture.width, max_height / picture.height);
        need(scale * picture.height + 4.0);
        const std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface(
            cairo_image_surface_create(CAIRO_FORMAT_RGB24, picture.width, picture.height),
            &cairo_surface_destroy);
        cairo_surface_flush(surface.get());
        unsigned char* data = cairo_image_surface_get_data(surface.get());
        const int stride = cairo_image_surface_get_stride(surface.get());
        for (int y = 0; y < picture.height; ++y)
        {
            auto* row =
                reinterpret_cast<std::uint32_t*>(data + static_cast<std::ptrdiff_t>(y) * stride);
            for (int x = 0; x < picture.width; ++x)
            {
                const Rgb8 c = picture.at(x, y);
                row[x] = (std::uint32_t{c[0]} << 16U) | (std::uint32_t{c[1]} << 8U) |
                         std::uint32_t{c[2]};
            }
        }
        cairo_surface_mark_dirty(surface.get());
        cairo_save(cr_.get());
        cairo_translate(cr_.get(), kMargin + 0.5 * (kTextWidth - scale * picture.width), y_);
        cairo_scale(cr_.get(), scale, scale);
        cairo_set_source_surface(cr_.get(), surface.get(), 0.0, 0.0);
        cairo_pattern_set_filter(cairo_get_source(cr_.get()), CAIRO_FILTER_GOOD);
        cairo_paint(cr_.get());
        cairo_restore(cr_.get());
        y_ += scale * picture.height + 4.0;
    }

    void color(double r, double g, double b) { cairo_set_source_rgb(cr_.get(), r, g, b); }

private:
    void use(const Font& font, double size)
    {
        cairo_select_font_face(cr_.get(), font.family, CAIRO_FONT_SLANT_NORMAL,
                               font.is_bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
        cairo_set_font_size(cr_.get(), size);
    }

    /// Width of \p word, its "10^N" powers set smaller.
    double width_of(const std::string& word, const Font& font)
    {
        double width = 0.0;
        for_each_piece(word,
                       [&](const std::string& piece, bool is_power)
                       {
                           use(font, is_power ? 0.7 * font.size : font.size);
                           cairo_text_extents_t extents;
                           cairo_text_extents(cr_.get(), piece.c_str(), &extents);
                           width += extents.x_advance;
                       });
        return width;
    }

    void draw_line(const std::string& line, const Font& font, double x, double baseline)
    {
        cairo_move_to(cr_.get(), x, baseline);
        for_each_piece(line,
                       [&](const std::string& piece, bool is_power)
                       {
                           use(font, is_power ? 0.7 * font.size : font.size);
                           double cx = 0.0;
                           double cy = 0.0;
                           cairo_get_current_point(cr_.get(), &cx, &cy);
                           cairo_move_to(cr_.get(), cx,
                                         baseline - (is_power ? 0.38 * font.size : 0.0));
                           cairo_show_text(cr_.get(), piece.c_str());
                       });
    }

    /// Calls \p f on the runs of \p text: plain, and the digits after "10^" (raised, the caret
    /// dropped) in a monospace-free font only.
    template <typename F>
    void for_each_piece(const std::string& line, F&& f)
    {
        std::size_t start = 0;
        for (std::size_t at = line.find("10^"); at != std::string::npos;
             at = line.find("10^", start))
        {
            std::size_t end = at + 3;
            while (end < line.size() && line[end] >= '0' && line[end] <= '9')
            {
                ++end;
            }
            f(line.substr(start, at + 2 - start), false);
            f(line.substr(at + 3, end - at - 3), true);
            start = end;
        }
        if (start < line.size())
        {
            f(line.substr(start), false);
        }
    }

    /// Lines of \p text no wider than \p width: broken at spaces, a longer word (a hash, a path)
    /// at any character.
    std::vector<std::string> wrap(const std::string& words, const Font& font, double width)
    {
        std::vector<std::string> lines;
        std::string line;
        std::size_t start = 0;
        while (start <= words.size())
        {
            std::size_t end = words.find(' ', start);
            if (end == std::string::npos)
            {
                end = words.size();
            }
            std::string word = words.substr(start, end - start);
            start = end + 1;
            const std::string joined = line.empty() ? word : line + " " + word;
            if (width_of(joined, font) <= width)
            {
                line = joined;
                continue;
            }
            if (!line.empty())
            {
                lines.push_back(line);
                line.clear();
            }
            // The word alone; cut it where it is too wide.
            while (width_of(word, font) > width && word.size() > 1)
            {
                std::size_t cut = word.size() - 1;
                while (cut > 1 && width_of(word.substr(0, cut), font) > width)
                {
                    --cut;
                }
                lines.push_back(word.substr(0, cut));
                word = word.substr(cut);
            }
            line = word;
        }
        if (!line.empty())
        {
            lines.push_back(line);
        }
        return lines;
    }

    std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface_;
    std::unique_ptr<cairo_t, decltype(&cairo_destroy)> cr_;
    double y_ = kMargin;
};

bool is_code(const std::string& label)
{
    return label == "SHA-256" || label == "Key fingerprint" || label == "Command";
}

}  // namespace

std::string evidence_pdf(const EvidenceText& text, const EvidencePictures& pictures)
{
    std::string out;
    {
        PageWriter page(out);
        page.set_title(text.title);
        page.color(0.1, 0.1, 0.1);
        page.paragraph(text.title, {kSans, 16.0, true}, 6.0);

        // The verdict in a coloured band, then its chance.
        const Font verdict_font{kSans, 11.0, true};
        const double verdict_height =
            page.text(text.verdict, verdict_font, kMargin, kTextWidth, true);
        if (text.is_claimed)
        {
            page.band(verdict_height, 0.906, 0.957, 0.910);
            page.color(0.106, 0.302, 0.122);
        }
        else
        {
            page.band(verdict_height, 0.945, 0.945, 0.945);
            page.color(0.2, 0.2, 0.2);
        }
        page.paragraph(text.verdict, verdict_font, 10.0);
        page.color(0.1, 0.1, 0.1);
        page.paragraph(text.chance, {kSans, kBody + 0.5, false}, 4.0);

        for (const EvidenceSection& section : text.sections)
        {
            page.skip(6.0);
            // A heading is not left alone at the foot of a page: it goes with its first paragraph.
            const Font heading{kSans, kHeading, true};
            double first = page.text(section.heading, heading, kMargin, kTextWidth, true) + 3.0;
            if (!section.paragraphs.empty())
            {
                first += page.text(section.paragraphs.front(), {kSans, kBody, false}, kMargin,
                                   kTextWidth, true);
            }
            page.need(first);
            page.paragraph(section.heading, heading, 3.0);
            for (const std::string& paragraph : section.paragraphs)
            {
                page.paragraph(paragraph, {kSans, kBody, false});
            }
            for (const auto& [label, value] : section.rows)
            {
                page.row(label, value, is_code(label));
            }
            if (section.figure != EvidenceSection::Figure::None)
            {
                page.skip(3.0);
                const bool is_alignment = section.figure == EvidenceSection::Figure::Alignment;
                page.image(is_alignment ? pictures.alignment : pictures.difference.image,
                           is_alignment ? 185.0 : 215.0);
                page.paragraph(section.caption, {kSans, kSmall, false});
            }
        }
        page.finish();
    }
    return out;
}

}  // namespace meshmark

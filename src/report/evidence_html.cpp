// SPDX-License-Identifier: MIT
// The report as one HTML page: inline CSS, pictures as base64 PNG data URIs, no script. The
// print styles keep it to at most 3 A4 pages from a browser.
#include <cstdio>
#include <string>

#include "meshmark/report/evidence_report.h"

namespace meshmark
{
namespace
{

constexpr const char* kStyle = R"css(
@page { size: A4; margin: 14mm 15mm; }
body { font-family: "DejaVu Sans", Arial, Helvetica, sans-serif; font-size: 11pt; line-height: 1.45;
       color: #222; max-width: 60em; margin: 2em auto; padding: 0 1em; }
h1 { font-size: 19pt; margin: 0 0 .3em 0; }
h2 { font-size: 13pt; margin: 1.2em 0 .4em 0; border-bottom: 1px solid #ccc; padding-bottom: .15em; }
p { margin: .35em 0; }
.verdict { margin: .6em 0; padding: .6em .9em; border-left: 7px solid; font-size: 13.5pt; font-weight: bold; }
.claimed { background: #e7f4e8; border-color: #2e7d32; color: #1b4d1f; }
.not-shown { background: #f1f1f1; border-color: #6d6d6d; color: #333; }
.chance { font-size: 11.5pt; }
table { border-collapse: collapse; margin: .4em 0; }
td { padding: .12em .8em .12em 0; vertical-align: top; }
td.label { color: #555; white-space: nowrap; }
code { font-family: "DejaVu Sans Mono", "Courier New", monospace; font-size: 9.5pt; word-break: break-all; }
figure { margin: .6em 0; break-inside: avoid; page-break-inside: avoid; }
figure img { display: block; width: 100%; height: auto; border: 1px solid #ddd; }
figcaption { font-size: 9.5pt; color: #444; margin-top: .3em; }
@media print {
  body { margin: 0; padding: 0; max-width: none; font-size: 9pt; line-height: 1.3; }
  h1 { font-size: 15pt; }
  h2 { font-size: 11pt; margin-top: .8em; break-after: avoid; page-break-after: avoid; }
  .verdict { font-size: 11pt; }
  .chance { font-size: 9.5pt; }
  code { font-size: 8pt; }
  figure img { width: auto; max-width: 100%; max-height: 62mm; }
  figcaption { font-size: 8pt; }
}
)css";

std::string escaped(const std::string& text)
{
    std::string out;
    out.reserve(text.size());
    for (const char c : text)
    {
        switch (c)
        {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

/// Escaped, with "10^N" written as a power (10<sup>N</sup>).
std::string prose(const std::string& text)
{
    std::string out = escaped(text);
    for (std::size_t at = out.find("10^"); at != std::string::npos; at = out.find("10^", at))
    {
        std::size_t end = at + 3;
        while (end < out.size() && out[end] >= '0' && out[end] <= '9')
        {
            ++end;
        }
        const std::string power = "10<sup>" + out.substr(at + 3, end - at - 3) + "</sup>";
        out.replace(at, end - at, power);
        at += power.size();
    }
    return out;
}

std::string base64(const std::string& bytes)
{
    static constexpr char kDigits[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3)
    {
        const auto a = static_cast<unsigned char>(bytes[i]);
        const auto b = static_cast<unsigned char>(bytes[i + 1]);
        const auto c = static_cast<unsigned char>(bytes[i + 2]);
        out += kDigits[a >> 2U];
        out += kDigits[((a & 3U) << 4U) | (b >> 4U)];
        out += kDigits[((b & 15U) << 2U) | (c >> 6U)];
        out += kDigits[c & 63U];
    }
    if (i < bytes.size())
    {
        const auto a = static_cast<unsigned char>(bytes[i]);
        const unsigned b = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0U;
        out += kDigits[a >> 2U];
        out += kDigits[((a & 3U) << 4U) | (b >> 4U)];
        out += i + 1 < bytes.size() ? kDigits[(b & 15U) << 2U] : '=';
        out += '=';
    }
    return out;
}

/// A value shown as code: hashes and command lines (no spaces to break at in a hash).
bool is_code(const std::string& label)
{
    return label == "SHA-256" || label == "Key fingerprint" || label == "Command";
}

void append_figure(std::string& html, const char* kind, const RgbImage& image,
                   const std::string& caption)
{
    html += "<figure><img class=\"";
    html += kind;
    html += "\" alt=\"" + escaped(caption) + "\" width=\"" + std::to_string(image.width) +
            "\" height=\"" + std::to_string(image.height) + "\" src=\"data:image/png;base64," +
            base64(encode_png(image)) + "\"><figcaption>" + prose(caption) +
            "</figcaption></figure>\n";
}

}  // namespace

std::string evidence_html(const EvidenceText& text, const EvidencePictures& pictures)
{
    std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
    html += "<title>" + escaped(text.title) + "</title>\n";
    // The verdict as the JSON states it, for programs that check the report against --json.
    char p[64];
    std::snprintf(p, sizeof p, "%.17g", text.false_positive_probability);
    std::string accused;
    for (const std::string& name : text.accused)
    {
        accused += (accused.empty() ? "" : ",") + name;
    }
    html += "<meta name=\"meshmark:detected\" content=\"" +
            std::string(text.is_claimed ? "true" : "false") +
            "\">\n<meta name=\"meshmark:false_positive_probability\" content=\"" + p +
            "\">\n<meta name=\"meshmark:accused\" content=\"" + escaped(accused) + "\">\n";
    html += "<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n";
    html += "<h1>" + escaped(text.title) + "</h1>\n";
    html += "<p class=\"verdict " + std::string(text.is_claimed ? "claimed" : "not-shown") + "\">" +
            prose(text.verdict) + "</p>\n";
    html += "<p class=\"chance\">" + prose(text.chance) + "</p>\n";
    for (const EvidenceSection& section : text.sections)
    {
        html += "<h2>" + escaped(section.heading) + "</h2>\n";
        for (const std::string& paragraph : section.paragraphs)
        {
            html += "<p>" + prose(paragraph) + "</p>\n";
        }
        if (!section.rows.empty())
        {
            html += "<table>\n";
            for (const auto& [label, value] : section.rows)
            {
                const std::string shown =
                    is_code(label) ? "<code>" + escaped(value) + "</code>" : prose(value);
                html += "<tr><td class=\"label\">" + escaped(label) + "</td><td>" + shown +
                        "</td></tr>\n";
            }
            html += "</table>\n";
        }
        if (section.figure == EvidenceSection::Figure::Alignment)
        {
            append_figure(html, "alignment", pictures.alignment, section.caption);
        }
        else if (section.figure == EvidenceSection::Figure::Difference)
        {
            append_figure(html, "difference", pictures.difference.image, section.caption);
        }
    }
    html += "</body>\n</html>\n";
    return html;
}

}  // namespace meshmark

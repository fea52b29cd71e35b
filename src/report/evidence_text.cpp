// SPDX-License-Identifier: MIT
// The report's words: every number and verdict read from the detect report's JSON, said for a
// reader who has never heard of spectral watermarks.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "meshmark/core/error.h"
#include "meshmark/core/length_unit.h"
#include "meshmark/core/plain_numbers.h"
#include "meshmark/io/file_sha256.h"
#include "meshmark/report/evidence_report.h"

namespace meshmark
{
namespace
{

/// A registered copy this many times further from the original than the mark's strength keeps
/// little of the mark (DetectReport::kFarCopyStrengths; docs/robustness.md).
constexpr double kFarCopyStrengths = 3.0;

std::string printf_string(const char* format, double value)
{
    char text[64];
    std::snprintf(text, sizeof text, format, value);
    return text;
}

/// A fraction of the diagonal as a percentage with three significant digits: "0.0312%".
std::string percent(double fraction)
{
    return printf_string("%.3g%%", 100.0 * fraction);
}

/// A fraction of the diagonal as a percentage, and as a length where the original's file says
/// its unit (EvidenceFacts::unit): "0.0755% (0.12 mm)".
std::string percent_and_length(double fraction, const EvidenceFacts& facts)
{
    std::string out = percent(fraction);
    if (facts.unit && facts.original_diagonal > 0.0)
    {
        // A metric length in the unit a print seller reads: 0.148 mm, not 0.000148 m (µm below 0.01
        // mm).
        const double length = fraction * facts.original_diagonal;
        LengthUnit shown = *facts.unit;
        if (shown != LengthUnit::Inch && shown != LengthUnit::Foot)
        {
            const double metres = length * metres_per(shown);
            shown = metres < 1e-5  ? LengthUnit::Micrometre
                    : metres < 1.0 ? LengthUnit::Millimetre
                                   : LengthUnit::Metre;
        }
        out += " (" + format_length(convert_length(length, *facts.unit, shown), shown) + ")";
    }
    return out;
}

/// A probability as printed beside "1 in N": "3.1e-10", "0.011".
std::string probability(double p)
{
    return printf_string("%.2g", p);
}

/// "at most 1 in N", or "less than 1 in 10^300" (one_in says "less than" itself).
std::string at_most(double p)
{
    const std::string n = one_in(p);
    return n.starts_with("less than") ? n : "at most " + n;
}

/// How often a chance result comes out: "in at most 1 in N checks", "in every check".
std::string how_often(double p)
{
    const std::string n = one_in(p);
    return n == "1 in 1" ? "in every check" : "in " + at_most(p) + " checks";
}

const nlohmann::json& field(const nlohmann::json& detect, const char* name)
{
    if (!detect.contains(name))
    {
        throw InvalidOption(std::string("evidence report: the detect report has no field '") +
                            name + "'.");
    }
    return detect[name];
}

double number(const nlohmann::json& detect, const char* name)
{
    return field(detect, name).get<double>();
}

/// "bob", "bob and carol", "bob, carol and dave".
std::string names_list(const std::vector<std::string>& names)
{
    std::string out;
    for (std::size_t i = 0; i < names.size(); ++i)
    {
        out += (i == 0 ? "" : i + 1 == names.size() ? " and " : ", ") + names[i];
    }
    return out;
}

/// What the report says about the owner's mark read alone (family keys): the `owner_mark` object
/// of the headline JSON, or the older `owner_detected` pair.
struct OwnerMark
{
    bool is_known = false;
    bool detected = false;
    double false_positive_probability = 1.0;
};

OwnerMark owner_mark(const nlohmann::json& detect)
{
    if (detect.contains("owner_mark") && detect["owner_mark"].is_object())
    {
        const nlohmann::json& o = detect["owner_mark"];
        return {true, o.value("detected", false), o.value("false_positive_probability", 1.0)};
    }
    if (detect.contains("owner_detected"))
    {
        return {true, detect["owner_detected"].get<bool>(),
                detect.value("owner_false_positive_probability", 1.0)};
    }
    return {};
}

EvidenceSection files_section(const EvidenceFacts& facts)
{
    EvidenceSection s;
    s.heading = "What was checked";
    s.paragraphs.push_back(
        "A 3D model found elsewhere (the suspect) was checked for the invisible watermark that the "
        "owner put into "
        "their model before publishing it. The check compares the suspect with the owner's "
        "original model and "
        "uses the owner's secret key. The key itself is not part of this report: it is identified "
        "only by its "
        "fingerprint below, which anyone can compare with the key file the owner presents.");
    const auto add = [&s](const std::string& what, const EvidenceFile& file)
    {
        s.rows.emplace_back(what, file.name);
        s.rows.emplace_back("Size", grouped_digits(file.size_bytes) + " bytes");
        s.rows.emplace_back("SHA-256", file.sha256);
    };
    add("Suspect (the copy found)", facts.suspect);
    add("Original (the owner's model)", facts.original);
    s.rows.emplace_back("Key fingerprint", facts.key.sha256);
    if (!facts.created.empty())
    {
        s.rows.emplace_back("Report made", facts.created);
    }
    return s;
}

EvidenceSection correspondence_section(const EvidenceFacts& facts, const EvidencePictures& pictures)
{
    const nlohmann::json& detect = facts.detect;
    const nlohmann::json& registration = field(detect, "registration");
    const std::string method = registration.value("method", std::string("none"));
    const double rms = registration.value("rms_error", 0.0);
    const double strength = detect.value("mark_strength", 0.0);
    const double cropped = number(detect, "cropped_fraction");
    const double outliers = detect.value("outlier_fraction", 0.0);
    const auto suspect_vertices = field(detect, "suspect_vertices").get<std::int64_t>();
    const auto original_vertices = field(detect, "original_vertices").get<std::int64_t>();

    EvidenceSection s;
    s.heading = "How the suspect was matched to the original";
    if (method.starts_with("same-connectivity"))
    {
        s.paragraphs.push_back(
            "The suspect is made of the same points as the original (" +
            grouped_digits(static_cast<std::uintmax_t>(suspect_vertices)) +
            " points, possibly renumbered), so each of its points was compared directly with the "
            "same point of "
            "the original, after undoing any move, turn or change of size of the whole model.");
    }
    else if (method.starts_with("registration (vertices matched)"))
    {
        s.paragraphs.push_back(
            "The suspect's points were renumbered or split, so it was first moved, turned and "
            "scaled onto the "
            "original (registration); its points then turned out to be the original's own, and "
            "each was "
            "compared with the same point of the original.");
    }
    else if (method.starts_with("registration"))
    {
        s.paragraphs.push_back("The suspect is not made of the original's points (" +
                               grouped_digits(static_cast<std::uintmax_t>(suspect_vertices)) +
                               " points against the original's " +
                               grouped_digits(static_cast<std::uintmax_t>(original_vertices)) +
                               "): it was re-meshed, simplified, cut or scanned again. It was "
                               "therefore first moved, turned and "
                               "scaled onto the original automatically (registration), and the "
                               "suspect's surface was then measured "
                               "at the original's points (resampling).");
    }
    else
    {
        s.paragraphs.push_back("Correspondence: " + method + ".");
    }
    if (method.find("not converged") != std::string::npos)
    {
        s.paragraphs.push_back(
            "The automatic alignment did not fully settle, so the match above may be rough.");
    }
    std::string meaning =
        "After this alignment the suspect lies on average (root mean square) " +
        percent_and_length(rms, facts) +
        " of the original's size (the diagonal of its bounding box) from the original";
    if (strength > 0.0)
    {
        meaning += "; the watermark itself moves the surface by about " +
                   percent_and_length(strength, facts) + ".";
        meaning +=
            rms <= 2.0 * strength
                ? " The suspect follows the original closely: it is the same shape, within the "
                  "size of the "
                  "mark."
                : " The suspect differs from the original by more than the mark itself, as after "
                  "simplification, re-meshing, smoothing or other editing.";
    }
    else
    {
        meaning += ".";
    }
    s.paragraphs.push_back(meaning);
    if (cropped > 0.0)
    {
        s.paragraphs.push_back(percent(cropped) +
                               " of the original has no counterpart in the suspect (cut away); "
                               "the check used the rest.");
    }
    s.rows.emplace_back("Correspondence", method);
    s.rows.emplace_back("Points",
                        "suspect " + grouped_digits(static_cast<std::uintmax_t>(suspect_vertices)) +
                            ", original " +
                            grouped_digits(static_cast<std::uintmax_t>(original_vertices)));
    s.rows.emplace_back("Distance after alignment (RMS)",
                        percent_and_length(rms, facts) + " of the original's diagonal");
    s.rows.emplace_back("Cut away (cropped)", percent(cropped) + " of the original");
    s.rows.emplace_back("Left out as too far", percent(outliers) + " of the original's points");
    s.figure = EvidenceSection::Figure::Alignment;
    s.caption =
        "Figure 1. Left: the suspect as received (orange). Right: the suspect moved onto the "
        "original by "
        "the alignment found (orange), drawn over the original (light grey) from the same "
        "direction. "
        "Orange covering grey means the suspect has that part of the original; grey alone is what "
        "the "
        "suspect lacks.";
    (void)pictures;
    return s;
}

EvidenceSection difference_section(const EvidenceFacts& facts, const EvidencePictures& pictures,
                                   double strength)
{
    EvidenceSection s;
    s.heading = "Where the suspect differs from the original";
    std::string text =
        "Each point of the aligned suspect is coloured by its distance to the original's surface: "
        "blue where it lies on it, red where it lies " +
        percent_and_length(pictures.red_distance_rel, facts) +
        " of the original's diagonal away or more. Half of the points lie within " +
        percent_and_length(pictures.median_distance_rel, facts) + ".";
    if (strength > 0.0)
    {
        text += " The watermark moves the surface by about " + percent_and_length(strength, facts) +
                ", far below what the eye sees on the model; a faint, even pattern at that level "
                "is what a "
                "marked copy shows, while larger red areas are where the suspect was edited.";
    }
    s.paragraphs.push_back(text);
    s.figure = EvidenceSection::Figure::Difference;
    s.caption =
        "Figure 2. Distance from the aligned suspect to the original's surface, in % of the "
        "original's "
        "diagonal (colour bar).";
    return s;
}

EvidenceSection method_section()
{
    EvidenceSection s;
    s.heading = "How the check works";
    s.paragraphs.push_back(
        "Before publishing, the owner moved every point of the model's surface by a tiny amount "
        "(typically a few "
        "hundredths of a percent of its size, far below what the eye or a 3D printer shows), in a "
        "pattern "
        "computed from a secret key. The pattern is built from smooth, wave-like shapes of the "
        "whole surface "
        "(a spectral basis), so it survives moving, scaling, re-saving, noise, smoothing, "
        "simplification and "
        "cutting. To check a suspect, the tool aligns it with the original, measures how the "
        "suspect departs "
        "from the original along those same shapes, and compares that with the pattern the key "
        "predicts. A "
        "model that does not carry this mark agrees with the secret pattern only by chance; the "
        "chance stated "
        "above is a proven upper bound on how often that happens, whatever the model. The method "
        "is that of "
        "J. Wu and L. Kobbelt, \"Efficient spectral watermarking of large meshes with orthogonal "
        "basis "
        "functions\", The Visual Computer 21, 2005, with meshmark's corrections to its detection "
        "and "
        "statistics.");
    return s;
}

EvidenceSection repeat_section(const EvidenceFacts& facts)
{
    EvidenceSection s;
    s.heading = "How to repeat the check";
    s.paragraphs.push_back(
        "Anyone holding the two model files and the key file above (their SHA-256 must match) can "
        "repeat the "
        "check with the same version of the tool; it gives the same result on every computer. The "
        "command "
        "prints the full result as JSON, from which this report was written:");
    s.rows.emplace_back("Tool", facts.version);
    s.rows.emplace_back("Command", facts.command);
    return s;
}

}  // namespace

EvidenceFile evidence_file(const std::filesystem::path& path)
{
    return {path.string(), std::filesystem::file_size(path), file_sha256(path)};
}

EvidenceText evidence_text(const EvidenceFacts& facts, const EvidencePictures& pictures)
{
    const nlohmann::json& detect = facts.detect;
    EvidenceText out;
    out.title = "Watermark evidence report";
    out.is_claimed = field(detect, "detected").get<bool>();
    const double p = number(detect, "false_positive_probability");
    std::vector<std::string> accused;
    if (detect.contains("recipients"))
    {
        for (const nlohmann::json& r : detect["recipients"])
        {
            accused.push_back(r.at("name").get<std::string>());
        }
    }
    const auto traced = detect.value("recipients_traced", std::size_t{0});
    out.false_positive_probability = p;
    out.accused = accused;

    // The verdict and its chance.
    if (out.is_claimed)
    {
        out.verdict = "CLAIMED: the suspect carries the owner's watermark";
        out.verdict += accused.empty()
                           ? "."
                           : "; it was made from the copy issued to " + names_list(accused) + ".";
        out.chance =
            "If the suspect did not carry this mark, a result at least this strong would come "
            "out " +
            how_often(p) + " (probability " + probability(p) +
            "). This bound holds whatever the model.";
    }
    else
    {
        out.verdict = "NOT SHOWN: this check does not show the owner's watermark in the suspect.";
        out.chance = "A model without this mark can give a result at least this strong " +
                     how_often(p) + " (probability " + probability(p) +
                     "), so the result is not evidence of the mark.";
        if (detect.contains("max_false_positive_probability"))
        {
            out.chance += " The tool claims a mark only when that chance is " +
                          at_most(detect["max_false_positive_probability"].get<double>()) + ".";
        }
        out.chance +=
            " \"Not shown\" is not proof that the suspect is not a copy: it means this check found "
            "no "
            "convincing evidence.";
    }

    EvidenceSection found;
    found.heading = "What was found";
    if (detect.contains("headline") && detect["headline"].is_string())
    {
        found.paragraphs.push_back("In one sentence, as the tool prints it: " +
                                   detect["headline"].get<std::string>());
    }
    const nlohmann::json& registration = field(detect, "registration");
    const double rms = registration.value("rms_error", 0.0);
    const double strength = detect.value("mark_strength", 0.0);
    if (!out.is_claimed &&
        registration.value("method", std::string()).starts_with("registration") && strength > 0.0 &&
        rms >= kFarCopyStrengths * strength)
    {
        found.paragraphs.push_back(
            "The suspect lies far from the original: " + printf_string("%.1f", rms / strength) +
            " times the size of the mark itself. Copies changed that much (coarse simplification, "
            "re-meshing) often "
            "keep too little of the mark to be claimed, so this result says little either way.");
    }
    found.rows.emplace_back("Verdict", out.is_claimed ? "claimed" : "not shown");
    found.rows.emplace_back("Chance without the mark", at_most(p) + " (" + probability(p) + ")");
    if (traced > 0)
    {
        found.rows.emplace_back("Whose copy",
                                accused.empty() ? "no recipient named" : names_list(accused));
        found.rows.emplace_back("Recipients checked", std::to_string(traced));
        for (const nlohmann::json& r : detect.value("recipients", nlohmann::json::array()))
        {
            const double q = r.value("false_positive_probability", 1.0);
            found.rows.emplace_back("  " + r.at("name").get<std::string>(),
                                    "named; chance for an innocent recipient " + at_most(q) + " (" +
                                        probability(q) + ")");
        }
        const OwnerMark owner = owner_mark(detect);
        if (owner.is_known)
        {
            found.rows.emplace_back("Owner's mark alone",
                                    std::string(owner.detected ? "shown" : "not shown") +
                                        "; chance " + at_most(owner.false_positive_probability) +
                                        " (" + probability(owner.false_positive_probability) + ")");
        }
    }

    out.sections.push_back(files_section(facts));
    out.sections.push_back(std::move(found));
    out.sections.push_back(correspondence_section(facts, pictures));
    out.sections.push_back(difference_section(facts, pictures, strength));
    out.sections.push_back(method_section());
    out.sections.push_back(repeat_section(facts));
    return out;
}

}  // namespace meshmark

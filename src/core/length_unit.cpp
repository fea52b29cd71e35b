// SPDX-License-Identifier: MIT
// Units of length: the symbols of the command line and --json, the conversions, and lengths
// as users write them ("0.05mm").
#include "meshmark/core/length_unit.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <utility>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

struct UnitName
{
    std::string_view symbol;
    LengthUnit unit;
};

constexpr std::array<UnitName, 7> kUnitNames = {{{"um", LengthUnit::Micrometre},
                                                 {"\xC2\xB5m", LengthUnit::Micrometre},
                                                 {"mm", LengthUnit::Millimetre},
                                                 {"cm", LengthUnit::Centimetre},
                                                 {"m", LengthUnit::Metre},
                                                 {"in", LengthUnit::Inch},
                                                 {"ft", LengthUnit::Foot}}};

constexpr std::string_view kAccepted = "um, mm, cm, m, in or ft";

std::string_view trimmed(std::string_view text)
{
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t'))
    {
        text.remove_prefix(1);
    }
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t'))
    {
        text.remove_suffix(1);
    }
    return text;
}

}  // namespace

const char* to_string(LengthUnit unit) noexcept
{
    switch (unit)
    {
        case LengthUnit::Micrometre:
            return "um";
        case LengthUnit::Millimetre:
            return "mm";
        case LengthUnit::Centimetre:
            return "cm";
        case LengthUnit::Metre:
            return "m";
        case LengthUnit::Inch:
            return "in";
        case LengthUnit::Foot:
            return "ft";
    }
    return "?";
}

double metres_per(LengthUnit unit) noexcept
{
    switch (unit)
    {
        case LengthUnit::Micrometre:
            return 1e-6;
        case LengthUnit::Millimetre:
            return 1e-3;
        case LengthUnit::Centimetre:
            return 1e-2;
        case LengthUnit::Metre:
            return 1.0;
        case LengthUnit::Inch:
            return 0.0254;
        case LengthUnit::Foot:
            return 0.3048;
    }
    return 1.0;
}

double convert_length(double value, LengthUnit from, LengthUnit to) noexcept
{
    return from == to ? value : value * (metres_per(from) / metres_per(to));
}

LengthUnit parse_length_unit(std::string_view symbol)
{
    const std::string_view text = trimmed(symbol);
    for (const UnitName& name : kUnitNames)
    {
        if (name.symbol == text)
        {
            return name.unit;
        }
    }
    throw InvalidOption("unknown unit \"" + std::string(symbol) + "\"; use " +
                        std::string(kAccepted) + ".");
}

Length parse_length(std::string_view text, std::string_view what)
{
    const std::string_view body = trimmed(text);
    const auto refuse = [&](const std::string& why)
    { return InvalidOption(std::string(what) + " \"" + std::string(text) + "\" " + why); };
    // The number: from_chars takes no leading '+' and no spaces, which is what we want.
    double value = 0.0;
    const auto [end, error] = std::from_chars(body.data(), body.data() + body.size(), value);
    if (error != std::errc() || end == body.data())
    {
        throw refuse("is not a length: write a number, optionally followed by a unit (" +
                     std::string(kAccepted) + "), like 0.05mm.");
    }
    if (!std::isfinite(value) || value <= 0.0)
    {
        throw refuse("must be a positive length.");
    }
    Length length{value, std::nullopt};
    const std::string_view suffix =
        trimmed(body.substr(static_cast<std::size_t>(end - body.data())));
    if (!suffix.empty())
    {
        try
        {
            length.unit = parse_length_unit(suffix);
        }
        catch (const InvalidOption&)
        {
            throw refuse("has an unknown unit \"" + std::string(suffix) + "\"; use " +
                         std::string(kAccepted) + ".");
        }
    }
    return length;
}

double length_in_mesh_units(const Length& length, std::optional<LengthUnit> mesh_unit,
                            std::string_view what)
{
    if (!mesh_unit)
    {
        throw InvalidOption(std::string(what) +
                            " needs the mesh's unit of length, and this file does not state one "
                            "(only 3MF and glTF do): give it with --unit (mm, cm, m, in, ft, um).");
    }
    return length.unit ? convert_length(length.value, *length.unit, *mesh_unit) : length.value;
}

std::string format_length(double value, LengthUnit unit)
{
    char text[64];
    std::snprintf(text, sizeof text, "%.3g %s", value, to_string(unit));
    return text;
}

}  // namespace meshmark

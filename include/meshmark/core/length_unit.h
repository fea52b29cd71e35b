// SPDX-License-Identifier: MIT
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace meshmark
{

/// \brief Units of length a mesh's coordinates may be in: what a file declares (3MF's model
/// unit, glTF's metres) or a user states (`--unit`).
enum class LengthUnit
{
    Micrometre,  ///< "um" (3MF: "micron").
    Millimetre,  ///< "mm" (3MF's default).
    Centimetre,  ///< "cm".
    Metre,       ///< "m" (glTF, by its specification).
    Inch,        ///< "in".
    Foot,        ///< "ft".
};

/// The unit's symbol as written on the command line and in --json: "um", "mm", "cm", "m", "in",
/// "ft".
[[nodiscard]] const char* to_string(LengthUnit unit) noexcept;

/// Metres in one \p unit (an inch is 0.0254 m exactly, a foot 0.3048 m).
[[nodiscard]] double metres_per(LengthUnit unit) noexcept;

/// \brief \p value in \p from expressed in \p to.
[[nodiscard]] double convert_length(double value, LengthUnit from, LengthUnit to) noexcept;

/// \brief The unit named by \p symbol: um, mm, cm, m, in, ft (also "µm").
/// \throws InvalidOption naming the text and the accepted symbols.
[[nodiscard]] LengthUnit parse_length_unit(std::string_view symbol);

/// \brief A length as a user writes it: a number, with or without a unit suffix.
struct Length
{
    double value = 0.0;
    std::optional<LengthUnit> unit;  ///< Empty for a bare number (the mesh's own unit).
};

/// \brief Parse "0.05mm", "0.05 mm", "50um", "2in" or a bare "0.3".
/// \throws InvalidOption (naming \p what and the text) unless it is a finite, positive number
/// followed by nothing or one of the symbols of parse_length_unit.
[[nodiscard]] Length parse_length(std::string_view text, std::string_view what = "length");

/// \brief \p length in the mesh's coordinates, which are in \p mesh_unit (empty: not known).
/// \throws InvalidOption (naming \p what) for a bare number or a unit suffix when \p mesh_unit
/// is empty: a length cannot be placed on a mesh of unknown unit, and none is guessed.
[[nodiscard]] double length_in_mesh_units(const Length& length, std::optional<LengthUnit> mesh_unit,
                                          std::string_view what = "length");

/// \brief \p value (in \p unit) as text with its symbol and about 3 significant digits: "0.81 mm".
[[nodiscard]] std::string format_length(double value, LengthUnit unit);

}  // namespace meshmark

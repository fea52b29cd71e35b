// SPDX-License-Identifier: MIT
// Units of length and lengths as users write them (embed --max-displacement, --unit).
#include "meshmark/core/length_unit.h"

#include <string>

#include <gtest/gtest.h>

#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

TEST(LengthUnitTest, parses_lengths_with_and_without_a_unit)
{
    const Length mm = parse_length("0.05mm");
    EXPECT_DOUBLE_EQ(mm.value, 0.05);
    EXPECT_EQ(mm.unit, LengthUnit::Millimetre);
    const Length um = parse_length("50um");
    EXPECT_DOUBLE_EQ(um.value, 50.0);
    EXPECT_EQ(um.unit, LengthUnit::Micrometre);
    EXPECT_EQ(parse_length("50\xC2\xB5m").unit, LengthUnit::Micrometre);
    const Length inch = parse_length(" 2 in ");
    EXPECT_DOUBLE_EQ(inch.value, 2.0);
    EXPECT_EQ(inch.unit, LengthUnit::Inch);
    EXPECT_EQ(parse_length("1e-3m").unit, LengthUnit::Metre);
    EXPECT_EQ(parse_length("3ft").unit, LengthUnit::Foot);
    EXPECT_EQ(parse_length("0.5cm").unit, LengthUnit::Centimetre);
    const Length bare = parse_length("0.3");
    EXPECT_DOUBLE_EQ(bare.value, 0.3);
    EXPECT_FALSE(bare.unit.has_value());
}

TEST(LengthUnitTest, refuses_what_is_not_a_positive_length)
{
    for (const char* text :
         {"", "mm", "abc", "0.05 parsec", "0.05mmm", "-1mm", "0", "0mm", "nan", "inf mm", "1,5mm"})
    {
        try
        {
            (void)parse_length(text, "--max-displacement");
            ADD_FAILURE() << "accepted \"" << text << "\"";
        }
        catch (const InvalidOption& e)
        {
            const std::string message = e.what();
            EXPECT_NE(message.find("--max-displacement"), std::string::npos) << message;
            EXPECT_NE(message.find(text), std::string::npos) << message;
        }
    }
    EXPECT_THROW((void)parse_length_unit("mile"), InvalidOption);
    EXPECT_THROW((void)parse_length_unit("MM"), InvalidOption);
}

TEST(LengthUnitTest, converts_into_the_mesh_unit_and_never_guesses_one)
{
    EXPECT_DOUBLE_EQ(length_in_mesh_units(parse_length("50um"), LengthUnit::Millimetre), 0.05);
    EXPECT_DOUBLE_EQ(length_in_mesh_units(parse_length("2in"), LengthUnit::Millimetre), 50.8);
    EXPECT_DOUBLE_EQ(length_in_mesh_units(parse_length("0.05mm"), LengthUnit::Metre), 5e-5);
    EXPECT_DOUBLE_EQ(length_in_mesh_units(parse_length("1ft"), LengthUnit::Inch), 12.0);
    // A bare number is in the mesh's own unit.
    EXPECT_DOUBLE_EQ(length_in_mesh_units(parse_length("0.3"), LengthUnit::Inch), 0.3);
    // Without a mesh unit neither a bare number nor a unit can be placed on it.
    EXPECT_THROW((void)length_in_mesh_units(parse_length("0.3"), std::nullopt), InvalidOption);
    EXPECT_THROW((void)length_in_mesh_units(parse_length("0.3mm"), std::nullopt), InvalidOption);
    EXPECT_EQ(format_length(0.8123, LengthUnit::Millimetre), "0.812 mm");
    EXPECT_EQ(std::string(to_string(LengthUnit::Micrometre)), "um");
}

}  // namespace
}  // namespace meshmark

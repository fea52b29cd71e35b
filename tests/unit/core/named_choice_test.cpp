// SPDX-License-Identifier: MIT
#include "meshmark/core/named_choice.h"

#include <string>

#include <gtest/gtest.h>

namespace meshmark
{
namespace
{

enum class Color
{
    Red,
    Green,
    Blue,
};

std::string message_of(const std::string& name,
                       std::initializer_list<std::pair<const char*, Color>> choices)
{
    try
    {
        (void)parse_named_choice<Color>(name, "color", choices);
    }
    catch (const InvalidOption& e)
    {
        return e.what();
    }
    return "no error";
}

}  // namespace

TEST(NamedChoiceTest, returns_the_named_value)
{
    EXPECT_EQ(
        parse_named_choice<Color>("green", "color", {{"red", Color::Red}, {"green", Color::Green}}),
        Color::Green);
    EXPECT_EQ(
        parse_named_choice<Color>("red", "color", {{"red", Color::Red}, {"green", Color::Green}}),
        Color::Red);
}

TEST(NamedChoiceTest, names_every_choice_when_the_name_is_unknown)
{
    EXPECT_EQ(message_of("Red", {{"red", Color::Red}, {"green", Color::Green}}),
              "unknown color 'Red' (expected red or green).");
    EXPECT_EQ(message_of("", {{"red", Color::Red}, {"green", Color::Green}, {"blue", Color::Blue}}),
              "unknown color '' (expected red, green or blue).");
}

}  // namespace meshmark

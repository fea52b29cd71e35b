// SPDX-License-Identifier: MIT
// The files an OBJ references: its `mtllib` libraries (as the format and exporters write them)
// and their textures.
#include "meshmark/io/obj_materials.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "io_test_support.h"

namespace meshmark
{

TEST(ObjMaterialsTest, libraries_are_read_as_written_and_as_the_folder_holds_them)
{
    const auto folder = test::temp_dir("obj_materials");
    test::put_bytes(folder / "my materials.mtl", "newmtl a\n");
    const std::string obj =
        "# mtllib commented.mtl\n"
        "usemtl mtllib\n"
        "  mtllib   my materials.mtl  \r\n"  // one file whose name has a space
        "mtllib a.mtl b.mtl\n"               // two names (neither exists)
        "mtllib\n"
        "v 0 0 0\n"
        "mtllib last.mtl";  // no final newline
    const auto statements = material_libraries(obj, folder);
    ASSERT_EQ(statements.size(), 4U);
    EXPECT_EQ(statements[0].names, std::vector<std::string>{"my materials.mtl"});
    EXPECT_EQ(obj.substr(statements[0].offset, statements[0].length), "my materials.mtl");
    EXPECT_EQ(statements[1].names, (std::vector<std::string>{"a.mtl", "b.mtl"}));
    EXPECT_EQ(obj.substr(statements[1].offset, statements[1].length), "a.mtl b.mtl");
    EXPECT_TRUE(statements[2].names.empty());
    EXPECT_EQ(statements[3].names, std::vector<std::string>{"last.mtl"});
    EXPECT_TRUE(material_libraries("v 0 0 0\nf 1 2 3\n", folder).empty());
}

TEST(ObjMaterialsTest, textures_are_the_last_word_of_each_map_statement)
{
    const std::string mtl =
        "newmtl wood\n"
        "Kd 0.8 0.6 0.4\n"
        "map_Kd -s 2 2 1 textures/wood.png\n"
        "MAP_KS spec.jpg\r\n"
        "bump -bm 0.5 bump.png\n"
        "norm normal.png\n"
        "disp d.png\n decal  decal.png\n"
        "refl -type sphere sky.png\n"
        "map_d\n"  // no file
        "# map_Kd commented.png\n";
    EXPECT_EQ(material_textures(mtl),
              (std::vector<std::string>{"textures/wood.png", "spec.jpg", "bump.png", "normal.png",
                                        "d.png", "decal.png", "sky.png"}));
}

}  // namespace meshmark

// SPDX-License-Identifier: MIT
// The unit of length a file declares (MeshFile::unit): 3MF's model unit (millimetre when
// absent), glTF's metres, none for PLY, OBJ, OFF and STL.
#include <filesystem>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "three_mf_test_support.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;

// A PrusaSlicer-style package whose root model says unit="<unit>" (or has no unit attribute
// when \p unit is empty).
fs::path package_with_unit(const fs::path& dir, const std::string& unit)
{
    std::string model = test::prusa_model(test::box_object("1", "20"));
    model = std::regex_replace(model, std::regex("unit=\"millimeter\""),
                               unit.empty() ? "" : "unit=\"" + unit + "\"");
    const fs::path path = dir / ("box-" + (unit.empty() ? std::string("none") : unit) + ".3mf");
    test::put_bytes(path, test::make_zip(dir, test::prusa_parts(model)));
    return path;
}

TEST(FileUnitTest, a_3mf_states_its_model_unit)
{
    const fs::path dir = test::temp_dir("three_mf_unit");
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "millimeter")).unit, LengthUnit::Millimetre);
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "inch")).unit, LengthUnit::Inch);
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "micron")).unit, LengthUnit::Micrometre);
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "centimeter")).unit, LengthUnit::Centimetre);
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "foot")).unit, LengthUnit::Foot);
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "meter")).unit, LengthUnit::Metre);
    // The specification's default.
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "")).unit, LengthUnit::Millimetre);
    // Outside the specification: no unit rather than a guess.
    EXPECT_FALSE(read_mesh_file(package_with_unit(dir, "parsec")).unit.has_value());
    // The geometry is the same whatever the unit (no scaling is applied).
    EXPECT_EQ(read_mesh_file(package_with_unit(dir, "inch")).mesh.V,
              read_mesh_file(package_with_unit(dir, "millimeter")).mesh.V);
}

TEST(FileUnitTest, gltf_is_in_metres_and_other_formats_have_no_unit)
{
    const fs::path dir = test::temp_dir("file_unit");
    const MeshFile box = read_mesh_file(package_with_unit(dir, "inch"));
    for (const char* name : {"box.ply", "box.obj", "box.off", "box.stl"})
    {
        write_mesh(dir / name, box.mesh);
        EXPECT_FALSE(read_mesh_file(dir / name).unit.has_value()) << name;
    }
    write_mesh(dir / "box.glb", box.mesh);
    EXPECT_EQ(read_mesh_file(dir / "box.glb").unit, LengthUnit::Metre);
    // A 3MF written from scratch says millimetres.
    write_mesh(dir / "written.3mf", box.mesh);
    EXPECT_EQ(read_mesh_file(dir / "written.3mf").unit, LengthUnit::Millimetre);
}

}  // namespace
}  // namespace meshmark

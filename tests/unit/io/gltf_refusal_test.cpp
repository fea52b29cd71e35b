// SPDX-License-Identifier: MIT
// glTF assets meshmark refuses: glTF 1.0 (naming the version and the upgrade), hostile files
// (one sentence naming the file).

#include <gtest/gtest.h>
#include <tiny_gltf.h>

#include "gltf_test_fixture.h"
#include "gltf_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark
{
namespace
{

namespace fs = std::filesystem;
using test::GltfBuilder;
using test::GltfTest;
using test::Json;
using test::two_boxes;

TEST_F(GltfTest, gltf_1_0_assets_are_refused_naming_the_version_and_the_upgrade)
{
    const auto expect_refused =
        [&](const std::string& name, const std::string& bytes, const std::string& version)
    {
        test::put_bytes(dir / name, bytes);
        try
        {
            static_cast<void>(read_mesh_file(dir / name));
            ADD_FAILURE() << name << " was accepted";
        }
        catch (const IoError& e)
        {
            const std::string what = e.what();
            EXPECT_NE(what.find(name), std::string::npos) << what;
            EXPECT_NE(what.find("glTF " + version + " is not supported"), std::string::npos)
                << what;
            EXPECT_NE(what.find("gltf-pipeline"), std::string::npos) << what;
        }
    };
    // The 1.0 layout, as collada2gltf wrote it (tinygltf reads it as a scene without meshes).
    const std::string v1 = R"({"asset": {"version": "1.0"}, "scene": "defaultScene",
        "scenes": {"defaultScene": {"nodes": ["node"]}}, "nodes": {"node": {"meshes": ["box"]}},
        "meshes": {"box": {"primitives": [{"attributes": {"POSITION": "pos"}, "mode": 4}]}},
        "accessors": {"pos": {"bufferView": "view", "byteOffset": 0, "componentType": 5126, "count": 3,
                              "type": "VEC3"}},
        "bufferViews": {"view": {"buffer": "buf", "byteOffset": 0, "byteLength": 36}},
        "buffers": {"buf": {"byteLength": 36, "uri": "data:application/octet-stream;base64,)" +
                           test::base64(std::string(36, '\0')) + R"("}}})";
    expect_refused("v1.gltf", v1, "1.0");
    // A numeric version (tinygltf refuses the asset object).
    std::string numeric = v1;
    numeric.replace(numeric.find(R"("version": "1.0")"), 16, R"("version": 1)");
    expect_refused("v1_number.gltf", numeric, "1");
    // No version at all, the 1.0 layout.
    std::string unversioned = v1;
    unversioned.replace(unversioned.find(R"("version": "1.0")"), 16, R"("generator": "x")");
    expect_refused("v1_unversioned.gltf", unversioned, "1.0");
    // A GLB container of version 1 (KHR_binary_glTF).
    std::string glb1 = two_boxes().builder.glb();
    glb1[4] = 1;
    try
    {
        test::put_bytes(dir / "v1.glb", glb1);
        static_cast<void>(read_mesh_file(dir / "v1.glb"));
        ADD_FAILURE() << "v1.glb was accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("glTF 1.0 binary"), std::string::npos) << e.what();
    }
}

TEST_F(GltfTest, hostile_files_fail_with_one_sentence_naming_the_file)
{
    const auto t = two_boxes();
    const std::string glb = t.builder.glb();
    const auto expect_error = [&](const std::string& name, const std::string& bytes)
    {
        test::put_bytes(dir / name, bytes);
        try
        {
            static_cast<void>(read_mesh_file(dir / name));
            ADD_FAILURE() << name << " was accepted";
        }
        catch (const Error& e)
        {
            EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
        }
    };
    expect_error("truncated.glb", glb.substr(0, glb.size() - 10));
    expect_error("not.glb", "hello world, this is not binary glTF");
    expect_error("bad.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [");

    // Index past the end of the positions.
    GltfBuilder b;
    const int pos = b.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    b.node({{"mesh", b.mesh(Json::array({{{"attributes", {{"POSITION", pos}}},
                                          {"indices", b.indices({0, 1, 7})}}}))}});
    expect_error("index.glb", b.glb());

    // A cycle in the node tree.
    GltfBuilder c;
    const int p2 = c.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    const int m2 = c.mesh(Json::array({{{"attributes", {{"POSITION", p2}}}}}));
    c.node({{"mesh", m2}, {"children", {1}}});
    c.node({{"children", {0}}}, false);
    expect_error("cycle.glb", c.glb());

    // An accessor reaching past its bufferView.
    GltfBuilder d;
    const int p3 = d.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    d.doc["accessors"][static_cast<std::size_t>(p3)]["count"] = 300;
    d.node({{"mesh", d.mesh(Json::array({{{"attributes", {{"POSITION", p3}}}}}))}});
    expect_error("overrun.glb", d.glb());

    // A Draco extension whose attributes are not an object (tinygltf::Value::Get asserts).
    GltfBuilder e;
    const int p4 = e.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
    e.node({{"mesh", e.mesh(Json::array({{{"attributes", {{"POSITION", p4}}},
                                          {"extensions",
                                           {{"KHR_draco_mesh_compression",
                                             {{"bufferView", 0}, {"attributes", 5}}}}}}}))}});
    expect_error("draco_ext.glb", e.glb());

    // Skins: a joint index past the skin's joints, a JOINTS_0 that is not a VEC4, a skin that
    // does not exist.
    for (const std::string bad : {"joint_index", "joints_type", "missing_skin"})
    {
        GltfBuilder f;
        const int p5 = f.positions({0, 0, 0, 1, 0, 0, 0, 1, 0});
        const std::vector<std::uint8_t> joints{
            0, 0, 0, 0, 0, 0, 0, 0, static_cast<std::uint8_t>(bad == "joint_index" ? 3 : 0),
            0, 0, 0};
        const std::vector<float> weights{1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
        const int j =
            f.accessor(f.view(GltfBuilder::raw(joints)), 0, 5121, bad == "joints_type" ? 4 : 3,
                       bad == "joints_type" ? "VEC3" : "VEC4");
        const int w = f.accessor(f.view(GltfBuilder::raw(weights)), 0, 5126, 3, "VEC4");
        const int joint = f.node({{"name", "joint"}, {"translation", {0.0, 1.0, 0.0}}});
        f.node({{"mesh",
                 f.mesh(Json::array(
                     {{{"attributes", {{"POSITION", p5}, {"JOINTS_0", j}, {"WEIGHTS_0", w}}}}}))},
                {"skin", bad == "missing_skin" ? 4 : 0}});
        f.doc["skins"] = Json::array({{{"joints", {joint}}}});
        expect_error("skin_" + bad + ".glb", f.glb());
    }
}

}  // namespace
}  // namespace meshmark

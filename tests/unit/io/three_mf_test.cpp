// SPDX-License-Identifier: MIT
// 3MF: mesh objects in the build's world frame, welded; the preserving writer changes vertex
// coordinates only (objects, triangles, materials, metadata, components and build items are
// compared through lib3mf).
#include <cmath>
#include <memory>

#include <Model/COM/NMR_DLLInterfaces.h>
#include <gtest/gtest.h>

#include "io_test_support.h"
#include "meshmark/core/error.h"
#include "meshmark/io/mesh_io.h"

// lib3mf 1.8 leaks a few libzip allocations (~480 bytes) on every package it reads, also in
// a plain C program; LeakSanitizer builds of this test ignore them (the hook is only read by
// the sanitizer runtime).
extern "C" const char* __lsan_default_suppressions()
{
    return "leak:libzip.so\n";
}

namespace meshmark {
namespace {

namespace fs = std::filesystem;

struct Release
{
    void operator()(NMR::PLib3MFBase* p) const { NMR::lib3mf_release(p); }
};
using Ptr = std::unique_ptr<NMR::PLib3MFBase, Release>;

template <typename F>
Ptr make(F&& create)
{
    NMR::PLib3MFBase* p = nullptr;
    EXPECT_EQ(create(&p), 0);
    return Ptr(p);
}

NMR::MODELTRANSFORM transform(float scale, float tx, float ty, float tz)
{
    NMR::MODELTRANSFORM t{};
    for (int r = 0; r < 3; ++r)
    {
        for (int c = 0; c < 3; ++c)
        {
            t.m_fFields[r][c] = r == c ? scale : 0.0f;
        }
    }
    t.m_fFields[0][3] = tx;
    t.m_fFields[1][3] = ty;
    t.m_fFields[2][3] = tz;
    return t;
}

// The unit box with 8 vertices and 12 triangles.
void set_box(NMR::PLib3MFBase* mesh)
{
    std::vector<NMR::MODELMESHVERTEX> v(8);
    for (int i = 0; i < 8; ++i)
    {
        v[static_cast<std::size_t>(i)].m_fPosition[0] = static_cast<float>(i & 1);
        v[static_cast<std::size_t>(i)].m_fPosition[1] = static_cast<float>((i >> 1) & 1);
        v[static_cast<std::size_t>(i)].m_fPosition[2] = static_cast<float>((i >> 2) & 1);
    }
    const DWORD tri[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    std::vector<NMR::MODELMESHTRIANGLE> t(12);
    for (std::size_t f = 0; f < 12; ++f)
    {
        for (std::size_t c = 0; c < 3; ++c)
        {
            t[f].m_nIndices[c] = tri[f][c];
        }
    }
    ASSERT_EQ(NMR::lib3mf_meshobject_setgeometry(mesh, v.data(), 8, t.data(), 12), 0);
}

// Box A (build item: scale 2, at x = 1) and box B reached through a components object
// (build item at x = 3, component scale 2): the world boxes [1,3]^3-ish and [3,5] share the
// face x = 3. A has base materials per triangle; the model has metadata.
std::string two_box_package()
{
    auto model = make([](NMR::PLib3MFBase** p) { return NMR::lib3mf_createmodel(p); });
    auto materials = make([&](NMR::PLib3MFBase** p)
                          { return NMR::lib3mf_model_addbasematerialgroup(model.get(), p); });
    DWORD red = 0;
    DWORD blue = 0;
    EXPECT_EQ(NMR::lib3mf_basematerial_addmaterialutf8(materials.get(), "red", 255, 0, 0, &red), 0);
    EXPECT_EQ(NMR::lib3mf_basematerial_addmaterialutf8(materials.get(), "blue", 0, 0, 255, &blue),
              0);
    DWORD group = 0;
    EXPECT_EQ(NMR::lib3mf_resource_getresourceid(materials.get(), &group), 0);

    auto a =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_addmeshobject(model.get(), p); });
    set_box(a.get());
    EXPECT_EQ(NMR::lib3mf_object_setnameutf8(a.get(), "box A"), 0);
    auto handler = make([&](NMR::PLib3MFBase** p)
                        { return NMR::lib3mf_meshobject_createpropertyhandler(a.get(), p); });
    for (DWORD f = 0; f < 12; ++f)
    {
        EXPECT_EQ(NMR::lib3mf_propertyhandler_setbasematerial(handler.get(), f, group,
                                                              f % 2 == 0 ? red : blue),
                  0);
    }
    // lib3mf refuses to write triangle properties without an object default property.
    auto defaults = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_object_createdefaultpropertyhandler(a.get(), p); });
    EXPECT_EQ(NMR::lib3mf_defaultpropertyhandler_setbasematerial(defaults.get(), group, red), 0);
    auto b =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_addmeshobject(model.get(), p); });
    set_box(b.get());
    EXPECT_EQ(NMR::lib3mf_object_setnameutf8(b.get(), "box B"), 0);
    auto parts = make([&](NMR::PLib3MFBase** p)
                      { return NMR::lib3mf_model_addcomponentsobject(model.get(), p); });
    NMR::MODELTRANSFORM scale2 = transform(2.0f, 0.0f, 0.0f, 0.0f);
    auto component = make(
        [&](NMR::PLib3MFBase** p)
        { return NMR::lib3mf_componentsobject_addcomponent(parts.get(), b.get(), &scale2, p); });

    NMR::MODELTRANSFORM ta = transform(2.0f, 1.0f, 0.0f, 0.0f);
    auto item_a = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_addbuilditem(model.get(), a.get(), &ta, p); });
    NMR::MODELTRANSFORM tb = transform(1.0f, 3.0f, 0.0f, 0.0f);
    auto item_b =
        make([&](NMR::PLib3MFBase** p)
             { return NMR::lib3mf_model_addbuilditem(model.get(), parts.get(), &tb, p); });
    EXPECT_EQ(NMR::lib3mf_model_addmetadatautf8(model.get(), "Title", "two boxes"), 0);
    EXPECT_EQ(NMR::lib3mf_model_addmetadatautf8(model.get(), "Designer", "meshmark tests"), 0);

    // Debian's lib3mf 1.8 cannot write to a buffer: write a file and read it.
    auto writer = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_querywriter(model.get(), "3mf", p); });
    const fs::path file = test::temp_dir("three_mf_fixture") / "fixture.3mf";
    EXPECT_EQ(NMR::lib3mf_writer_writetofileutf8(writer.get(), file.string().c_str()), 0);
    return test::file_bytes(file);
}

// Everything lib3mf exposes about a package except vertex coordinates, as text.
struct Summary
{
    std::string structure;
    std::vector<std::vector<float>> vertices;  // per mesh object
};

Summary summarize(const fs::path& path)
{
    Summary s;
    auto model = make([](NMR::PLib3MFBase** p) { return NMR::lib3mf_createmodel(p); });
    auto reader = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_queryreader(model.get(), "3mf", p); });
    EXPECT_EQ(NMR::lib3mf_reader_readfromfileutf8(reader.get(), path.string().c_str()), 0);
    DWORD count = 0;
    EXPECT_EQ(NMR::lib3mf_model_getmetadatacount(model.get(), &count), 0);
    for (DWORD m = 0; m < count; ++m)
    {
        char key[256] = {};
        char value[256] = {};
        ULONG needed = 0;
        NMR::lib3mf_model_getmetadatakeyutf8(model.get(), m, key, sizeof(key), &needed);
        NMR::lib3mf_model_getmetadatavalueutf8(model.get(), m, value, sizeof(value), &needed);
        s.structure += std::string("meta ") + key + "=" + value + "\n";
    }
    auto meshes = make([&](NMR::PLib3MFBase** p)
                       { return NMR::lib3mf_model_getmeshobjects(model.get(), p); });
    BOOL has = 0;
    while (NMR::lib3mf_resourceiterator_movenext(meshes.get(), &has) == 0 && has != 0)
    {
        auto mesh = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_resourceiterator_getcurrent(meshes.get(), p); });
        DWORD id = 0;
        DWORD nv = 0;
        DWORD nt = 0;
        char name[256] = {};
        ULONG needed = 0;
        NMR::lib3mf_resource_getresourceid(mesh.get(), &id);
        NMR::lib3mf_object_getnameutf8(mesh.get(), name, sizeof(name), &needed);
        NMR::lib3mf_meshobject_getvertexcount(mesh.get(), &nv);
        NMR::lib3mf_meshobject_gettrianglecount(mesh.get(), &nt);
        s.structure += "mesh " + std::to_string(id) + " '" + name + "' " + std::to_string(nv) +
                       " " + std::to_string(nt) + "\n";
        std::vector<NMR::MODELMESHTRIANGLE> t(nt);
        NMR::lib3mf_meshobject_gettriangleindices(mesh.get(), t.data(), nt, nullptr);
        auto handler =
            make([&](NMR::PLib3MFBase** p)
                 { return NMR::lib3mf_meshobject_createpropertyhandler(mesh.get(), p); });
        for (DWORD f = 0; f < nt; ++f)
        {
            DWORD g = 0;
            DWORD i = 0;
            NMR::lib3mf_propertyhandler_getbasematerial(handler.get(), f, &g, &i);
            s.structure += " t " + std::to_string(t[f].m_nIndices[0]) + " " +
                           std::to_string(t[f].m_nIndices[1]) + " " +
                           std::to_string(t[f].m_nIndices[2]) + " m " + std::to_string(g) + ":" +
                           std::to_string(i) + "\n";
        }
        std::vector<NMR::MODELMESHVERTEX> v(nv);
        NMR::lib3mf_meshobject_getvertices(mesh.get(), v.data(), nv, nullptr);
        s.vertices.emplace_back();
        for (const auto& x : v)
        {
            s.vertices.back().insert(s.vertices.back().end(),
                                     {x.m_fPosition[0], x.m_fPosition[1], x.m_fPosition[2]});
        }
    }
    auto items =
        make([&](NMR::PLib3MFBase** p) { return NMR::lib3mf_model_getbuilditems(model.get(), p); });
    while (NMR::lib3mf_builditemiterator_movenext(items.get(), &has) == 0 && has != 0)
    {
        auto item = make([&](NMR::PLib3MFBase** p)
                         { return NMR::lib3mf_builditemiterator_getcurrent(items.get(), p); });
        DWORD id = 0;
        NMR::MODELTRANSFORM t{};
        NMR::lib3mf_builditem_getobjectresourceid(item.get(), &id);
        NMR::lib3mf_builditem_getobjecttransform(item.get(), &t);
        s.structure += "item " + std::to_string(id);
        for (const auto& row : t.m_fFields)
        {
            for (const float x : row)
            {
                s.structure += " " + std::to_string(x);
            }
        }
        s.structure += "\n";
    }
    return s;
}

class ThreeMfTest : public ::testing::Test
{
protected:
    fs::path dir = test::temp_dir("three_mf_test");
};

TEST_F(ThreeMfTest, reads_objects_in_the_build_frame_welded)
{
    test::put_bytes(dir / "boxes.3mf", two_box_package());
    const MeshFile file = read_mesh_file(dir / "boxes.3mf");
    EXPECT_EQ(file.format, MeshFormat::ThreeMf);
    // 8 + 8 corners, 4 shared on the face x = 3.
    EXPECT_EQ(file.mesh.V.rows(), 12);
    EXPECT_EQ(file.mesh.F.rows(), 24);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(0).minCoeff(), 1.0);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(0).maxCoeff(), 5.0);
    EXPECT_DOUBLE_EQ(file.mesh.V.col(2).maxCoeff(), 2.0);
}

TEST_F(ThreeMfTest, round_trip_changes_only_vertex_coordinates)
{
    const std::string package = two_box_package();
    test::put_bytes(dir / "in.3mf", package);
    const MeshFile file = read_mesh_file(dir / "in.3mf");
    write_mesh_file(dir / "same.3mf", file, file.mesh.V);
    EXPECT_EQ(test::file_bytes(dir / "same.3mf"), package);

    Positions moved = file.mesh.V;
    for (Eigen::Index i = 0; i < moved.rows(); ++i)
    {
        moved(i, 1) += 0.01 * static_cast<double>(i + 1);
    }
    write_mesh_file(dir / "out.3mf", file, moved);
    const Summary before = summarize(dir / "in.3mf");
    const Summary after = summarize(dir / "out.3mf");
    EXPECT_EQ(after.structure, before.structure);
    ASSERT_EQ(after.vertices.size(), 2U);
    EXPECT_NE(after.vertices, before.vertices);

    const MeshFile again = read_mesh_file(dir / "out.3mf");
    ASSERT_EQ(again.mesh.V.rows(), moved.rows());
    EXPECT_EQ(again.mesh.F, file.mesh.F);
    // lib3mf writes coordinates with 6 decimals ("%f"): up to 1e-6 in local units, times the
    // transforms' scale 2, plus float32 rounding.
    EXPECT_LT((again.mesh.V - moved).cwiseAbs().maxCoeff(), 2.5e-6);
}

TEST_F(ThreeMfTest, generic_writer_and_bad_packages)
{
    TriangleMesh mesh;
    mesh.V.resize(4, 3);
    mesh.V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
    mesh.F.resize(4, 3);
    mesh.F << 0, 2, 1, 0, 1, 3, 1, 2, 3, 2, 0, 3;
    write_mesh(dir / "w.3mf", mesh);
    const TriangleMesh again = read_mesh(dir / "w.3mf");
    EXPECT_EQ(again.F, mesh.F);
    EXPECT_EQ(again.V, mesh.V);

    const std::string package = two_box_package();
    test::put_bytes(dir / "cut.3mf", package.substr(0, package.size() / 2));
    try
    {
        static_cast<void>(read_mesh_file(dir / "cut.3mf"));
        FAIL() << "accepted";
    }
    catch (const IoError& e)
    {
        EXPECT_NE(std::string(e.what()).find("cut.3mf"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace meshmark

// SPDX-License-Identifier: MIT
// 3MF test packages zipped with libzip from hand-written XML, as slicers write them
// (PrusaSlicer with its config and a thumbnail relationship whose part is missing, Bambu/Orca
// style production-extension parts), and their entries as libzip reads them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <regex>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <zip.h>

#include "io_test_support.h"
#include "meshmark/io/mesh_io.h"

namespace meshmark::test
{

struct Entry
{
    std::string name;
    std::string content;  // uncompressed
    std::string raw;      // compressed bytes as stored
    zip_uint16_t method = 0;
};

inline std::vector<Entry> entries_of(const std::string& bytes)
{
    std::vector<Entry> entries;
    zip_error_t error;
    zip_error_init(&error);
    zip_source_t* source = zip_source_buffer_create(bytes.data(), bytes.size(), 0, &error);
    zip_t* archive = source == nullptr ? nullptr : zip_open_from_source(source, ZIP_RDONLY, &error);
    zip_error_fini(&error);
    if (archive == nullptr)
    {
        ADD_FAILURE() << "not a zip archive";
        zip_source_free(source);
        return entries;
    }
    const auto count = static_cast<zip_uint64_t>(zip_get_num_entries(archive, 0));
    for (zip_uint64_t i = 0; i < count; ++i)
    {
        zip_stat_t stat;
        zip_stat_init(&stat);
        EXPECT_EQ(zip_stat_index(archive, i, 0, &stat), 0);
        Entry entry;
        entry.name = stat.name;
        entry.method = stat.comp_method;
        for (const zip_flags_t flags : {zip_flags_t{0}, zip_flags_t{ZIP_FL_COMPRESSED}})
        {
            std::string& data = flags == 0 ? entry.content : entry.raw;
            data.resize(flags == 0 ? stat.size : stat.comp_size);
            zip_file_t* file = zip_fopen_index(archive, i, flags);
            EXPECT_NE(file, nullptr);
            if (file != nullptr)
            {
                EXPECT_EQ(zip_fread(file, data.data(), data.size()),
                          static_cast<zip_int64_t>(data.size()));
                zip_fclose(file);
            }
        }
        entries.push_back(std::move(entry));
    }
    zip_discard(archive);
    return entries;
}

using Parts = std::vector<std::pair<std::string, std::string>>;

// A zip archive of \p parts in this order, each compressed with \p method.
inline std::string make_zip(const std::filesystem::path& dir, const Parts& parts,
                            zip_int32_t method = ZIP_CM_DEFLATE)
{
    const std::filesystem::path file = dir / "made.zip";
    int code = 0;
    zip_t* archive = zip_open(file.string().c_str(), ZIP_CREATE | ZIP_TRUNCATE, &code);
    EXPECT_NE(archive, nullptr);
    for (const auto& [name, content] : parts)
    {
        zip_source_t* source = zip_source_buffer(archive, content.data(), content.size(), 0);
        const zip_int64_t index = zip_file_add(archive, name.c_str(), source, 0);
        EXPECT_GE(index, 0);
        EXPECT_EQ(zip_set_file_compression(archive, static_cast<zip_uint64_t>(index), method, 0),
                  0);
    }
    EXPECT_EQ(zip_close(archive), 0);
    return test::file_bytes(file);
}

inline const std::string kContentTypes = R"(<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
 <Default Extension="png" ContentType="image/png"/>
</Types>
)";

// As PrusaSlicer 2.5 writes it headless: the thumbnail relationship stays, the part does not.
inline const std::string kPrusaRels = R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
 <Relationship Target="/Metadata/thumbnail.png" Id="rel-2" Type="http://schemas.openxmlformats.org/package/2006/relationships/metadata/thumbnail"/>
</Relationships>
)";

// The vertices of a box [0, size]^3 as <vertex> lines, written in a few legal spellings
// (single quotes, spaces around '=', attributes out of order, a character reference).
inline std::string box_vertices(const std::string& size)
{
    return "     <vertex x=\"0\" y=\"0\" z=\"0\"/>\n"
           "     <vertex x=\"" +
           size +
           "\" y=\"0\" z=\"0\"/>\n"
           "     <vertex z='0' y = \"" +
           size +
           "\" x=\"0\" />\n"
           "     <vertex x=\"" +
           size + "\" y=\"" + size +
           "\" z=\"0\"/>\n"
           "     <vertex x=\"0.0000000\" y=\"0\" z=\"" +
           size +
           "\"/>\n"
           "     <vertex x=\"" +
           size + "\"\n         y=\"0\" z=\"" + size +
           "\"/>\n"
           "     <vertex x=\"0\" y=\"" +
           size + "\" z=\"&#32;" + size +
           "\"/>\n"
           "     <vertex x=\"" +
           size + "\" y=\"" + size + "\" z=\"" + size + "\"/>\n";
}

inline const std::string kBoxTriangles =
    "     <triangle v1=\"0\" v2=\"2\" v3=\"1\"/>\n     <triangle v1=\"1\" v2=\"2\" v3=\"3\"/>\n"
    "     <triangle v1=\"4\" v2=\"5\" v3=\"6\"/>\n     <triangle v1=\"5\" v2=\"7\" v3=\"6\"/>\n"
    "     <triangle v1=\"0\" v2=\"1\" v3=\"4\"/>\n     <triangle v1=\"1\" v2=\"5\" v3=\"4\"/>\n"
    "     <triangle v1=\"2\" v2=\"6\" v3=\"3\"/>\n     <triangle v1=\"3\" v2=\"6\" v3=\"7\"/>\n"
    "     <triangle v1=\"0\" v2=\"4\" v3=\"2\"/>\n     <triangle v1=\"2\" v2=\"4\" v3=\"6\"/>\n"
    "     <triangle v1=\"1\" v2=\"3\" v3=\"5\"/>\n     <triangle v1=\"3\" v2=\"7\" v3=\"5\"/>\n";

inline std::string box_object(const std::string& id, const std::string& size,
                              const std::string& attributes = "",
                              const std::string& triangles = kBoxTriangles)
{
    return "  <object id=\"" + id + "\" type=\"model\"" + attributes +
           ">\n   <mesh>\n    <vertices>\n" + box_vertices(size) +
           "    </vertices>\n    <triangles>\n" + triangles +
           "    </triangles>\n   </mesh>\n  </object>\n";
}

// A PrusaSlicer 2.5 style model: its namespace and metadata, a vendor element, one box of
// 20 mm placed at (100, 100, 10) by the build item.
inline std::string prusa_model(const std::string& object)
{
    return R"(<?xml version="1.0" encoding="UTF-8"?>
<model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02" xmlns:slic3rpe="http://schemas.slic3r.org/3mf/2017/06">
 <metadata name="slic3rpe:Version3mf">1</metadata>
 <metadata name="Title">box &amp; more</metadata>
 <metadata name="Application">PrusaSlicer-2.5.0</metadata>
 <!-- a comment -->
 <slic3rpe:extra note="kept"/>
 <resources>
)" + object +
           R"( </resources>
 <build>
  <item objectid="1" transform="1 0 0 0 1 0 0 0 1 100 100 10" printable="1"/>
 </build>
</model>
)";
}

inline const std::string kPrusaConfig = R"(<?xml version="1.0" encoding="UTF-8"?>
<config>
 <object id="1" instances_count="1">
  <metadata type="object" key="name" value="box.stl"/>
  <volume firstid="0" lastid="11">
   <metadata type="volume" key="matrix" value="1 0 0 10 0 1 0 10 0 0 1 10 0 0 0 1"/>
  </volume>
 </object>
</config>
)";

inline Parts prusa_parts(const std::string& model)
{
    return {{"[Content_Types].xml", kContentTypes},
            {"_rels/.rels", kPrusaRels},
            {"3D/3dmodel.model", model},
            {"Metadata/Slic3r_PE_model.config", kPrusaConfig}};
}

// A Bambu Studio / Orca style package: the root model holds one components object whose
// components are two boxes in another model part (production extension p:path; OPC part
// names are case-insensitive, so both paths name the same part).
inline const std::string kProductionRoot = R"(<?xml version="1.0" encoding="UTF-8"?>
<model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02" xmlns:BambuStudio="http://schemas.bambulab.com/package/2021" xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p">
 <metadata name="Application">BambuStudio-01.08.00.57</metadata>
 <metadata name="BambuStudio:3mfVersion">1</metadata>
 <resources>
  <object id="2" p:UUID="00000001-61cb-4c03-9d28-80fed5dfa1dc" type="model">
   <components>
    <component p:path="/3D/Objects/object_1.model" objectid="1" p:UUID="00010000-b206-40ff-9872-83e8017abed1" transform="1 0 0 0 1 0 0 0 1 0 0 0"/>
    <component p:path="/3D/objects/Object_1.model" objectid="3" p:UUID="00010001-b206-40ff-9872-83e8017abed1" transform="2 0 0 0 2 0 0 0 2 30 0 0"/>
   </components>
  </object>
 </resources>
 <build p:UUID="2c7c17d8-22b5-4d84-8835-1976022ea369">
  <item objectid="2" p:UUID="00000002-b1ec-4553-aec9-835e5b724bb4" transform="1 0 0 0 1 0 0 0 1 128 128 5" printable="1"/>
 </build>
</model>
)";

inline std::string production_objects()
{
    return R"(<?xml version="1.0" encoding="UTF-8"?>
<model unit="millimeter" xml:lang="en-US" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02" xmlns:BambuStudio="http://schemas.bambulab.com/package/2021" xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p">
 <metadata name="BambuStudio:3mfVersion">1</metadata>
 <resources>
)" + box_object("1", "10", " p:UUID=\"00010000-81cb-4c03-9d28-80fed5dfa1dc\"") +
           box_object("3", "10.0000001", " p:UUID=\"00030000-81cb-4c03-9d28-80fed5dfa1dc\"") +
           R"( </resources>
 <build/>
</model>
)";
}

inline Parts production_parts()
{
    return {{"[Content_Types].xml", kContentTypes},
            {"_rels/.rels", R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
 <Relationship Target="/Metadata/plate_1.png" Id="rel-2" Type="http://schemas.openxmlformats.org/package/2006/relationships/metadata/thumbnail"/>
</Relationships>
)"},
            {"3D/3dmodel.model", kProductionRoot},
            {"3D/_rels/3dmodel.model.rels", R"(<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/Objects/object_1.model" Id="rel-1" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
)"},
            {"3D/Objects/object_1.model", production_objects()},
            {"Metadata/plate_1.png", std::string("\x89PNG\r\n\x1a\n\0\0\0\rIHDR", 16)},
            {"Metadata/model_settings.config", "<?xml version=\"1.0\"?>\n<config/>\n"}};
}

// The model text with every x/y/z value of a <vertex> element replaced by '@', and the values
// in file order. Written independently of the reader: a regular expression per element.
struct Masked
{
    std::string text;
    std::vector<std::string> values;
};

inline Masked mask_vertex_values(const std::string& text)
{
    Masked masked;
    const std::regex element(R"(<vertex\s[^>]*>)");
    const std::regex attribute(R"((\s[xyz]\s*=\s*)(["'])([^"']*)(["']))");
    std::size_t at = 0;
    for (auto e = std::sregex_iterator(text.begin(), text.end(), element);
         e != std::sregex_iterator(); ++e)
    {
        const auto start = static_cast<std::size_t>(e->position());
        masked.text.append(text, at, start - at);
        const std::string tag = e->str();
        std::size_t tag_at = 0;
        for (auto a = std::sregex_iterator(tag.begin(), tag.end(), attribute);
             a != std::sregex_iterator(); ++a)
        {
            masked.text.append(tag, tag_at, static_cast<std::size_t>(a->position(3)) - tag_at);
            masked.text += '@';
            masked.values.push_back((*a)[3].str());
            tag_at = static_cast<std::size_t>(a->position(4));
        }
        masked.text.append(tag, tag_at, std::string::npos);
        at = start + tag.size();
    }
    masked.text.append(text, at, std::string::npos);
    return masked;
}

// Set the declared uncompressed size of entry \p name in its local and central headers.
inline void patch_declared_size(std::string& zip, const std::string& name, std::uint32_t size)
{
    const auto put32 = [&](std::size_t at, std::uint32_t value)
    {
        for (int b = 0; b < 4; ++b)
        {
            zip[at + static_cast<std::size_t>(b)] = static_cast<char>((value >> (8 * b)) & 0xffU);
        }
    };
    const auto get16 = [&](std::size_t at)
    {
        return static_cast<std::size_t>(static_cast<unsigned char>(zip[at])) |
               (static_cast<std::size_t>(static_cast<unsigned char>(zip[at + 1])) << 8U);
    };
    int patched = 0;
    for (std::size_t at = 0; at + 46 < zip.size(); ++at)
    {
        if (zip.compare(at, 4, "PK\x03\x04") == 0 && zip.compare(at + 30, name.size(), name) == 0 &&
            get16(at + 26) == name.size())
        {
            put32(at + 22, size);
            ++patched;
        }
        if (zip.compare(at, 4, "PK\x01\x02") == 0 && zip.compare(at + 46, name.size(), name) == 0 &&
            get16(at + 28) == name.size())
        {
            put32(at + 24, size);
            ++patched;
        }
    }
    ASSERT_EQ(patched, 2);
}

// The message of the meshmark error that reading \p path throws ("" if it reads).
template <typename E>
inline std::string read_error(const std::filesystem::path& path)
{
    try
    {
        static_cast<void>(read_mesh_file(path));
    }
    catch (const E& e)
    {
        return e.what();
    }
    return "";
}

}  // namespace meshmark::test

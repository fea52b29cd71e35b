// SPDX-License-Identifier: MIT
// Builds small glTF assets for the io tests: one binary buffer, accessors, meshes and nodes,
// saved as .glb, as .gltf with a data: URI, or as .gltf with an external .bin.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "io_test_support.h"

namespace meshmark::test
{

using Json = nlohmann::ordered_json;

inline std::string base64(const std::string& bytes)
{
    static const char* kAlphabet =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    std::size_t i = 0;
    for (; i + 2 < bytes.size(); i += 3)
    {
        const auto v = (static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16U) |
                       (static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8U) |
                       static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 2]));
        for (int s = 18; s >= 0; s -= 6)
        {
            out += kAlphabet[(v >> static_cast<unsigned>(s)) & 63U];
        }
    }
    if (i < bytes.size())
    {
        auto v = static_cast<unsigned>(static_cast<unsigned char>(bytes[i])) << 16U;
        if (i + 1 < bytes.size())
        {
            v |= static_cast<unsigned>(static_cast<unsigned char>(bytes[i + 1])) << 8U;
        }
        out += kAlphabet[(v >> 18U) & 63U];
        out += kAlphabet[(v >> 12U) & 63U];
        out += i + 1 < bytes.size() ? kAlphabet[(v >> 6U) & 63U] : '=';
        out += '=';
    }
    return out;
}

/// A glTF asset under construction: JSON plus one binary buffer.
struct GltfBuilder
{
    Json doc = Json::object();
    std::string bin;
    /// Buffers 1, 2, ... as JSON objects (buffer 0 is \c bin).
    Json more_buffers = Json::array();

    GltfBuilder()
    {
        doc["asset"] = {
            {"version", "2.0"}, {"generator", "meshmark tests"}, {"extras", {{"k", 1}}}};
        doc["scene"] = 0;
        doc["scenes"] = Json::array({Json::object({{"nodes", Json::array()}})});
        doc["nodes"] = Json::array();
        doc["meshes"] = Json::array();
        doc["accessors"] = Json::array();
        doc["bufferViews"] = Json::array();
        doc["materials"] = Json::array(
            {{{"name", "red"}, {"pbrMetallicRoughness", {{"baseColorFactor", {1, 0, 0, 1}}}}}});
    }

    void align()
    {
        while (bin.size() % 4 != 0)
        {
            bin.push_back('\0');
        }
    }

    /// Append raw bytes as a new bufferView; returns its index.
    int view(const std::string& bytes, int stride = 0)
    {
        align();
        Json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes.size()}};
        if (stride > 0)
        {
            v["byteStride"] = stride;
        }
        bin += bytes;
        doc["bufferViews"].push_back(v);
        return static_cast<int>(doc["bufferViews"].size() - 1);
    }

    template <typename T>
    static std::string raw(const std::vector<T>& values)
    {
        std::string s(values.size() * sizeof(T), '\0');
        std::memcpy(s.data(), values.data(), s.size());
        return s;
    }

    int accessor(int view_index, std::size_t offset, int component, std::size_t count,
                 const char* type, bool normalized = false)
    {
        Json a = {{"bufferView", view_index},
                  {"byteOffset", offset},
                  {"componentType", component},
                  {"count", count},
                  {"type", type}};
        if (normalized)
        {
            a["normalized"] = true;
        }
        doc["accessors"].push_back(a);
        return static_cast<int>(doc["accessors"].size() - 1);
    }

    /// A float VEC3 accessor in its own tightly packed view, with min/max.
    int positions(const std::vector<float>& xyz)
    {
        const int a = accessor(view(raw(xyz)), 0, 5126, xyz.size() / 3, "VEC3");
        set_bounds(a, xyz);
        return a;
    }

    void set_bounds(int a, const std::vector<float>& xyz)
    {
        std::array<float, 3> lo{1e30f, 1e30f, 1e30f};
        std::array<float, 3> hi{-1e30f, -1e30f, -1e30f};
        for (std::size_t k = 0; k < xyz.size(); ++k)
        {
            lo[k % 3] = std::min(lo[k % 3], xyz[k]);
            hi[k % 3] = std::max(hi[k % 3], xyz[k]);
        }
        doc["accessors"][static_cast<std::size_t>(a)]["min"] = lo;
        doc["accessors"][static_cast<std::size_t>(a)]["max"] = hi;
    }

    int indices(const std::vector<std::uint16_t>& values)
    {
        return accessor(view(raw(values)), 0, 5123, values.size(), "SCALAR");
    }

    int mesh(const Json& primitives)
    {
        doc["meshes"].push_back({{"primitives", primitives}});
        return static_cast<int>(doc["meshes"].size() - 1);
    }

    int node(Json node_json, bool is_root = true)
    {
        doc["nodes"].push_back(std::move(node_json));
        const int n = static_cast<int>(doc["nodes"].size() - 1);
        if (is_root)
        {
            doc["scenes"][0]["nodes"].push_back(n);
        }
        return n;
    }

    [[nodiscard]] std::string glb() const
    {
        Json d = doc;
        std::string b = bin;
        while (b.size() % 4 != 0)
        {
            b.push_back('\0');
        }
        d["buffers"] = Json::array({{{"byteLength", bin.size()}}});
        for (const auto& extra : more_buffers)
        {
            d["buffers"].push_back(extra);
        }
        std::string json = d.dump();
        while (json.size() % 4 != 0)
        {
            json.push_back(' ');
        }
        std::string out;
        const auto u32 = [&out](std::uint32_t v)
        {
            for (unsigned s = 0; s < 32; s += 8)
            {
                out.push_back(static_cast<char>((v >> s) & 0xffU));
            }
        };
        u32(0x46546C67U);
        u32(2);
        u32(static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + b.size()));
        u32(static_cast<std::uint32_t>(json.size()));
        u32(0x4E4F534AU);
        out += json;
        u32(static_cast<std::uint32_t>(b.size()));
        u32(0x004E4942U);
        out += b;
        return out;
    }

    /// .gltf text with the buffer as a data: URI, or as \p bin_name beside it.
    [[nodiscard]] std::string gltf(const std::string& bin_name = "") const
    {
        Json d = doc;
        d["buffers"] = Json::array(
            {{{"byteLength", bin.size()},
              {"uri", bin_name.empty() ? "data:application/octet-stream;base64," + base64(bin)
                                       : bin_name}}});
        for (const auto& extra : more_buffers)
        {
            d["buffers"].push_back(extra);
        }
        return d.dump(2);
    }
};

/// The JSON chunk of a GLB file's bytes, and its BIN chunk payload in \p bin when asked
/// (empty when there is none).
inline Json glb_json(const std::string& bytes, std::string* bin = nullptr)
{
    const auto u32 = [&bytes](std::size_t o)
    {
        std::uint32_t v = 0;
        std::memcpy(&v, bytes.data() + o, 4);
        return v;
    };
    const std::size_t json_length = u32(12);
    if (bin != nullptr)
    {
        const std::size_t bin_at = 20 + json_length;
        *bin = bin_at + 8 <= bytes.size() ? bytes.substr(bin_at + 8, u32(bin_at)) : std::string();
    }
    return Json::parse(bytes.substr(20, json_length));
}

/// Little-endian float32 at byte \p offset of \p bytes.
inline float float_at(const std::string& bytes, std::size_t offset)
{
    float v = 0.0f;
    std::memcpy(&v, bytes.data() + offset, sizeof(float));
    return v;
}

/// \brief An arm that bends: the triangles \p idx over positions \p xyz, skinned to a shoulder
/// joint at the origin and an elbow joint at x = \p elbow (weights blending linearly from the
/// shoulder to the elbow over x in [elbow - blend, elbow + blend]), stored straight (the scene
/// pose is the bind pose). Its first animation lifts the shoulder by \p lift in y (a STEP key at
/// 0.02 s) and turns the elbow about z from 0 at t = 0 to \p turn radians at t = 0.1 s
/// (LINEAR; the second key stored as the negated quaternion, which an importer must bring into
/// the first key's hemisphere). A second animation would straighten everything again.
struct BendingArm
{
    double elbow = 0.0;
    double blend = 0.4;
    double turn = 100.0 * 3.14159265358979323846 / 180.0;
    double lift = 0.3;
    bool is_bend_first =
        true;  // "bend" is the file's first animation, else its second (after "straight")

    /// The elbow's weight at \p x.
    [[nodiscard]] double weight(double x) const
    {
        return std::clamp((x - (elbow - blend)) / (2.0 * blend), 0.0, 1.0);
    }

    [[nodiscard]] std::string glb(const std::vector<float>& xyz,
                                  const std::vector<std::uint16_t>& idx) const
    {
        GltfBuilder b;
        const std::size_t n = xyz.size() / 3;
        std::vector<std::uint8_t> joints(4 * n, 0);
        std::vector<float> weights(4 * n, 0.0f);
        for (std::size_t v = 0; v < n; ++v)
        {
            const double w = weight(xyz[3 * v]);
            joints[4 * v + 1] = 1;
            weights[4 * v] = static_cast<float>(1.0 - w);
            weights[4 * v + 1] = static_cast<float>(w);
        }
        const int pos = b.positions(xyz);
        const int joint_acc = b.accessor(b.view(GltfBuilder::raw(joints)), 0, 5121, n, "VEC4");
        const int weight_acc = b.accessor(b.view(GltfBuilder::raw(weights)), 0, 5126, n, "VEC4");
        const int mesh = b.mesh(
            Json::array({{{"attributes",
                           {{"POSITION", pos}, {"JOINTS_0", joint_acc}, {"WEIGHTS_0", weight_acc}}},
                          {"indices", b.indices(idx)}}}));
        return rig(b, mesh);
    }

    /// The skeleton, its skin on mesh \p mesh of \p b (a primitive with JOINTS_0 and WEIGHTS_0
    /// as glb() makes them) and the animations: the asset as a GLB.
    [[nodiscard]] std::string rig(GltfBuilder& b, int mesh) const
    {
        const auto e = static_cast<float>(elbow);
        const std::vector<float> ibm{
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0,  0, 0, 1,   //
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -e, 0, 0, 1};  // column-major
        const int ibm_acc = b.accessor(b.view(GltfBuilder::raw(ibm)), 0, 5126, 2, "MAT4");
        const int elbow_node =
            b.node({{"name", "elbow"}, {"translation", {elbow, 0.0, 0.0}}}, false);
        const int shoulder = b.node({{"name", "shoulder"}, {"children", {elbow_node}}});
        b.node({{"mesh", mesh}, {"skin", 0}});
        b.doc["skins"] =
            Json::array({{{"joints", {shoulder, elbow_node}}, {"inverseBindMatrices", ibm_acc}}});
        const auto floats = [&](const std::vector<float>& values, const char* type)
        {
            const std::size_t width = std::string(type) == "SCALAR" ? 1
                                      : std::string(type) == "VEC3" ? 3
                                                                    : 4;
            return b.accessor(b.view(GltfBuilder::raw(values)), 0, 5126, values.size() / width,
                              type);
        };
        const std::vector<float> times{0.0f, 0.02f};
        const std::vector<float> turn_times{0.0f, 0.1f};
        const auto h = static_cast<float>(turn / 2.0);
        const int lift_at = floats(times, "SCALAR");
        const int lifts = floats({0.0f, 0.0f, 0.0f, 0.0f, static_cast<float>(lift), 0.0f}, "VEC3");
        const int turn_at = floats(turn_times, "SCALAR");
        const int turns =
            floats({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, -std::sin(h), -std::cos(h)}, "VEC4");
        const int straight = floats({0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f, 0.0f, 1.0f}, "VEC4");
        const Json bend = {
            {"name", "bend"},
            {"samplers",
             {{{"input", lift_at}, {"output", lifts}, {"interpolation", "STEP"}},
              {{"input", turn_at}, {"output", turns}}}},
            {"channels",
             {{{"sampler", 0}, {"target", {{"node", shoulder}, {"path", "translation"}}}},
              {{"sampler", 1}, {"target", {{"node", elbow_node}, {"path", "rotation"}}}}}}};
        const Json still = {
            {"name", "straight"},
            {"samplers", {{{"input", turn_at}, {"output", straight}}}},
            {"channels",
             {{{"sampler", 0}, {"target", {{"node", elbow_node}, {"path", "rotation"}}}}}}};
        b.doc["animations"] =
            is_bend_first ? Json::array({bend, still}) : Json::array({still, bend});
        return b.glb();
    }

    /// Where Blender shows a stored point \p p after import (1/24 s into the first animation):
    /// the elbow's turn interpolated as Blender does (quaternion components, then normalized).
    [[nodiscard]] Eigen::Vector3d shown(const Eigen::Vector3d& p) const
    {
        return shown(p, weight(p.x()));
    }

    /// The same for a point \p p skinned with elbow weight \p w, at \p t seconds into the
    /// animation.
    [[nodiscard]] Eigen::Vector3d shown(const Eigen::Vector3d& p, double w,
                                        double t = 1.0 / 24.0) const
    {
        const double s = std::clamp(t / 0.1, 0.0, 1.0);
        const double angle =
            2.0 * std::atan2(s * std::sin(turn / 2.0), (1.0 - s) + s * std::cos(turn / 2.0));
        const Eigen::Affine3d shoulder(Eigen::Translation3d(0.0, t >= 0.02 ? lift : 0.0, 0.0));
        const Eigen::Affine3d elbow_world = shoulder * Eigen::Translation3d(elbow, 0.0, 0.0) *
                                            Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()) *
                                            Eigen::Translation3d(-elbow, 0.0, 0.0);
        return (1.0 - w) * (shoulder * p) + w * (elbow_world * p);
    }
};

/// A strip of 2 x (segments + 1) vertices along x from \p x0 in steps of \p dx, 0.2 wide, its z
/// zigzagging by 0.05 (not flat), two triangles per segment: positions (3 per vertex) and indices.
inline std::pair<std::vector<float>, std::vector<std::uint16_t>> strip(int segments, float x0,
                                                                       float dx)
{
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    for (int i = 0; i <= segments; ++i)
    {
        for (int j = 0; j <= 1; ++j)
        {
            xyz.insert(xyz.end(), {x0 + dx * static_cast<float>(i), 0.2f * static_cast<float>(j),
                                   0.05f * static_cast<float>(i % 3)});
        }
    }
    for (int i = 0; i < segments; ++i)
    {
        const auto a = static_cast<std::uint16_t>(2 * i);
        idx.insert(idx.end(),
                   {a, static_cast<std::uint16_t>(a + 2), static_cast<std::uint16_t>(a + 1),
                    static_cast<std::uint16_t>(a + 1), static_cast<std::uint16_t>(a + 2),
                    static_cast<std::uint16_t>(a + 3)});
    }
    return {xyz, idx};
}

/// \p V moved by a small field (1e-3 to 2e-3 per vertex), as a mark moves a mesh.
inline Positions nudged(Positions V)
{
    for (Eigen::Index i = 0; i < V.rows(); ++i)
    {
        V.row(i) += Eigen::RowVector3d(1e-3 * std::sin(static_cast<double>(i)), 2e-3,
                                       -1e-3 * static_cast<double>(i % 2));
    }
    return V;
}

/// A skinned strip whose scene pose is not its bind pose (a converted character: the knee
/// bent): 9 x 2 vertices along x from 0 to 2, joint 0 (hip) below x = 0.75, joint 1 (knee)
/// beyond 1.25, blended between, the weights summing to 2 on purpose (an exporter that does not
/// normalize them). Bind pose: hip at the origin, knee at x = 1. Scene pose: the hip moved up by
/// 0.5 and the knee bent by 40 degrees about z; the mesh node's own scale and translation, which
/// glTF ignores for a skinned mesh, are 3 and (7, 0, 0).
struct KneeRig
{
    std::vector<float> xyz;
    std::vector<std::uint16_t> idx;
    std::vector<std::uint8_t> joints;
    std::vector<float> weights;
    double angle = 40.0 * 3.14159265358979323846 / 180.0;

    KneeRig()
    {
        std::tie(xyz, idx) = strip(8, 0.0f, 0.25f);
        joints.assign(4 * size(), 0);
        weights.assign(4 * size(), 0.0f);
        for (std::size_t v = 0; v < size(); ++v)
        {
            const double t = std::clamp((xyz[3 * v] - 0.75) / 0.5, 0.0, 1.0);
            joints[4 * v + 1] = 1;
            weights[4 * v] = static_cast<float>(2.0 * (1.0 - t));
            weights[4 * v + 1] = static_cast<float>(2.0 * t);
        }
    }

    [[nodiscard]] std::size_t size() const { return xyz.size() / 3; }

    /// The skeleton in its scene pose and the skin, for mesh \p mesh of \p b.
    void add_skeleton(GltfBuilder& b, int mesh) const
    {
        const std::vector<float> ibm{
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0,  0, 0, 1,   //
            1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 0, 1};  // column-major
        const int ibm_acc = b.accessor(b.view(GltfBuilder::raw(ibm)), 0, 5126, 2, "MAT4");
        const int knee =
            b.node({{"name", "knee"},
                    {"translation", {1.0, 0.0, 0.0}},
                    {"rotation", {0.0, 0.0, std::sin(angle / 2), std::cos(angle / 2)}}},
                   false);
        const int hip =
            b.node({{"name", "hip"}, {"translation", {0.0, 0.5, 0.0}}, {"children", {knee}}});
        b.node({{"mesh", mesh},
                {"skin", 0},
                {"scale", {3.0, 3.0, 3.0}},
                {"translation", {7.0, 0.0, 0.0}}});
        b.doc["skins"] = Json::array({{{"joints", {hip, knee}}, {"inverseBindMatrices", ibm_acc}}});
    }

    /// Where a viewer shows vertex \p v, computed here from the definitions above.
    [[nodiscard]] Eigen::Vector3d shown(std::size_t v) const
    {
        const Eigen::Affine3d hip_world(Eigen::Translation3d(0.0, 0.5, 0.0));
        const Eigen::Affine3d knee_world = hip_world * Eigen::Translation3d(1.0, 0.0, 0.0) *
                                           Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ());
        const Eigen::Affine3d knee_inverse_bind(Eigen::Translation3d(-1.0, 0.0, 0.0));
        const Eigen::Vector3d p(xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]);
        const double w0 = weights[4 * v] / 2.0;
        const double w1 = weights[4 * v + 1] / 2.0;
        return w0 * (hip_world * p) + w1 * (knee_world * (knee_inverse_bind * p));
    }
};

}  // namespace meshmark::test

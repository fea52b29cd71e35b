// SPDX-License-Identifier: MIT
// The glTF scene walk: roots of the default scene (else every scene, else every parentless
// node), node transforms down the tree, each triangle or point primitive's POSITION accessor
// or Draco data read into the world frame once per accessor (further instances under other
// transforms are kept aside, not marked), and coincident world-space vertices welded into the
// one mesh that meshmark marks.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>
#include <sstream>
#include <string>

#include <Eigen/Geometry>

#include "io/detail/gltf_json.h"
#include "io/detail/gltf_reader.h"
#include "io/detail/numbers.h"
#include "io/detail/support.h"
#include "io/detail/weld.h"
#include "meshmark/core/error.h"

namespace meshmark::detail {

namespace {

namespace fs = std::filesystem;

constexpr int kModePoints = 0;
constexpr int kModeTriangles = 4;

// Node visits allowed while walking the scene graph (a DAG of shared children can otherwise
// explode exponentially in a hostile file).
constexpr std::size_t kMaxNodeVisits = 1U << 20U;

// A skinned primitive whose joints place every vertex within this fraction of its extent of
// where its node's transform does is read through the node (the bind pose).
constexpr double kBindPoseTolerance = 1e-6;

// One vertex of one instance before welding.
struct RawVertices
{
    std::vector<double> world;        // 3 per element
    std::vector<std::int32_t> group;  // transform group per element
};

class Reader
{
public:
    Reader(const fs::path& path, const tinygltf::Model& model, GltfAsset& asset, std::optional<double> animation_time,
           std::size_t animation)
        : path_(path),
          model_(model),
          asset_(asset),
          accessors_(path, model, asset),
          animation_time_(animation_time),
          animation_(animation)
    {
    }

    TriangleMesh run();

private:
    // A node's world matrix as stored, and in the shown pose (the same when not animated), and
    // the node (-1 above the roots).
    struct Placement
    {
        Eigen::Matrix4d to_world;
        Eigen::Matrix4d posed;
        int node = -1;
    };

    void walk(int node, const Placement& parent, std::vector<char>& on_stack);
    void add_primitive(int mesh, int index, const Placement& place, int skin);
    void add_plain(const tinygltf::Primitive& prim, int mesh, int index, const Placement& place, int skin);
    // JOINTS_n and WEIGHTS_n of a primitive, set by set, 4 values per element.
    struct SkinSets
    {
        std::vector<std::vector<double>> joints;
        std::vector<std::vector<double>> weights;
    };
    SkinSets skin_sets(const tinygltf::Primitive& prim);
    std::vector<Eigen::Matrix4d> skinning(const SkinSets& sets, int skin, std::size_t count,
                                          const Eigen::Matrix4d& to_world,
                                          const std::vector<Eigen::Matrix4d>& globals);
    std::vector<Eigen::Matrix4d> add_skinned(const std::vector<double>& local, const SkinSets& sets, int skin,
                                             const Placement& place, const std::vector<double>& shown);
    std::vector<double> morphed(const tinygltf::Primitive& prim, const std::vector<double>& local,
                                const Placement& place, const std::string& where);
    void animation_spans();
    void pose_from_animation();
    void add_posed(const Eigen::Vector4d& local, const Eigen::Matrix4d& rest, const Eigen::Matrix4d& posed);
    void keep_pose(const std::vector<std::int32_t>& welded, const std::vector<double>& xyz);
    std::vector<double> read_vectors(int accessor, int components, const std::string& what,
                                     bool integers_only);
    std::vector<Eigen::Matrix4d> world_matrices(const std::vector<Eigen::Matrix4d>& locals) const;
    void add_draco(const tinygltf::Primitive& prim, int mesh, int index, const Placement& place, int skin);
    void add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                       std::size_t count);
    void add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                       std::size_t count, std::vector<std::size_t>& corners);
    std::size_t add_instance(std::size_t first, std::size_t count, const Eigen::Matrix4d& from,
                             const Eigen::Matrix4d& to);
    std::int32_t group_of(const Eigen::Matrix4d& to_world);
    // The elements of \p local placed by \p place into \p group, and into the shown pose (as
    // \p shown when not empty: the shape its morph targets blend) unless \p with_pose is false
    // (the caller placed them there).
    void append_world(const std::vector<double>& local, const Placement& place, std::int32_t group,
                      const std::vector<double>& shown = {}, bool with_pose = true);
    TriangleMesh weld();
    [[noreturn]] void fail(const std::string& what) const { fail_io(path_, what); }

    const fs::path& path_;
    const tinygltf::Model& model_;
    GltfAsset& asset_;
    GltfAccessors accessors_;
    std::optional<double> animation_time_;  // where animation_ is posed; none: not posed
    std::size_t animation_ = 0;
    std::size_t visits_ = 0;
    std::map<int, std::size_t> accessor_slot_;  // POSITION accessor -> asset_.accessors
    std::map<int, std::size_t> draco_slot_;     // Draco bufferView -> asset_.draco
    std::vector<std::size_t> slot_base_;        // first raw element of each accessor slot
    std::vector<std::size_t> draco_base_;       // first raw element of each Draco slot
    std::vector<std::pair<std::size_t, std::size_t>> draco_corners_;  // its range of corners_
    std::vector<double> instance_xyz_;           // other instances, world frame, 3 per point
    std::vector<std::size_t> instance_corners_;  // their triangles, into instance_xyz_
    std::vector<Eigen::Matrix4d> groups_;        // distinct world transforms
    RawVertices raw_;
    std::vector<std::size_t> corners_;  // raw element ids, 3 per triangle
    std::vector<Eigen::Matrix4d> globals_;  // every node's world matrix (skins' joints)
    // The shown pose of an animated asset (all empty when it has none that moves a node or
    // blends a morph target): every node's local and world matrix and morph weights in it, and
    // every raw element's place in it (3 per element) with the linear map taking a displacement
    // there back to the stored frame.
    std::string pose_name_;
    std::vector<Eigen::Matrix4d> posed_locals_;
    std::vector<Eigen::Matrix4d> posed_globals_;
    std::vector<std::vector<double>> posed_weights_;
    std::vector<double> posed_world_;
    std::vector<Eigen::Matrix3d> to_rest_;
};


// A time of an animation as Blender's frames show it ("10/24 s": frame 10 at 24 frames per
// second), or in seconds when it falls between frames.
std::string time_name(double t)
{
    const double frame = std::round(t * 24.0);
    if (std::abs(t * 24.0 - frame) <= 1e-6 * std::max(1.0, std::abs(frame)))  // (float32 key times)
    {
        return std::to_string(static_cast<long long>(frame)) + "/24 s";
    }
    std::ostringstream out;
    out << t << " s";
    return out.str();
}

// The Draco attribute ids of a skinned primitive's JOINTS_n and WEIGHTS_n, in pairs, set by set
// while both the primitive and its Draco extension have them.
std::vector<std::int32_t> draco_skin_ids(const tinygltf::Primitive& prim, const tinygltf::Value& draco)
{
    std::vector<std::int32_t> ids;
    const auto& attributes = draco.Get("attributes");
    for (int set = 0;; ++set)
    {
        const std::string joints = "JOINTS_" + std::to_string(set);
        const std::string weights = "WEIGHTS_" + std::to_string(set);
        if (prim.attributes.count(joints) == 0 || prim.attributes.count(weights) == 0 || !attributes.Has(joints) ||
            !attributes.Has(weights) || !attributes.Get(joints).IsInt() || !attributes.Get(weights).IsInt())
        {
            return ids;
        }
        ids.push_back(attributes.Get(joints).Get<int>());
        ids.push_back(attributes.Get(weights).Get<int>());
    }
}

bool same_matrix(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
    return std::memcmp(a.data(), b.data(), sizeof(double) * 16) == 0;
}

TriangleMesh Reader::run()
{
    // Roots: the default scene, else every scene, else every node that is no one's child.
    std::vector<int> roots;
    const auto scene_count = static_cast<int>(model_.scenes.size());
    if (model_.defaultScene >= 0 && model_.defaultScene < scene_count)
    {
        roots = model_.scenes[static_cast<std::size_t>(model_.defaultScene)].nodes;
    }
    else if (scene_count > 0)
    {
        for (const auto& scene : model_.scenes)
        {
            roots.insert(roots.end(), scene.nodes.begin(), scene.nodes.end());
        }
    }
    else
    {
        std::vector<char> is_child(model_.nodes.size(), 0);
        for (const auto& node : model_.nodes)
        {
            for (const int c : node.children)
            {
                if (c >= 0 && static_cast<std::size_t>(c) < is_child.size())
                {
                    is_child[static_cast<std::size_t>(c)] = 1;
                }
            }
        }
        for (std::size_t n = 0; n < is_child.size(); ++n)
        {
            if (is_child[n] == 0)
            {
                roots.push_back(static_cast<int>(n));
            }
        }
    }
    if (!animation_time_)
    {
        animation_spans();
    }
    pose_from_animation();
    if (animation_time_ && posed_globals_.empty())
    {
        return TriangleMesh{};  // (only the pose was asked for, and at that time nothing moves)
    }
    std::vector<char> on_stack(model_.nodes.size(), 0);
    for (const int root : roots)
    {
        walk(root, {Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity(), -1}, on_stack);
    }
    const auto common = asset_.animations.empty() ? std::nullopt : shared_mesh_path(model_, roots);
    for (AnimationSpan& span : asset_.animations)
    {
        try
        {
            span.moves_only_as_a_whole = common && moves_only_as_a_whole(model_, accessors_, span.index, *common);
        }
        catch (const IoError&)
        {
            // (a scale key that cannot be read: the animation may bend the mesh)
        }
    }
    return weld();
}

// The span of every animation that animates a node or morph weights (MeshFile::animations); a
// malformed one is left out (it only means no animation). A file whose meshes show a blend of
// their morph targets (shape keys left at a value) that no animation changes gets one more, of
// no length, past the file's animations: its pose is that blend (a viewer shows it, and
// Blender's copies carry it).
void Reader::animation_spans()
{
    bool blends = false;
    for (std::size_t a = 0; a < model_.animations.size(); ++a)
    {
        try
        {
            if (auto span = animation_span(model_, accessors_, a))
            {
                span->index = a;
                asset_.animations.push_back(std::move(*span));
                blends = blends || has_weights_channel(model_, a);
            }
        }
        catch (const IoError&)
        {
        }
    }
    const auto weights = default_morph_weights(model_);
    const bool shows_a_blend = std::any_of(weights.begin(), weights.end(), [](const std::vector<double>& w) {
        return std::any_of(w.begin(), w.end(), [](double x) { return x != 0.0; });
    });
    if (!blends && shows_a_blend)
    {
        AnimationSpan span;
        span.index = model_.animations.size();
        span.name = "the stored morph target weights";
        asset_.animations.push_back(std::move(span));
    }
}

// When a time is asked for, every node's local and world matrix and morph weights at that time
// of animation_ (one past the file's animations: the stored matrices and weights, animation_spans)
// (for_each_animation_pose: detection reads a copy posed by the animation through it). A blend
// of morph targets is a pose even where no node moves. A malformed animation only means no pose.
void Reader::pose_from_animation()
{
    if (!animation_time_ || animation_ > model_.animations.size())
    {
        return;
    }
    std::vector<Eigen::Matrix4d> locals;
    std::vector<std::vector<double>> weights;
    try
    {
        locals = animated_local_matrices(model_, accessors_, animation_, *animation_time_);
        weights = animated_morph_weights(model_, accessors_, animation_, *animation_time_);
    }
    catch (const IoError&)
    {
        return;
    }
    bool moves = false;
    for (std::size_t n = 0; n < locals.size(); ++n)
    {
        if (!locals[n].allFinite() ||
            !std::all_of(weights[n].begin(), weights[n].end(), [](double w) { return std::isfinite(w); }))
        {
            return;  // (a non-finite key: no pose)
        }
        moves = moves || !same_matrix(locals[n], local_matrix(model_.nodes[n])) ||
                std::any_of(weights[n].begin(), weights[n].end(), [](double w) { return w != 0.0; });
    }
    if (!moves)
    {
        return;
    }
    if (animation_ == model_.animations.size())
    {
        pose_name_ = "the stored morph target weights";
    }
    else
    {
        const std::string& name = model_.animations[animation_].name;
        pose_name_ = (name.empty() ? "animation " + std::to_string(animation_) : "animation '" + name + "'") +
                     " at " + time_name(*animation_time_);
    }
    posed_globals_ = world_matrices(locals);
    posed_locals_ = std::move(locals);
    posed_weights_ = std::move(weights);
}

// \p local (3 per element) with the morph targets of \p prim blended in by the weights of the
// pose at \p place's node (the specification's base + sum of weight x POSITION delta), or empty
// when there is no pose or no target with a weight and a readable POSITION of as many elements.
std::vector<double> Reader::morphed(const tinygltf::Primitive& prim, const std::vector<double>& local,
                                    const Placement& place, const std::string& where)
{
    if (posed_globals_.empty() || place.node < 0 || prim.targets.empty())
    {
        return {};
    }
    const std::vector<double>& weights = posed_weights_[static_cast<std::size_t>(place.node)];
    std::vector<double> shown;
    for (std::size_t k = 0; k < prim.targets.size() && k < weights.size(); ++k)
    {
        const auto position = prim.targets[k].find("POSITION");
        if (weights[k] == 0.0 || position == prim.targets[k].end())
        {
            continue;
        }
        std::vector<double> delta;
        try
        {
            delta = read_vectors(position->second, 3, where + " morph target " + std::to_string(k) + " POSITION",
                                 false);
        }
        catch (const IoError&)
        {
            continue;  // (a malformed target only means no blend of it, as a malformed animation means no pose)
        }
        if (delta.size() != local.size())
        {
            continue;  // (a target of another length: nothing a viewer would show either)
        }
        if (shown.empty())
        {
            shown = local;
        }
        for (std::size_t c = 0; c < shown.size(); ++c)
        {
            shown[c] += weights[k] * delta[c];
        }
    }
    return shown;
}

void Reader::add_posed(const Eigen::Vector4d& local, const Eigen::Matrix4d& rest, const Eigen::Matrix4d& posed)
{
    const Eigen::Vector4d w = posed * local;
    posed_world_.insert(posed_world_.end(), {w.x(), w.y(), w.z()});
    const Eigen::Matrix3d p = posed.topLeftCorner<3, 3>();
    // A part the pose collapses (zero scale) has no way back: its displacements read as noise.
    const double det = p.determinant();
    const double scale = p.squaredNorm() / 3.0;
    to_rest_.push_back(std::abs(det) > 1e-9 * std::pow(scale, 1.5) ? Eigen::Matrix3d(rest.topLeftCorner<3, 3>() * p.inverse())
                                                                   : Eigen::Matrix3d::Identity());
}

void Reader::walk(int node_index, const Placement& parent, std::vector<char>& on_stack)
{
    if (node_index < 0 || static_cast<std::size_t>(node_index) >= model_.nodes.size())
    {
        fail("node index " + std::to_string(node_index) + " is out of range");
    }
    const auto n = static_cast<std::size_t>(node_index);
    if (on_stack[n] != 0)
    {
        fail("node " + std::to_string(node_index) +
             " is its own ancestor (a cycle in the node tree)");
    }
    if (++visits_ > kMaxNodeVisits)
    {
        fail("the node graph expands to more than " + std::to_string(kMaxNodeVisits) + " nodes");
    }
    const auto& node = model_.nodes[n];
    const Eigen::Matrix4d to_world = parent.to_world * local_matrix(node);
    const Placement place{to_world, posed_locals_.empty() ? to_world : Eigen::Matrix4d(parent.posed * posed_locals_[n]),
                          node_index};
    if (!to_world.allFinite())
    {
        fail("node " + std::to_string(node_index) + " has a non-finite transform");
    }
    if (node.mesh >= 0)
    {
        if (static_cast<std::size_t>(node.mesh) >= model_.meshes.size())
        {
            fail("node " + std::to_string(node_index) + " refers to missing mesh " +
                 std::to_string(node.mesh));
        }
        // A singular transform (zero scale) hides the mesh: it has no world geometry to mark.
        if (std::abs(to_world.topLeftCorner<3, 3>().determinant()) > 0.0)
        {
            const auto& mesh = model_.meshes[static_cast<std::size_t>(node.mesh)];
            for (std::size_t p = 0; p < mesh.primitives.size(); ++p)
            {
                add_primitive(node.mesh, static_cast<int>(p), place, node.skin);
            }
        }
    }
    on_stack[n] = 1;
    for (const int child : node.children)
    {
        walk(child, place, on_stack);
    }
    on_stack[n] = 0;
}

void Reader::add_primitive(int mesh, int index, const Placement& place, int skin)
{
    const auto& prim =
        model_.meshes[static_cast<std::size_t>(mesh)].primitives[static_cast<std::size_t>(index)];
    if (prim.mode != kModeTriangles && prim.mode != kModePoints)
    {
        return;  // lines, strips and fans are carried through untouched
    }
    if (prim.extensions.count(kDracoExtension) != 0)
    {
        add_draco(prim, mesh, index, place, skin);
    }
    else
    {
        add_plain(prim, mesh, index, place, skin);
    }
}

std::int32_t Reader::group_of(const Eigen::Matrix4d& to_world)
{
    for (std::size_t g = 0; g < groups_.size(); ++g)
    {
        if (same_matrix(groups_[g], to_world))
        {
            return static_cast<std::int32_t>(g);
        }
    }
    groups_.push_back(to_world);
    return static_cast<std::int32_t>(groups_.size() - 1);
}

void Reader::append_world(const std::vector<double>& local, const Placement& place, std::int32_t group,
                          const std::vector<double>& shown, bool with_pose)
{
    const std::size_t n = local.size() / 3;
    const std::vector<double>& in_pose = shown.empty() ? local : shown;
    for (std::size_t i = 0; i < n; ++i)
    {
        const Eigen::Vector4d p(local[3 * i], local[3 * i + 1], local[3 * i + 2], 1.0);
        const Eigen::Vector4d w = place.to_world * p;
        raw_.world.insert(raw_.world.end(), {w.x(), w.y(), w.z()});
        raw_.group.push_back(group);
        if (with_pose && !posed_globals_.empty())
        {
            add_posed(Eigen::Vector4d(in_pose[3 * i], in_pose[3 * i + 1], in_pose[3 * i + 2], 1.0), place.to_world,
                      place.posed);
        }
    }
}

void Reader::add_plain(const tinygltf::Primitive& prim, int mesh, int index, const Placement& place, int skin)
{
    const Eigen::Matrix4d& to_world = place.to_world;
    // A skinned use: JOINTS_0 and WEIGHTS_0 under a node with a skin (glTF then places the
    // vertices by the joints and ignores the node's transform).
    if (skin >= 0 && (prim.attributes.count("JOINTS_0") == 0 || prim.attributes.count("WEIGHTS_0") == 0))
    {
        skin = -1;
    }
    const auto it = prim.attributes.find("POSITION");
    if (it == prim.attributes.end())
    {
        return;
    }
    const int a = it->second;
    if (a < 0 || static_cast<std::size_t>(a) >= model_.accessors.size())
    {
        fail("mesh " + std::to_string(mesh) + " primitive " + std::to_string(index) +
             " has a missing POSITION accessor");
    }
    std::size_t slot = 0;
    if (const auto found = accessor_slot_.find(a); found != accessor_slot_.end())
    {
        slot = found->second;
        // Another instance of the same positions under a different transform: its vertices
        // cannot take a second displacement, so only the first instance is watermarked; its
        // geometry is kept aside for registration (MeshFile::instances).
        const auto& first = asset_.accessors[slot];
        if (first.skin >= 0 || skin >= 0)
        {
            // Skinned: the same skin shows the same vertices (the node's transform does not
            // count); a use under another skin is not marked and not kept aside.
            if (first.skin == skin && prim.mode == kModeTriangles)
            {
                add_triangles(prim, mesh, index, slot_base_[slot], first.elements.size());
            }
            return;
        }
        if (!same_matrix(asset_.accessors[slot].to_world, to_world))
        {
            const std::size_t base =
                add_instance(slot_base_[slot], asset_.accessors[slot].elements.size(),
                             asset_.accessors[slot].to_world, to_world);
            if (prim.mode == kModeTriangles)
            {
                add_triangles(prim, mesh, index, base, asset_.accessors[slot].elements.size(),
                              instance_corners_);
            }
            return;
        }
    }
    else
    {
        const auto& acc = model_.accessors[static_cast<std::size_t>(a)];
        const auto component = component_of(acc.componentType);
        if (acc.type != TINYGLTF_TYPE_VEC3 || !component || *component == GltfComponent::UInt32)
        {
            fail("POSITION accessor " + std::to_string(a) +
                 " is not a VEC3 of float or 8/16-bit integers");
        }
        GltfPositionAccessor record;
        record.accessor = a;
        record.component = *component;
        record.is_normalized = acc.normalized;
        record.to_world = to_world;
        record.elements = accessors_.locate(a, 3, "POSITION");
        // Local positions, decoded and de-normalized as a renderer would.
        std::vector<double> local(3 * record.elements.size(), 0.0);
        const auto type = scalar_of(record.component);
        const std::size_t size = component_size(record.component);
        for (std::size_t e = 0; e < record.elements.size(); ++e)
        {
            const auto& el = record.elements[e];
            for (std::size_t d = 0; d < 3 && el.buffer >= 0; ++d)
            {
                const char* p = asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() +
                                el.offset + d * size;
                local[3 * e + d] =
                    dequantize(load_scalar(p, type, false), record.component, record.is_normalized);
            }
        }
        for (std::size_t k = 0; k < local.size(); ++k)
        {
            if (!std::isfinite(local[k]))
            {
                fail_mesh(path_, "POSITION accessor " + std::to_string(a) + " element " +
                                     std::to_string(k / 3) + " has a non-finite coordinate");
            }
        }
        slot = asset_.accessors.size();
        accessor_slot_[a] = slot;
        slot_base_.push_back(raw_.group.size());
        const std::vector<double> shown =
            morphed(prim, local, place, "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index));
        if (skin >= 0)
        {
            record.skin = skin;
            record.skinning = add_skinned(local, skin_sets(prim), skin, place, shown);
        }
        else
        {
            append_world(local, place, group_of(to_world), shown);
        }
        asset_.accessors.push_back(std::move(record));
    }
    if (prim.mode == kModeTriangles)
    {
        add_triangles(prim, mesh, index, slot_base_[slot], asset_.accessors[slot].elements.size());
    }
}

// A skinned primitive's elements (\p local, 3 per element), placed where a viewer shows the
// scene: each by its own blend of joint matrices, in a group of its own (positions of other
// parts that meet it within float rounding are welded to it, its own distinct positions
// never), and into the shown pose. A rig shown in its bind pose under a node placed like it
// (what most exporters write) puts every vertex where the node's transform does, up to the
// float32 rounding of its inverse bind matrices: it is read through the node, to the bit as
// before skins were applied, so that keys made then still match. Returns the matrices (empty
// when read through the node).
std::vector<Eigen::Matrix4d> Reader::add_skinned(const std::vector<double>& local, const SkinSets& sets, int skin,
                                                 const Placement& place, const std::vector<double>& shown)
{
    const Eigen::Matrix4d& to_world = place.to_world;
    const std::size_t count = local.size() / 3;
    const auto at = [&](std::size_t e) { return Eigen::Vector4d(local[3 * e], local[3 * e + 1], local[3 * e + 2], 1.0); };
    std::vector<Eigen::Matrix4d> scene = skinning(sets, skin, count, to_world, globals_);
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    double largest = 0.0;
    for (std::size_t e = 0; e < count; ++e)
    {
        const Eigen::Vector3d by_node = (to_world * at(e)).head<3>();
        lo = lo.cwiseMin(by_node);
        hi = hi.cwiseMax(by_node);
        largest = std::max(largest, ((scene[e] * at(e)).head<3>() - by_node).norm());
    }
    if (count == 0 || largest <= kBindPoseTolerance * (hi - lo).norm())
    {
        scene.clear();
    }
    if (!posed_globals_.empty())
    {
        // Animated: every element's own way into the pose.
        const std::vector<Eigen::Matrix4d> posed = skinning(sets, skin, count, place.posed, posed_globals_);
        for (std::size_t e = 0; e < count; ++e)
        {
            const Eigen::Vector4d in_pose =
                shown.empty() ? at(e) : Eigen::Vector4d(shown[3 * e], shown[3 * e + 1], shown[3 * e + 2], 1.0);
            add_posed(in_pose, scene.empty() ? to_world : scene[e], posed[e]);
        }
    }
    if (scene.empty())
    {
        append_world(local, place, group_of(to_world), {}, false);
        return scene;
    }
    groups_.push_back(to_world);
    const auto group = static_cast<std::int32_t>(groups_.size() - 1);
    for (std::size_t e = 0; e < count; ++e)
    {
        const Eigen::Vector4d w = scene[e] * at(e);
        raw_.world.insert(raw_.world.end(), {w.x(), w.y(), w.z()});
        raw_.group.push_back(group);
    }
    return scene;
}

void Reader::add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                           std::size_t count)
{
    add_triangles(prim, mesh, index, base, count, corners_);
}

// The points of another instance of raw elements [first, first + count), first read under
// \p from, now under \p to; returns the index of its first point in instance_xyz_.
std::size_t Reader::add_instance(std::size_t first, std::size_t count, const Eigen::Matrix4d& from,
                                 const Eigen::Matrix4d& to)
{
    const Eigen::Matrix4d map = to * from.inverse();
    const std::size_t base = instance_xyz_.size() / 3;
    for (std::size_t e = first; e < first + count; ++e)
    {
        const Eigen::Vector4d p(raw_.world[3 * e], raw_.world[3 * e + 1], raw_.world[3 * e + 2],
                                1.0);
        const Eigen::Vector4d q = map * p;
        instance_xyz_.insert(instance_xyz_.end(), {q.x(), q.y(), q.z()});
    }
    return base;
}

void Reader::add_triangles(const tinygltf::Primitive& prim, int mesh, int index, std::size_t base,
                           std::size_t count, std::vector<std::size_t>& corners)
{
    const std::string where =
        "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index);
    if (prim.indices < 0)
    {
        if (count % 3 != 0)
        {
            fail_mesh(path_, where + " has " + std::to_string(count) +
                                 " non-indexed vertices, not a multiple of 3");
        }
        for (std::size_t e = 0; e < count; ++e)
        {
            corners.push_back(base + e);
        }
        return;
    }
    if (static_cast<std::size_t>(prim.indices) >= model_.accessors.size())
    {
        fail(where + " has a missing indices accessor");
    }
    const auto& acc = model_.accessors[static_cast<std::size_t>(prim.indices)];
    const auto component = component_of(acc.componentType);
    if (acc.type != TINYGLTF_TYPE_SCALAR || !component ||
        (*component != GltfComponent::UInt8 && *component != GltfComponent::UInt16 &&
         *component != GltfComponent::UInt32))
    {
        fail(where + " has indices that are not unsigned integer scalars");
    }
    const auto elements = accessors_.locate(prim.indices, 1, "indices");
    if (elements.size() % 3 != 0)
    {
        fail_mesh(path_, where + " has " + std::to_string(elements.size()) +
                             " indices, not a multiple of 3");
    }
    const auto type = scalar_of(*component);
    for (const auto& el : elements)
    {
        const std::uint64_t i =
            el.buffer < 0
                ? 0
                : static_cast<std::uint64_t>(load_integer(
                      asset_.buffers[static_cast<std::size_t>(el.buffer)].bytes.data() + el.offset,
                      type, false));
        if (i >= count)
        {
            fail_mesh(path_, where + " has index " + std::to_string(i) + " " + index_range(count));
        }
        corners.push_back(base + i);
    }
}

void Reader::add_draco(const tinygltf::Primitive& prim, int mesh, int index, const Placement& place, int skin)
{
    const Eigen::Matrix4d& to_world = place.to_world;
    const std::string where =
        "mesh " + std::to_string(mesh) + " primitive " + std::to_string(index);
    const auto& ext = prim.extensions.at(kDracoExtension);
    // tinygltf::Value::Get asserts an object: check the shape before each lookup.
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
    {
        fail(where + " has a malformed " + std::string(kDracoExtension) + " extension");
    }
    const auto& view_value = ext.Get("bufferView");
    const auto& position_value = ext.Get("attributes").Get("POSITION");
    const auto position = prim.attributes.find("POSITION");
    if (!view_value.IsInt() || !position_value.IsInt() || position == prim.attributes.end() ||
        position->second < 0 ||
        static_cast<std::size_t>(position->second) >= model_.accessors.size())
    {
        fail(where + " has a " + std::string(kDracoExtension) +
             " extension without bufferView or POSITION attribute");
    }
    const int view_index = view_value.Get<int>();
    if (view_index < 0 || static_cast<std::size_t>(view_index) >= model_.bufferViews.size())
    {
        fail(where + " refers to missing Draco bufferView " + std::to_string(view_index));
    }
    std::size_t slot = 0;
    if (const auto found = draco_slot_.find(view_index); found != draco_slot_.end())
    {
        slot = found->second;
        if (asset_.draco[slot].skin >= 0 || (skin >= 0 && !draco_skin_ids(prim, ext).empty()))
        {
            return;  // skinned: the same skin shows the same vertices, another is not marked (add_plain)
        }
        if (!same_matrix(asset_.draco[slot].to_world, to_world))
        {
            // A second instance, see add_plain.
            const std::size_t base =
                add_instance(draco_base_[slot], asset_.draco[slot].welded.size(),
                             asset_.draco[slot].to_world, to_world);
            const auto [first, last] = draco_corners_[slot];
            for (std::size_t k = first; k < last; ++k)
            {
                instance_corners_.push_back(base + corners_[k] - draco_base_[slot]);
            }
            return;
        }
    }
    else
    {
        const auto& view = model_.bufferViews[static_cast<std::size_t>(view_index)];
        if (!accessors_.is_view_in_buffer(view))
        {
            fail(where + " has a Draco bufferView past the end of its buffer");
        }
        GltfDracoPrimitive record;
        record.mesh = mesh;
        record.primitive = index;
        record.buffer_view = view_index;
        record.position_accessor = position->second;
        record.position_attribute_id = position_value.Get<int>();
        record.to_world = to_world;
        const auto& draco_attributes = ext.Get("attributes").Keys();
        record.has_foreign_attributes = !prim.targets.empty();
        for (const auto& [name, accessor] : prim.attributes)
        {
            static_cast<void>(accessor);
            if (std::find(draco_attributes.begin(), draco_attributes.end(), name) ==
                draco_attributes.end())
            {
                record.has_foreign_attributes = true;
            }
        }
        const auto& buffer = asset_.buffers[static_cast<std::size_t>(view.buffer)].bytes;
        // Skinned: the joints and weights too, decoded from the same Draco data.
        const std::vector<std::int32_t> skin_ids = skin >= 0 ? draco_skin_ids(prim, ext) : std::vector<std::int32_t>{};
        const auto decode = [&] {
            return decode_draco(path_, buffer.substr(view.byteOffset, view.byteLength), record.position_attribute_id,
                                skin_ids);
        };
        // (posing at many times, for_each_animation_pose: each view is decoded once)
        DracoGeometry decoded;
        const DracoGeometry* cached = nullptr;
        if (animation_time_)
        {
            auto decoded_before = asset_.pose_draco.find(view_index);
            if (decoded_before == asset_.pose_draco.end() || decoded_before->second.more.size() < skin_ids.size())
            {
                asset_.pose_draco.erase(view_index);
                decoded_before = asset_.pose_draco.emplace(view_index, decode()).first;
            }
            cached = &decoded_before->second;
        }
        else
        {
            decoded = decode();
        }
        const DracoGeometry& geometry = cached != nullptr ? *cached : decoded;
        // The decoded values are stored values: with KHR_mesh_quantization, integers that the
        // accessor's `normalized` maps to [-1, 1] or [0, 1], as for uncompressed data.
        const auto& accessor = model_.accessors[static_cast<std::size_t>(position->second)];
        record.component = geometry.component;
        record.is_normalized = accessor.normalized && geometry.component != GltfComponent::Float32;
        std::vector<double> local(geometry.positions.size());
        for (std::size_t k = 0; k < local.size(); ++k)
        {
            local[k] = dequantize(geometry.positions[k], record.component, record.is_normalized);
        }
        slot = asset_.draco.size();
        draco_slot_[view_index] = slot;
        draco_base_.push_back(raw_.group.size());
        // (a primitive with morph targets is encoded keeping its points' order, sequentially,
        // and its targets stay plain accessors, element for element of the decoded points)
        const std::vector<double> shown = morphed(prim, local, place, where);
        if (!skin_ids.empty())
        {
            SkinSets sets;
            for (std::size_t k = 0; k + 1 < skin_ids.size(); k += 2)
            {
                sets.joints.push_back(geometry.more[k]);
                sets.weights.push_back(geometry.more[k + 1]);
            }
            record.skin = skin;
            record.skinning = add_skinned(local, sets, skin, place, shown);
        }
        else
        {
            append_world(local, place, group_of(to_world), shown);
        }
        record.welded.resize(geometry.point_count);
        asset_.draco.push_back(std::move(record));
        const std::size_t first_corner = corners_.size();
        if (prim.mode == kModeTriangles)
        {
            for (const auto c : geometry.triangles)
            {
                corners_.push_back(draco_base_[slot] + c);
            }
        }
        draco_corners_.emplace_back(first_corner, corners_.size());
        return;
    }
    // A repeated use under the same transform adds the same triangles again; the Draco data
    // has one connectivity, so they are already there.
}

std::vector<Eigen::Matrix4d> Reader::world_matrices(const std::vector<Eigen::Matrix4d>& locals) const
{
    // glTF nodes form a forest (a node has at most one parent); walk it from every parentless
    // node. A node left unvisited (a cycle, which walk() reports) keeps the identity.
    const std::size_t n = model_.nodes.size();
    std::vector<Eigen::Matrix4d> globals(n, Eigen::Matrix4d::Identity());
    std::vector<char> has_parent(n, 0);
    for (const auto& node : model_.nodes)
    {
        for (const int c : node.children)
        {
            if (c >= 0 && static_cast<std::size_t>(c) < n)
            {
                has_parent[static_cast<std::size_t>(c)] = 1;
            }
        }
    }
    std::vector<char> seen(n, 0);
    std::vector<int> stack;
    for (std::size_t r = 0; r < n; ++r)
    {
        if (has_parent[r] != 0)
        {
            continue;
        }
        globals[r] = locals[r];
        seen[r] = 1;
        stack.push_back(static_cast<int>(r));
        while (!stack.empty())
        {
            const auto k = static_cast<std::size_t>(stack.back());
            stack.pop_back();
            for (const int c : model_.nodes[k].children)
            {
                if (c < 0 || static_cast<std::size_t>(c) >= n || seen[static_cast<std::size_t>(c)] != 0)
                {
                    continue;
                }
                const auto child = static_cast<std::size_t>(c);
                seen[child] = 1;
                globals[child] = globals[k] * locals[child];
                stack.push_back(c);
            }
        }
    }
    return globals;
}

std::vector<double> Reader::read_vectors(int accessor, int components, const std::string& what,
                                         bool integers_only)
{
    return accessors_.values(accessor, components, what, integers_only);
}

Reader::SkinSets Reader::skin_sets(const tinygltf::Primitive& prim)
{
    SkinSets sets;
    for (int set = 0;; ++set)
    {
        const auto j = prim.attributes.find("JOINTS_" + std::to_string(set));
        const auto w = prim.attributes.find("WEIGHTS_" + std::to_string(set));
        if (j == prim.attributes.end() || w == prim.attributes.end())
        {
            return sets;
        }
        sets.joints.push_back(read_vectors(j->second, 4, "JOINTS_" + std::to_string(set), true));
        sets.weights.push_back(read_vectors(w->second, 4, "WEIGHTS_" + std::to_string(set), false));
    }
}

std::vector<Eigen::Matrix4d> Reader::skinning(const SkinSets& sets, int skin, std::size_t count,
                                              const Eigen::Matrix4d& to_world,
                                              const std::vector<Eigen::Matrix4d>& globals)
{
    if (static_cast<std::size_t>(skin) >= model_.skins.size())
    {
        fail("a node refers to missing skin " + std::to_string(skin));
    }
    if (globals_.empty())
    {
        std::vector<Eigen::Matrix4d> locals(model_.nodes.size());
        for (std::size_t n = 0; n < locals.size(); ++n)
        {
            locals[n] = local_matrix(model_.nodes[n]);
        }
        globals_ = world_matrices(locals);
    }
    const auto& s = model_.skins[static_cast<std::size_t>(skin)];
    std::vector<double> inverse_binds;
    if (s.inverseBindMatrices >= 0)
    {
        inverse_binds = read_vectors(s.inverseBindMatrices, 16, "inverseBindMatrices", false);
        if (inverse_binds.size() < 16 * s.joints.size())
        {
            fail("skin " + std::to_string(skin) + " has fewer inverse bind matrices than joints");
        }
    }
    std::vector<Eigen::Matrix4d> joint(s.joints.size(), Eigen::Matrix4d::Identity());
    for (std::size_t k = 0; k < s.joints.size(); ++k)
    {
        const int node = s.joints[k];
        if (node < 0 || static_cast<std::size_t>(node) >= model_.nodes.size())
        {
            fail("skin " + std::to_string(skin) + " has joint node " + std::to_string(node) + " out of range");
        }
        Eigen::Matrix4d inverse_bind = Eigen::Matrix4d::Identity();
        if (!inverse_binds.empty())
        {
            inverse_bind = Eigen::Map<const Eigen::Matrix4d>(inverse_binds.data() + 16 * k);  // column-major
        }
        joint[k] = globals[static_cast<std::size_t>(node)] * inverse_bind;
    }
    std::vector<Eigen::Matrix4d> result(count, Eigen::Matrix4d::Zero());
    std::vector<double> total(count, 0.0);
    for (std::size_t set = 0; set < sets.joints.size(); ++set)
    {
        const std::vector<double>& joints = sets.joints[set];
        const std::vector<double>& weights = sets.weights[set];
        if (joints.size() < 4 * count || weights.size() < 4 * count)
        {
            fail("JOINTS_" + std::to_string(set) + " or WEIGHTS_" + std::to_string(set) +
                 " has fewer elements than POSITION");
        }
        for (std::size_t e = 0; e < count; ++e)
        {
            for (std::size_t c = 0; c < 4; ++c)
            {
                const double weight = weights[4 * e + c];
                if (weight == 0.0)
                {
                    continue;
                }
                const double index = joints[4 * e + c];
                // (glTF's joints are unsigned; a signed accessor's negative index is refused too)
                if (index < 0.0 || index >= static_cast<double>(joint.size()))
                {
                    fail("JOINTS_" + std::to_string(set) + " element " + std::to_string(e) + " refers to joint " +
                         std::to_string(static_cast<long long>(index)) + ", but skin " + std::to_string(skin) +
                         " has " + std::to_string(joint.size()) + " joint(s)");
                }
                result[e] += weight * joint[static_cast<std::size_t>(index)];
                total[e] += weight;
            }
        }
    }
    // Weights that do not sum to 1 are normalized, as Blender's armature and three.js do; an
    // element without weight or whose joints collapse it (no inverse, so no displacement can
    // be written back) keeps the node's transform.
    for (std::size_t e = 0; e < count; ++e)
    {
        if (total[e] > 0.0)
        {
            result[e] /= total[e];
        }
        const double det = result[e].topLeftCorner<3, 3>().determinant();
        const double scale = result[e].topLeftCorner<3, 3>().squaredNorm() / 3.0;  // mean squared column norm
        if (!(total[e] > 0.0) || !result[e].allFinite() || !(std::abs(det) > 1e-9 * std::pow(scale, 1.5)))
        {
            result[e] = to_world;
        }
    }
    return result;
}

// The shown pose of every welded vertex (its first element's), kept unless the pose only moves
// the asset as a whole (a similarity, which registration undoes anyway).
void Reader::keep_pose(const std::vector<std::int32_t>& welded, const std::vector<double>& xyz)
{
    const std::size_t n = xyz.size() / 3;
    ShownPose pose;
    pose.name = pose_name_;
    pose.time = *animation_time_;
    pose.V.resize(static_cast<Eigen::Index>(n), 3);
    pose.to_rest.assign(n, Eigen::Matrix3d::Identity());
    std::vector<char> is_set(n, 0);
    for (std::size_t e = 0; e < welded.size(); ++e)
    {
        const auto v = static_cast<std::size_t>(welded[e]);
        if (is_set[v] == 0)
        {
            is_set[v] = 1;
            pose.V.row(static_cast<Eigen::Index>(v)) << posed_world_[3 * e], posed_world_[3 * e + 1], posed_world_[3 * e + 2];
            pose.to_rest[v] = to_rest_[e];
        }
    }
    if (n < 3 || !pose.V.allFinite())
    {
        return;
    }
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic>> rest(xyz.data(), 3, static_cast<Eigen::Index>(n));
    const Eigen::Matrix<double, 3, Eigen::Dynamic> posed = pose.V.transpose();
    const Eigen::Matrix4d similarity = Eigen::umeyama(rest, posed, true);
    const Eigen::Matrix<double, 3, Eigen::Dynamic> fitted =
        (similarity.topLeftCorner<3, 3>() * rest).colwise() + similarity.topRightCorner<3, 1>();
    const double extent = (posed.rowwise().maxCoeff() - posed.rowwise().minCoeff()).norm();
    if ((fitted - posed).colwise().norm().maxCoeff() <= kBindPoseTolerance * extent)
    {
        return;
    }
    asset_.pose = std::move(pose);
}

TriangleMesh Reader::weld()
{
    if (raw_.group.size() > kMaxVertices)
    {
        fail("the asset has more than " + std::to_string(kMaxVertices) + " vertices");
    }
    if (animation_time_)
    {
        // Only the pose is wanted (for_each_animation_pose): the welding is the same at every time.
        if (asset_.pose_welded.size() != raw_.group.size())
        {
            asset_.pose_welded =
                weld_world_positions(raw_.world, raw_.group, groups_.size(), kCrossTransformWeldRel, asset_.pose_rest);
        }
        if (!posed_globals_.empty())
        {
            keep_pose(asset_.pose_welded, asset_.pose_rest);
        }
        return TriangleMesh{};
    }
    std::vector<double> xyz;
    const auto welded =
        weld_world_positions(raw_.world, raw_.group, groups_.size(), kCrossTransformWeldRel, xyz);

    // Hand the welded ids to the layout, then build the mesh.
    for (std::size_t s = 0; s < asset_.accessors.size(); ++s)
    {
        auto& record = asset_.accessors[s];
        record.welded.assign(
            welded.begin() + static_cast<std::ptrdiff_t>(slot_base_[s]),
            welded.begin() + static_cast<std::ptrdiff_t>(slot_base_[s] + record.elements.size()));
    }
    for (std::size_t s = 0; s < asset_.draco.size(); ++s)
    {
        auto& record = asset_.draco[s];
        const auto first = welded.begin() + static_cast<std::ptrdiff_t>(draco_base_[s]);
        std::copy(first, first + static_cast<std::ptrdiff_t>(record.welded.size()),
                  record.welded.begin());
    }
    if (!instance_xyz_.empty())
    {
        asset_.instances = make_mesh(instance_xyz_, instance_corners_);
    }
    TriangleBuffer triangles;
    triangles.reserve(corners_.size() / 3);
    for (std::size_t t = 0; t + 2 < corners_.size(); t += 3)
    {
        triangles.push(welded[corners_[t]], welded[corners_[t + 1]], welded[corners_[t + 2]]);
    }
    return make_mesh(xyz, triangles);
}

}  // namespace

TriangleMesh read_scene(const fs::path& path, const tinygltf::Model& model, GltfAsset& asset,
                        std::optional<double> animation_time, std::size_t animation)
{
    Reader reader(path, model, asset, animation_time, animation);
    return reader.run();
}

}  // namespace meshmark::detail

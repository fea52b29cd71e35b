// SPDX-License-Identifier: MIT
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "meshmark/core/length_unit.h"
#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// File formats, chosen by file extension (case-insensitive).
enum class MeshFormat
{
    Ply,  ///< .ply: ASCII, binary little- and big-endian; `face` lists and `tristrips`.
    Obj,  ///< .obj: v/vt/vn/f in every index form, polygons, groups, materials.
    Off,  ///< .off: OFF (also COFF/NOFF/CNOFF headers' positions).
    Stl,  ///< .stl: ASCII and binary; corners welded for analysis.
    /// .gltf: glTF 2.0 JSON with data: URIs or external buffers (KHR_draco_mesh_compression
    /// and KHR_mesh_quantization included). The mesh is every TRIANGLES (and POINTS)
    /// primitive of the scene in world coordinates, coincident vertices welded.
    Gltf,
    Glb,  ///< .glb: binary glTF 2.0, read like Gltf.
    /// .3mf: every mesh object in the build's world frame (build item and component
    /// transforms, production-extension parts included), coincident vertices welded; written
    /// back as the same package with only the moved vertices' x/y/z values rewritten.
    ThreeMf,
};

/// \brief Format for a path's extension.
/// \throws IoError naming the file when the extension is not one of .ply .obj .off .stl
/// .gltf .glb .3mf.
[[nodiscard]] MeshFormat format_from_extension(const std::filesystem::path& path);

/// Name of a format as used in messages and --json ("PLY", "OBJ", ...).
[[nodiscard]] const char* to_string(MeshFormat format) noexcept;

namespace detail
{
struct FileLayout;  // Everything a preserving writer needs: the original bytes and where positions
                    // sit.
}

/// \brief Where an animated file's mesh stands at one time of one of its animations
/// (for_each_animation_pose).
/// \details glTF: Blender's importer shows the first animation at frame 1 (1/24 s), and its
/// writers, modifiers and exports then hand on that pose (or another frame's, or another
/// animation's, when the user moved the timeline or switched the action), not the stored
/// (rest) one the mark was embedded in. Each vertex of the
/// pose is an affine image of its stored place, after the morph targets' blend moved it
/// (rigid node animation, skinning); `to_rest` carries a displacement made in the pose back.
struct ShownPose
{
    std::string name;   ///< What the pose is, for messages ("animation 'Run' at 1/24 s").
    double time = 0.0;  ///< Seconds into the animation (1/24 in the first: what Blender shows).
    Positions V;  ///< MeshFile::mesh's vertices in the pose, row for row; empty: no such pose.
    /// Per row: the linear map taking a displacement near the posed vertex back to the stored
    /// frame (the inverse of the pose's linear part at that vertex).
    std::vector<Eigen::Matrix3d> to_rest;
};

/// \brief An animation of a glTF file one of whose channels animates a node (its translation,
/// rotation or scale) or the morph target weights of its mesh. Blender's importer plays the
/// file's first one and keeps the others as actions a user may switch to. A file whose meshes
/// show a fixed blend of morph targets that no animation keys has one more, of no length, one
/// past its animations (named "the stored morph target weights"): its pose is that blend.
struct AnimationSpan
{
    std::size_t index = 0;   ///< Its place in the file's list of animations (see above).
    std::string name;        ///< Its name in the file ("animation K" when it has none).
    double first_key = 0.0;  ///< Time of its earliest key, seconds.
    double last_key = 0.0;   ///< Time of its latest key, seconds.
    /// It only turns, moves or uniformly scales the asset as a whole (a turntable): every node
    /// it animates lies above every mesh of the scene (none skinned), with similarities on the
    /// way, so no time of it poses the mesh (for_each_animation_pose gives empty poses throughout).
    bool moves_only_as_a_whole = false;
};

/// \brief A mesh as read from a file, with what is needed to write it back unchanged except
/// for its vertex positions.
struct MeshFile
{
    TriangleMesh
        mesh;  ///< Positions (every vertex record of the file, referenced or not) and
               ///< triangles (polygons fan-triangulated, strips decoded). For STL the
               ///< positions are the distinct corner positions (bit-identical corners welded).
    MeshFormat format = MeshFormat::Ply;
    std::filesystem::path path;
    /// Positions were stored as float32 and changed ones are written back as float32: binary
    /// or float-typed ASCII PLY, binary STL; for OBJ, OFF and ASCII STL, every coordinate
    /// token had at most 9 significant digits.
    bool is_single_precision = false;
    /// Opaque; used by write_mesh_file (and by for_each_animation_pose: a glTF file with
    /// animations keeps its parsed scene here).
    std::shared_ptr<const detail::FileLayout> layout;
    /// glTF and 3MF: the geometry of the other instances of meshes that several nodes (build
    /// items, components) show under different transforms, in the world frame. `mesh` holds the
    /// first instance only (the instances share their stored positions, so only one can take a
    /// displacement); a copy re-exported by a tool that flattens instances shows all of them, and
    /// detection registers against `mesh` plus these. Empty for other formats and files without
    /// such instances.
    TriangleMesh instances;
    /// glTF: every animation that animates a node or morph weights, in the file's order, to
    /// sample its poses (for_each_animation_pose), whether or not they differ from the stored
    /// one, and the fixed blend of morph targets (AnimationSpan). Empty for other formats and
    /// files without such animations.
    std::vector<AnimationSpan> animations;
    /// The unit of length the file declares for its coordinates: 3MF's `<model unit=...>`
    /// (millimetre when the attribute is absent, as the 3MF specification says), metres for
    /// glTF/GLB (its specification's unit). Empty for PLY, OBJ, OFF and STL, which have none,
    /// and for a 3MF unit outside its specification's list: a unit is never guessed.
    std::optional<LengthUnit> unit;
};

/// \brief Read a mesh file, keeping everything needed for a preserving write.
/// \details The whole file is read and validated (finite coordinates, indices in range)
/// before anything is returned; a file is never opened for writing.
/// \throws IoError (missing, unreadable, truncated, malformed; names the file and the line
/// or byte offset) or InvalidMesh (non-finite coordinate, index out of range).
[[nodiscard]] MeshFile read_mesh_file(const std::filesystem::path& path);

/// \brief The mesh of a glTF file, as read_mesh_file read it, posed by its animation
/// \p animation (AnimationSpan::index; 0: the first; one past the file's animations: its stored
/// morph weights) at each of \p times (seconds), one call of \p visit per time, in order. A pose
/// blends the morph targets by their weights at that time. Nothing is read or parsed again:
/// read_mesh_file keeps what posing needs of a glTF file with animations (in `layout`).
/// \details Each pose has MeshFile::mesh's rows and the maps back (ShownPose), with an empty
/// `V` where the pose is only a similarity of the stored one (or the animation is malformed).
/// Other formats, files without an animation, and a MeshFile without layout, call \p visit with
/// empty poses. A copy re-posed by a user (a rigged character exported at another frame) is read
/// through these.
/// \throws IoError for a malformed mesh in the pose (as read_mesh_file would).
void for_each_animation_pose(const MeshFile& file, std::span<const double> times,
                             const std::function<void(ShownPose&&)>& visit,
                             std::size_t animation = 0);

/// \brief for_each_animation_pose of the file at \p path, read first (read_mesh_file; other
/// formats than glTF are not read: their poses are empty).
/// \throws the errors of read_mesh_file.
void for_each_animation_pose(const std::filesystem::path& path, std::span<const double> times,
                             const std::function<void(ShownPose&&)>& visit,
                             std::size_t animation = 0);

/// \brief Read only the geometry of a mesh file. Same errors as read_mesh_file.
[[nodiscard]] TriangleMesh read_mesh(const std::filesystem::path& path);

/// Options of the generic writers.
struct WriteOptions
{
    bool is_binary = true;  ///< PLY and STL: binary (little-endian) rather than ASCII.
    /// Store positions as float32 instead of float64 (PLY binary and ASCII; for OBJ, OFF and
    /// ASCII STL: shortest float32 digits). Binary STL is always float32.
    bool use_single_precision = false;
    /// Optional per-vertex colors (PLY only: red/green/blue uchar properties), #V entries.
    const std::vector<std::array<std::uint8_t, 3>>* vertex_colors = nullptr;
    /// write_mesh_file preserving a source: the folder the file will be read from when it is
    /// written elsewhere first (a cluster worker's staging folder, docs/cluster.md); relative
    /// links to the source's files outside it (an OBJ's `mtllib`, a glTF's images) start
    /// there. Empty: the folder it is written to.
    std::filesystem::path link_folder;

    /// \brief Throws InvalidOption unless vertex_colors is null or has \p vertex_count entries.
    void validate(Eigen::Index vertex_count) const;
};

/// \brief Write \p mesh to \p path in the format of its extension, atomically.
/// \details ASCII numbers use the shortest representation that reads back to the same double.
/// \throws IoError (unknown extension, unwritable directory); nothing is left at \p path then.
/// \throws InvalidMesh (non-finite coordinate, index out of range) and InvalidOption
/// (vertex_colors of the wrong size) before anything is written.
void write_mesh(const std::filesystem::path& path, const TriangleMesh& mesh,
                const WriteOptions& options = {});

/// \brief Write \p source with its vertex positions replaced by \p positions, atomically.
/// \details When \p path has the same format as \p source, everything but the positions is
/// preserved byte for byte: header, comments, property order and types, extra elements and
/// properties, normals, texture coordinates, faces (polygons and strips as they were),
/// unreferenced vertices. Positions keep the file's precision: float32 stays float32; an
/// ASCII coordinate is rewritten only if its value changed, with the shortest digits that
/// read back to the new value in the file's precision. STL facets get their corners' new
/// positions and a recomputed normal (a zero normal stays zero). When the formats differ,
/// this is write_mesh of the positions and triangles, and only then are \p options used (but
/// for link_folder, used only when they are the same).
/// Writing the unchanged positions reproduces the source file byte for byte; \p path may be
/// the source file itself. See docs/file_formats.md for the precision rules per format.
/// \pre positions.rows() == source.mesh.V.rows().
/// \throws IoError as write_mesh, or when a changed coordinate does not fit an integer
/// position type; InvalidOption on a row-count mismatch; InvalidMesh on a non-finite position.
void write_mesh_file(const std::filesystem::path& path, const MeshFile& source,
                     const Positions& positions, const WriteOptions& options = {});

/// \brief The bytes of \p source with its positions replaced by \p positions, in \p format, as
/// one file (a service's response): what write_mesh_file writes to a path of that format in
/// the source's folder, without touching the disk.
/// \details When \p format is the source's (and \p source was read by read_mesh_file), these
/// are the preserved bytes of write_mesh_file for a path beside the source: an OBJ's `mtllib`
/// statements and a glTF's image URIs stay as written (nothing is relinked or copied: they
/// resolve against wherever the caller puts the bytes). PLY (ASCII and binary), OBJ, OFF, STL,
/// GLB, glTF with its buffers in data: URIs and 3MF are one file; a glTF asset with external
/// buffers (.bin files) is not, and is refused. Otherwise these are write_mesh's bytes of the
/// positions and triangles, and only then are \p options used. Errors name the source file.
/// A binary file is one copy of the source's bytes, patched.
/// \param source     A file as read by read_mesh_file (or a MeshFile without layout: converted).
/// \param positions  #V×3, row i the new place of source.mesh.V's row i.
/// \param format     The format of the bytes.
/// \param options    As write_mesh (used only when converting).
/// \return The whole file.
/// \pre positions.rows() == source.mesh.V.rows().
/// \throws InvalidOption on a row-count mismatch (or bad options); InvalidMesh on a non-finite
/// position or an index out of range; IoError when a changed coordinate does not fit an
/// integer position type, or when a glTF asset with external buffers is asked for in its own
/// format (ask for another: it then carries the positions and triangles only).
[[nodiscard]] std::string mesh_file_bytes(const MeshFile& source, const Positions& positions,
                                          MeshFormat format, const WriteOptions& options = {});

}  // namespace meshmark

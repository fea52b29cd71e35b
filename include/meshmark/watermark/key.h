// SPDX-License-Identifier: MIT
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "meshmark/core/triangle_mesh.h"

namespace meshmark
{

/// How coefficients are modulated (docs/algorithms/embedding.md, "Modulation").
enum class EmbeddingRule
{
    Additive,  ///< beta = alpha + b' s, one step s for all modulated coefficients (default).
    Paper,     ///< beta = alpha (1 + b' rho) [Wu & Kobbelt 2005, Eq. 6], in the canonical frame.
};

/// Name used in key files and on the command line: "additive" or "paper".
[[nodiscard]] const char* to_string(EmbeddingRule rule) noexcept;
/// \throws InvalidOption for any other name.
[[nodiscard]] EmbeddingRule parse_embedding_rule(const std::string& name);

/// What the additive rule's strength measures (docs/algorithms/embedding.md, "Strength").
enum class StrengthMeasure
{
    /// The RMS distance between the marked and the original surface, to first order: the
    /// area-weighted RMS of the displacement's normal component (surface_rms_displacement),
    /// relative to the bounding-box diagonal of the analysed vertices. What a surface metric
    /// (MRMS) reads, whatever the sampling density (default).
    Surface,
    /// The RMS vertex displacement relative to the principal bounding-box diagonal: the same
    /// number of vertices moves as much wherever they are dense (keys made before 2026-11-25).
    Vertex,
};

/// Names used in key files and on the command line: "surface" or "vertex".
[[nodiscard]] const char* to_string(StrengthMeasure measure) noexcept;
/// \throws InvalidOption for any other name.
[[nodiscard]] StrengthMeasure parse_strength_measure(const std::string& name);

/// Default strength of each rule: the additive rule's RMS surface distance (or, with the vertex
/// measure, RMS vertex displacement) relative to the diagonal, and the paper's rho.
[[nodiscard]] double default_strength(EmbeddingRule rule,
                                      StrengthMeasure measure = StrengthMeasure::Surface) noexcept;

/// The spectral basis the watermark lives in (docs/algorithms/basis.md).
enum class BasisType
{
    Rbf,        ///< Orthogonalized RBFs [Wu & Kobbelt 2005] (default).
    Laplacian,  ///< Eigenvectors of the combinatorial Laplacian [Karni & Gotsman 2000] (baseline).
};

/// How the k RBF centers are chosen (docs/algorithms/embedding.md, "Centers and basis").
enum class CenterSelection
{
    Random,    ///< Uniformly at random from the key's seed (default).
    Decimate,  ///< Survivors of a QEM edge-collapse decimation down to k vertices (seed-free).
};

/// Names used in key files and on the command line: "rbf"/"laplacian", "random"/"decimate".
[[nodiscard]] const char* to_string(BasisType basis) noexcept;
[[nodiscard]] const char* to_string(CenterSelection centers) noexcept;
/// \throws InvalidOption for any other name.
[[nodiscard]] BasisType parse_basis_type(const std::string& name);
/// \throws InvalidOption for any other name.
[[nodiscard]] CenterSelection parse_center_selection(const std::string& name);

/// Parameters that, with the original mesh and the seed, determine the watermark.
struct EmbedOptions
{
    int basis_size = 100;  ///< k, number of RBF centers [Wu & Kobbelt: 100].
    int coefficients = 8;  ///< m, bits per axis: 3m payload bits (24, Wu & Kobbelt's count).
    /// Spreading factor r: each payload bit is embedded on r coefficients (modes m r in all,
    /// bit t on coefficients t, t + 3m, t + 6m, ...), each with its own key-mask sign, and read
    /// back by soft-decision correlation. More coefficients at the same distortion make a
    /// verdict with a far smaller false-positive probability possible (docs/statistics.md).
    /// kAutoRepetitions (the default) lets the watermark choose on the original
    /// (automatic_repetitions, watermark.h): 5 (120 coefficients on modes 12-51, an intact score
    /// of sqrt(120) = 10.95) on meshes of 5,000 analysed vertices or more, else 4 (96
    /// coefficients on modes 12-43, 9.8); 2 for a family key's owner mark (kFamilyRepetitions);
    /// fewer where the original's vertices span fewer modes of the basis than that (a flat CAD
    /// part whose faces have no inner vertices: EmbedStats::shortened_to_span).
    /// The key file records the number chosen. Keys written before this field existed mean 1.
    int repetitions = kAutoRepetitions;
    /// repetitions value that asks the watermark to choose (never stored in a key file).
    static constexpr int kAutoRepetitions = 0;
    /// Index of the first modulated mode: modes first_mode .. first_mode + m r - 1 carry the
    /// mark. The very first modes are almost rigid motions of the whole model, which detection
    /// must fit and remove, so a mark there is lost; skipping them keeps the energy where it
    /// is read back (docs/statistics.md). Keys written before this field existed mean 0.
    int first_mode = 12;
    EmbeddingRule rule = EmbeddingRule::Additive;
    /// Additive: the displacement as a fraction of the diagonal, in `measure`.
    /// Paper: rho. Negative means "the rule's default" (default_strength).
    double strength = -1.0;
    /// What the additive strength measures. Keys without the field mean Vertex; the paper's
    /// rule ignores it.
    StrengthMeasure measure = StrengthMeasure::Surface;
    /// The surface measure, once calibrated on the original (the embedding does it when it
    /// makes the key): the RMS vertex displacement, as a fraction of the principal bbox
    /// diagonal, that gives `strength`. The modulation, and so detection, are built from it.
    /// Negative until calibrated.
    double vertex_strength = -1.0;
    double sigma_factor = 1.0;  ///< sigma = sigma_factor * diagonal / 2 [Wu & Kobbelt].
    /// The basis; keys written before this field existed mean Rbf.
    BasisType basis = BasisType::Rbf;
    /// RBF centers; ignored by the Laplacian basis. Keys without the field mean Random.
    CenterSelection centers = CenterSelection::Random;
    /// RBF Gram matrix from at most this many rows (0 = every row): above it, G = B^T B,
    /// B^T 1 and B^T P are estimated from that many evenly spaced rows (RbfBasis), which makes
    /// the basis pass of very large meshes cost the same as at this size; meshes with fewer
    /// analysed vertices are unaffected. Ignored by the Laplacian basis. Keys written before
    /// this field existed mean 0 (docs/algorithms/basis.md, "Sampled Gram matrix").
    std::int64_t gram_rows = kDefaultGramRows;
    static constexpr std::int64_t kDefaultGramRows = std::int64_t{1} << 20;
    /// Smallest gram_rows other than 0, as a multiple of the basis size (chosen by hand; no
    /// study on record).
    static constexpr int kMinGramRowsPerCenter = 16;

    /// \throws InvalidOption naming the field, value and allowed range.
    void validate() const;
    /// The strength actually used (resolves the negative default).
    [[nodiscard]] double resolved_strength() const noexcept;
    /// True for the additive rule with the surface measure not yet calibrated.
    [[nodiscard]] bool needs_calibration() const noexcept;
    /// Additive rule: the RMS vertex displacement (fraction of the principal bbox diagonal) the
    /// modulation is built from: the strength (vertex measure), the calibrated vertex_strength,
    /// or before calibration the strength times sqrt(3) (what an isotropic displacement needs
    /// for that surface distance on a uniformly sampled surface).
    [[nodiscard]] double modulation_strength() const noexcept;
};

/// Number of payload bits for \p options (3m).
[[nodiscard]] inline int payload_bit_count(const EmbedOptions& options) noexcept
{
    return 3 * options.coefficients;
}

/// Number of modes that carry the watermark (m r), from EmbedOptions::first_mode on.
[[nodiscard]] inline int modulated_modes(const EmbedOptions& options) noexcept
{
    return options.coefficients * options.repetitions;
}

/// Identifies the original mesh a key belongs to.
struct MeshFingerprint
{
    std::int64_t vertex_count = 0;
    std::int64_t face_count = 0;
    std::uint64_t position_hash = 0;  ///< hash_bytes over the positions as IEEE doubles.

    friend bool operator==(const MeshFingerprint&, const MeshFingerprint&) = default;
};

/// Fingerprint of a mesh's positions and counts.
[[nodiscard]] MeshFingerprint fingerprint(const TriangleMesh& mesh);

/// One recipient of a family key: its copy carries the code drawn from the key's seed and
/// its index (recipient_code), so the name and index are all the key records of it.
struct Recipient
{
    std::string name;
    std::uint32_t index = 0;
};

/// \brief The per-recipient part of a family key (docs/fingerprinting.md): every copy carries
/// the owner's mark and, on the M modes after it, a code of its own, one independent keyed
/// sign per coefficient (3M).
/// r of a new family key's owner mark unless chosen: 2 (48 coefficients on modes 12-27), so
/// that the recipient code's 64 modes fit after it in the default basis of 100.
inline constexpr int kFamilyRepetitions = 2;

/// The fewest modes a shortened recipient code keeps (RecipientCodes::shorten_to_span): 72
/// coefficients, an intact copy's code scores about 8.5.
inline constexpr int kMinRecipientModes = 24;

struct RecipientCodes
{
    /// M, the modes after the owner's (first_mode + m r ..) that carry the recipient code: 64
    /// fit after a family owner's modes 12-27 in the default basis of 100 (docs/fingerprinting.md).
    int modes = 64;
    /// Share of the displacement energy (strength^2) given to the recipient code; the owner's
    /// mark keeps the rest, so a copy is displaced as much as a single mark of the same strength.
    /// 0.64: the codes carry single copies through the attack suite and the owner's 36% keeps
    /// the mark of pooled copies (docs/fingerprinting.md).
    double energy_share = 0.64;
    std::vector<Recipient> recipients;  ///< In the order they were issued; indices unique.
    /// \brief A new key only (never stored): where the original's vertices span too few modes
    /// for M after the owner's mark, the watermark takes as many as fit, down to
    /// kMinRecipientModes, and the key records that M (SpectralWatermark::key()).
    bool shorten_to_span = false;

    /// The recipient called \p name, or null.
    [[nodiscard]] const Recipient* find(const std::string& name) const noexcept;
    /// \throws InvalidOption for M < 1, a share outside (0, 1), or modes beyond the basis.
    void validate(const EmbedOptions& options) const;
};

/// \brief Checks a recipient name: 1-100 characters, none of them '/', '\\', a control
/// character or a quote, not starting with '.' (a name becomes part of a file name).
/// \throws InvalidOption naming the problem.
void check_recipient_name(const std::string& name);

/// \brief The code of recipient \p index: n signs (0/1 for -1/+1) from the seed's
/// "recipient-code" stream for that index, independent of every other recipient's and of the
/// owner's mask.
[[nodiscard]] std::vector<std::uint8_t> recipient_code(std::uint64_t seed, std::uint32_t index,
                                                       int n);

/// \brief Everything that, with the original mesh, regenerates the watermarked mesh and
/// detects it: stored as a versioned JSON key file (mode 0600).
struct Key
{
    static constexpr int kVersion = 1;

    std::uint64_t seed = 0;  ///< Secret; every random choice derives from it.
    EmbedOptions options;
    std::vector<std::uint8_t> payload;   ///< 3m bits (0/1), before the key-derived mask.
    std::optional<std::string> message;  ///< The text the payload was derived from, if any.
    MeshFingerprint original;
    /// A family key (one copy per recipient, `meshmark embed --recipient`): the recipients'
    /// codes. Absent for a single-owner key.
    std::optional<RecipientCodes> recipients;
};

/// \brief Payload bits from a message: the first n bits of Rng(hash_bytes(message)).
[[nodiscard]] std::vector<std::uint8_t> payload_from_message(const std::string& message, int n);

/// \brief Payload bits from hex digits, most significant bit first.
/// \details Exactly ceil(n / 4) digits are required; unused low bits of the last digit must be 0.
/// \throws InvalidOption for other lengths, non-hex characters or non-zero padding.
[[nodiscard]] std::vector<std::uint8_t> payload_from_hex(const std::string& hex, int n);

/// \brief A random payload drawn from the seed's "payload" stream.
[[nodiscard]] std::vector<std::uint8_t> random_payload(std::uint64_t seed, int n);

/// \brief A new key (the one way to make one): \p seed, \p options with the strength resolved
/// (EmbedOptions::resolved_strength), and the payload from \p message (payload_from_message),
/// else from \p bits_hex (payload_from_hex), else drawn from the seed (random_payload).
/// \details The original's fingerprint is left empty: set `key.original = fingerprint(original)`
/// before the key is used to detect or written (the in-memory embed and embed_file do).
/// \throws InvalidOption for malformed \p bits_hex.
[[nodiscard]] Key make_key(const EmbedOptions& options, std::uint64_t seed,
                           const std::optional<std::string>& message = std::nullopt,
                           const std::optional<std::string>& bits_hex = std::nullopt);

/// \brief The key-derived mask XOR-ed with the payload before embedding
/// (docs/algorithms/embedding.md, "Payload bits"): without it, a wrong key reads the mark, because
/// the leading modes barely depend on the centers. \details One bit per modulated coefficient (3 m
/// r); the first n bits do not depend on n.
[[nodiscard]] std::vector<std::uint8_t> payload_mask(std::uint64_t seed, int n);

/// Bits as a string of '0'/'1'.
[[nodiscard]] std::string to_bit_string(const std::vector<std::uint8_t>& bits);
/// Bits as hex digits, most significant first (the inverse of payload_from_hex).
[[nodiscard]] std::string to_hex(const std::vector<std::uint8_t>& bits);

/// \brief Serialize a key to its JSON text (versioned, with a checksum over the content).
[[nodiscard]] std::string to_json(const Key& key);
/// \brief Parse and validate a key's JSON text.
/// \param source Names the file in error messages.
/// \throws IoError for malformed JSON, another format or version, missing or invalid fields,
/// or a checksum mismatch (a tampered or truncated key).
[[nodiscard]] Key parse_key(const std::string& text, const std::string& source);

/// \brief Write a key file atomically with mode 0600.
void write_key(const std::filesystem::path& path, const Key& key);
/// \brief Read and validate a key file. \throws IoError as parse_key, or if unreadable.
[[nodiscard]] Key read_key(const std::filesystem::path& path);

}  // namespace meshmark

// SPDX-License-Identifier: MIT
#include "meshmark/attacks/attack_spec.h"

#include <array>
#include <charconv>
#include <initializer_list>
#include <optional>
#include <utility>

#include "attacks/detail/format.h"
#include "attacks/detail/step_reader.h"
#include "meshmark/core/error.h"

namespace meshmark
{
namespace
{

constexpr std::string_view kKnownAttacks =
    "similarity, noise, smooth, taubin, quantize, simplify, remesh, subdivide, crop, reorder, "
    "voxel";

using detail::quoted;
using detail::split;
using detail::StepReader;
using detail::trim;

// --- Direction keys shared by similarity and crop: axis=x|y|z, or ax=, ay=, az=. ---

std::optional<Eigen::Vector3d> take_axis(StepReader& step)
{
    const auto word = step.take("axis");
    const auto ax = step.take_number("ax");
    const auto ay = step.take_number("ay");
    const auto az = step.take_number("az");
    const bool has_components = ax || ay || az;
    if (word && has_components)
    {
        step.fail("give the axis as axis=x|y|z or as ax=,ay=,az=, not both.");
    }
    if (word)
    {
        return step.choice<Eigen::Vector3d>(*word, "the axis",
                                            {{"x", Eigen::Vector3d::UnitX()},
                                             {"y", Eigen::Vector3d::UnitY()},
                                             {"z", Eigen::Vector3d::UnitZ()}});
    }
    if (has_components)
    {
        return Eigen::Vector3d(ax.value_or(0.0), ay.value_or(0.0), az.value_or(0.0));
    }
    return std::nullopt;
}

std::string axis_keys(const Eigen::Vector3d& axis)
{
    const std::array<std::pair<const char*, Eigen::Vector3d>, 3> named = {
        {{"x", Eigen::Vector3d::UnitX()},
         {"y", Eigen::Vector3d::UnitY()},
         {"z", Eigen::Vector3d::UnitZ()}}};
    for (const auto& [name, unit] : named)
    {
        if (axis == unit)
        {
            return std::string(":axis=") + name;
        }
    }
    return ":ax=" + detail::format_number(axis.x()) + ":ay=" + detail::format_number(axis.y()) +
           ":az=" + detail::format_number(axis.z());
}

std::string key(const char* name, double value)
{
    return std::string(":") + name + "=" + detail::format_number(value);
}

// --- One parser per attack: level and keys into the options struct. ---

AttackSpec parse_similarity(StepReader& step)
{
    step.forbid_level();
    SimilarityOptions options;
    const auto axis = take_axis(step);
    const auto angle = step.take_number("angle");
    const auto scale = step.take_number("scale");
    const auto tx = step.take_number("tx");
    const auto ty = step.take_number("ty");
    const auto tz = step.take_number("tz");
    const auto mirror = step.take("mirror");
    const auto smax = step.take_number("smax");
    const auto tmax = step.take_number("tmax");
    step.finish(
        "axis, ax, ay, az, angle, scale, tx, ty, tz, mirror (explicit); smax, tmax (random)");
    options.is_random = !(axis || angle || scale || tx || ty || tz || mirror);
    if (!options.is_random && (smax || tmax))
    {
        step.fail(
            "smax and tmax shape a random similarity and cannot be mixed with explicit "
            "keys.");
    }
    options.axis = axis.value_or(options.axis);
    options.angle_deg = angle.value_or(options.angle_deg);
    options.scale = scale.value_or(options.scale);
    options.translation = {tx.value_or(0.0), ty.value_or(0.0), tz.value_or(0.0)};
    if (mirror)
    {
        options.mirror = step.choice<int>(*mirror, "the mirror", {{"x", 0}, {"y", 1}, {"z", 2}});
    }
    options.max_scale = smax.value_or(options.max_scale);
    options.max_translation_radii = tmax.value_or(options.max_translation_radii);
    return options;
}

AttackSpec parse_noise(StepReader& step)
{
    NoiseOptions options;
    options.amplitude = step.level_number("the amplitude").value_or(options.amplitude);
    options.distribution =
        step.take_choice<NoiseDistribution>("dist", {{"uniform", NoiseDistribution::Uniform},
                                                     {"gaussian", NoiseDistribution::Gaussian}})
            .value_or(options.distribution);
    options.direction =
        step.take_choice<NoiseDirection>(
                "dir", {{"iso", NoiseDirection::Isotropic}, {"normal", NoiseDirection::Normal}})
            .value_or(options.direction);
    options.reference =
        step.take_choice<NoiseReference>("ref", {{"diag", NoiseReference::BboxDiagonal},
                                                 {"centroid", NoiseReference::CentroidDistance}})
            .value_or(options.reference);
    step.finish("dist, dir, ref");
    return options;
}

AttackSpec parse_smooth(StepReader& step)
{
    LaplacianSmoothingOptions options;
    options.iterations = step.level_integer("the iteration count").value_or(options.iterations);
    options.lambda = step.take_number("lambda").value_or(options.lambda);
    step.finish("lambda");
    return options;
}

AttackSpec parse_taubin(StepReader& step)
{
    TaubinSmoothingOptions options;
    options.iterations = step.level_integer("the iteration count").value_or(options.iterations);
    options.lambda = step.take_number("lambda").value_or(options.lambda);
    options.mu = step.take_number("mu").value_or(options.mu);
    step.finish("lambda, mu");
    return options;
}

AttackSpec parse_quantize(StepReader& step)
{
    QuantizationOptions options;
    options.bits = step.level_integer("the bit count").value_or(options.bits);
    step.finish("");
    return options;
}

AttackSpec parse_simplify(StepReader& step)
{
    SimplificationOptions options;
    options.vertex_fraction =
        step.level_number("the vertex fraction").value_or(options.vertex_fraction);
    options.policy = step.take_choice<SimplificationPolicy>(
                             "policy", {{"gh", SimplificationPolicy::GarlandHeckbert},
                                        {"lt", SimplificationPolicy::LindstromTurk}})
                         .value_or(options.policy);
    options.method = step.take_choice<SimplificationMethod>(
                             "method", {{"meshopt", SimplificationMethod::Meshoptimizer},
                                        {"cgal", SimplificationMethod::Cgal}})
                         .value_or(options.method);
    options.boundary_weight = step.take_number("boundary").value_or(options.boundary_weight);
    step.finish("policy, method, boundary");
    return options;
}

AttackSpec parse_remesh(StepReader& step)
{
    RemeshingOptions options;
    options.vertex_fraction =
        step.level_number("the vertex fraction").value_or(options.vertex_fraction);
    options.iterations = step.take_integer("iter").value_or(options.iterations);
    step.finish("iter");
    return options;
}

AttackSpec parse_subdivide(StepReader& step)
{
    SubdivisionOptions options;
    if (const auto level = step.level())
    {
        options.scheme = step.choice<SubdivisionScheme>(*level, "the scheme",
                                                        {{"loop", SubdivisionScheme::Loop},
                                                         {"midpoint", SubdivisionScheme::Midpoint},
                                                         {"sqrt3", SubdivisionScheme::Sqrt3}});
    }
    options.steps = step.take_integer("steps").value_or(options.steps);
    step.finish("steps");
    return options;
}

AttackSpec parse_crop(StepReader& step)
{
    CropOptions options;
    options.vertex_fraction =
        step.level_number("the vertex fraction").value_or(options.vertex_fraction);
    options.direction = take_axis(step);
    step.finish("axis, ax, ay, az");
    return options;
}

AttackSpec parse_reorder(StepReader& step)
{
    step.forbid_level();
    step.finish("");
    return ReorderOptions{};
}

AttackSpec parse_voxel(StepReader& step)
{
    VoxelRemeshingOptions options;
    options.resolution = step.level_number("the resolution").value_or(options.resolution);
    step.finish("");
    return options;
}

struct AttackParser
{
    std::string_view name;
    AttackSpec (*parse)(StepReader&);
};

// In the order of AttackSpec's alternatives: attack_name() indexes this table by variant index.
constexpr std::array<AttackParser, 11> kParsers = {{
    {"similarity", parse_similarity},
    {"noise", parse_noise},
    {"smooth", parse_smooth},
    {"taubin", parse_taubin},
    {"quantize", parse_quantize},
    {"simplify", parse_simplify},
    {"remesh", parse_remesh},
    {"subdivide", parse_subdivide},
    {"crop", parse_crop},
    {"reorder", parse_reorder},
    {"voxel", parse_voxel},
}};

static_assert(std::variant_size_v<AttackSpec> == kParsers.size());

AttackSpec parse_step(std::string_view text)
{
    StepReader step(text);
    for (const auto& parser : kParsers)
    {
        if (parser.name == step.name())
        {
            AttackSpec spec = parser.parse(step);
            try
            {
                std::visit([](const auto& options) { options.validate(); }, spec);
            }
            catch (const InvalidOption& e)
            {
                step.fail(e.what());
            }
            return spec;
        }
    }
    step.fail("unknown attack " + quoted(step.name()) +
              "; known attacks: " + std::string(kKnownAttacks) + ".");
}

// --- Canonical text, one overload per options struct. ---

std::string text_of(const SimilarityOptions& o)
{
    const SimilarityOptions defaults;
    std::string text = "similarity";
    if (o.is_random)
    {
        text += o.max_scale != defaults.max_scale ? key("smax", o.max_scale) : "";
        text += o.max_translation_radii != defaults.max_translation_radii
                    ? key("tmax", o.max_translation_radii)
                    : "";
        return text;
    }
    std::string keys = o.axis != defaults.axis ? axis_keys(o.axis) : "";
    keys += o.angle_deg != 0.0 ? key("angle", o.angle_deg) : "";
    keys += o.scale != 1.0 ? key("scale", o.scale) : "";
    keys += o.translation.x() != 0.0 ? key("tx", o.translation.x()) : "";
    keys += o.translation.y() != 0.0 ? key("ty", o.translation.y()) : "";
    keys += o.translation.z() != 0.0 ? key("tz", o.translation.z()) : "";
    keys += o.mirror >= 0 ? std::string(":mirror=") + "xyz"[o.mirror] : "";
    // An explicit identity still needs one explicit key to read back as explicit.
    return text + (keys.empty() ? key("scale", 1.0) : keys);
}

std::string text_of(const NoiseOptions& o)
{
    std::string text = "noise=" + detail::format_number(o.amplitude);
    text += o.distribution == NoiseDistribution::Gaussian ? ":dist=gaussian" : "";
    text += o.direction == NoiseDirection::Normal ? ":dir=normal" : "";
    text += o.reference == NoiseReference::CentroidDistance ? ":ref=centroid" : "";
    return text;
}

std::string text_of(const LaplacianSmoothingOptions& o)
{
    const LaplacianSmoothingOptions defaults;
    return "smooth=" + std::to_string(o.iterations) +
           (o.lambda != defaults.lambda ? key("lambda", o.lambda) : "");
}

std::string text_of(const TaubinSmoothingOptions& o)
{
    const TaubinSmoothingOptions defaults;
    return "taubin=" + std::to_string(o.iterations) +
           (o.lambda != defaults.lambda ? key("lambda", o.lambda) : "") +
           (o.mu != defaults.mu ? key("mu", o.mu) : "");
}

std::string text_of(const QuantizationOptions& o)
{
    return "quantize=" + std::to_string(o.bits);
}

std::string text_of(const SimplificationOptions& o)
{
    return "simplify=" + detail::format_number(o.vertex_fraction) +
           (o.policy == SimplificationPolicy::LindstromTurk ? ":policy=lt" : "") +
           (o.method == SimplificationOptions{}.method
                ? ""
                : (o.method == SimplificationMethod::Meshoptimizer ? ":method=meshopt"
                                                                   : ":method=cgal")) +
           (o.boundary_weight != SimplificationOptions{}.boundary_weight
                ? key("boundary", o.boundary_weight)
                : "");
}

std::string text_of(const RemeshingOptions& o)
{
    const RemeshingOptions defaults;
    return "remesh=" + detail::format_number(o.vertex_fraction) +
           (o.iterations != defaults.iterations ? ":iter=" + std::to_string(o.iterations) : "");
}

std::string text_of(const SubdivisionOptions& o)
{
    const char* scheme = o.scheme == SubdivisionScheme::Loop       ? "loop"
                         : o.scheme == SubdivisionScheme::Midpoint ? "midpoint"
                                                                   : "sqrt3";
    return std::string("subdivide=") + scheme +
           (o.steps != 1 ? ":steps=" + std::to_string(o.steps) : "");
}

std::string text_of(const CropOptions& o)
{
    return "crop=" + detail::format_number(o.vertex_fraction) +
           (o.direction ? axis_keys(*o.direction) : "");
}

std::string text_of(const ReorderOptions& /*options*/)
{
    return "reorder";
}

std::string text_of(const VoxelRemeshingOptions& o)
{
    return "voxel=" + detail::format_number(o.resolution);
}
}  // namespace

std::vector<AttackSpec> parse_attack_spec(std::string_view text)
{
    if (trim(text).empty())
    {
        throw InvalidOption(
            "The attack spec is empty; expected STEP[,STEP]... such as "
            "'similarity,simplify=0.1,noise=0.001'.");
    }
    std::vector<AttackSpec> specs;
    for (const auto step : split(text, ','))
    {
        specs.push_back(parse_step(step));
    }
    return specs;
}

std::string to_string(const AttackSpec& spec)
{
    return std::visit([](const auto& options) { return text_of(options); }, spec);
}

std::string to_string(const std::vector<AttackSpec>& specs)
{
    std::string text;
    for (const auto& spec : specs)
    {
        if (!text.empty())
        {
            text += ',';
        }
        text += to_string(spec);
    }
    return text;
}

std::string_view attack_name(const AttackSpec& spec)
{
    return kParsers[spec.index()].name;
}

}  // namespace meshmark

// Stage 1: the initial feature line through the key vertices, along mesh edges.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/cancellation.h"
#include "engine/enum_names.h"
#include "engine/prepared_mesh.h"

namespace featureline {

enum class InitialMethod {
  marching,      ///< the paper's marching feature search (Eqs. 9-10), made robust
  feature_path,  ///< minimal path whose edge cost falls with |mean curvature|
  geodesic,      ///< plain shortest edge path, the paper's baseline (Fig. 3b)
};
template <>
struct EnumNames<InitialMethod> {
  static constexpr std::array<std::pair<InitialMethod, const char*>, 4> entries{{{InitialMethod::marching, "marching"},
                                                                                {InitialMethod::feature_path, "feature-path"},
                                                                                {InitialMethod::geodesic, "geodesic"},
                                                                                {InitialMethod::feature_path, "feature_path"}}};
};

/// What f_C compares; the paper's text allows all three readings.
enum class MarchingCurvatureTerm {
  similar_to_current,  ///< literal: inverse proportion to |C_vi - C_vc| (wanders along iso-lines)
  similar_to_end,      ///< "every vertex ... should have high-curvature similar to v_e": |C_vi - C_ve|
  high_magnitude,      ///< "features are located in high-curvature regions": rank by |C_vi|
};
template <>
struct EnumNames<MarchingCurvatureTerm> {
  static constexpr std::array<std::pair<MarchingCurvatureTerm, const char*>, 3> entries{
      {{MarchingCurvatureTerm::similar_to_current, "similar-to-current"},
       {MarchingCurvatureTerm::similar_to_end, "similar-to-end"},
       {MarchingCurvatureTerm::high_magnitude, "high-magnitude"}}};
};

struct InitialLineOptions {
  InitialMethod method = InitialMethod::feature_path;
  /// Weights of Eq. (10), F = alpha f_O1 + beta f_O2 + gamma f_D + delta f_C; the paper uses 1,1,1,2.
  double marching_alpha = 1, marching_beta = 1, marching_gamma = 1, marching_delta = 2;
  MarchingCurvatureTerm marching_curvature_term = MarchingCurvatureTerm::similar_to_end;
  /// When marching fails on a segment, use feature_path there and record it in `fallbacks`.
  bool fallback = true;
  /// feature_path edge weight = length * (floor + (1 - floor) * (1 - s)), where s in [0, 1] is the
  /// edge's feature strength (mean |H| of its ends over the mesh's 90th percentile, clamped).
  /// Smaller floor hugs features harder; 1 turns feature_path into geodesic. A path along a
  /// full-strength feature may be up to 1 / floor times longer than the straight way across:
  /// at 0.05 keys off every feature drew lines up to four times their keys' distance (random
  /// bunny keys), and on noisy CAD, where noise unmarks a weak crease's edges, paths left it
  /// for a strong crease five times as long (bench_accuracy: the wing nut's refined lines 0.365
  /// -> 0.181 edges from the crease at 0.1; no smooth-field row worse).
  double feature_weight_floor = 0.1;
  /// Feature strength uses only curvature of the keys' sign (ridges or valleys) when the keys
  /// agree in sign; |H| otherwise. Keeps a ridge path from jumping into a neighbouring valley.
  bool sign_aware = true;
  /// The longest line accepted, in edges: every later stage costs in proportion to the line's
  /// length, so this bounds a line's work whatever its keys (InvalidInputError beyond).
  int max_edges = 1000;
};

/// One fallback from marching to feature_path, as reported in `stats.fallbacks`.
struct InitialLineFallback {
  std::size_t segment = 0;  ///< index of the segment (from key `segment` to the next key)
  InitialMethod from = InitialMethod::marching;
  InitialMethod to = InitialMethod::feature_path;
  std::string reason;
};

struct InitialLineResult {
  InitialMethod method = InitialMethod::feature_path;
  /// Vertex ids along the line. For closed lines the first key is not repeated at the end.
  std::vector<std::uint32_t> vertices;
  /// Index into `vertices` of each key, in key order.
  std::vector<std::size_t> key_indices;
  double length = 0;  ///< sum of edge lengths (closing edge included for closed lines)
  std::vector<InitialLineFallback> fallbacks;
  std::vector<std::string> warnings;
};

/// The initial line through `keys` (at least 2; a closed line joins the last key to the first).
/// Consecutive segments avoid vertices already used, so a loop does not retrace itself.
/// \throw InvalidInputError for ids out of range, fewer than two keys or repeated consecutive keys;
///        GeometryError when keys lie on different components or on unreferenced vertices.
/// \throw CancelledError once `cancel` is requested.
InitialLineResult find_initial_line(const PreparedMesh& mesh, const std::vector<std::uint32_t>& keys, bool closed,
                                    const InitialLineOptions& options = {}, const Cancellation* cancel = nullptr);

/// The marching feature search from `from` to `to` alone (no fallback). Returns the path
/// (both ends included) or std::nullopt with `failure` set to the reason.
std::optional<std::vector<std::uint32_t>> marching_search(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                          const InitialLineOptions& options, std::string* failure = nullptr,
                                                          const std::vector<std::uint32_t>* blocked = nullptr,
                                                          const Cancellation* cancel = nullptr);

/// On a noisy mesh, the share of the crease angle from which an unmarked edge's fold weighs as
/// a feature: strength 0 there, rising to 1 at the crease angle (CurvatureField::fold). Noise
/// leaves some edges of a true crease unmarked, bent just under the angle or with wings as sharp,
/// and a line refused them took a parallel crease 3 crease edges off (a wing nut's). From 0.7 to
/// 0.85 bench_accuracy's noisy CAD lines read the same; from 0.6 more lines end worse than
/// their initial line, at 0.9 and above the gain is lost.
constexpr double kFoldFeatureShare = 0.75;

/// The feature path's cost of the edge from v to mesh.neighbors()[k]: its length times
/// floor + (1 - floor)(1 - strength), strength the mean feature strength of its ends, 1 on a
/// crease of the line's sign, 0 on a chord between crease vertices; on a noisy mesh at least
/// what its fold says (kFoldFeatureShare). Never below floor times the length. Not thread-safe
/// (it remembers the last v's strength).
class FeaturePathCost {
 public:
  FeaturePathCost(const PreparedMesh& mesh, const InitialLineOptions& options, double feature_sign);
  double operator()(std::uint32_t v, std::uint32_t k);
  double floor() const { return floor_; }

 private:
  // The strength an unmarked edge's fold gives it for lines of sign_ (kFoldFeatureShare); 0
  // where no folds are measured (a clean mesh, or creases off).
  double fold_strength(std::uint32_t k) const;

  const PreparedMesh& mesh_;
  double floor_, sign_;
  bool noisy_;  // the mesh's noise reaches kNoisyCreaseNoise
  std::uint32_t strength_of_ = UINT32_MAX;  // the vertex whose strength strength_v_ holds
  double strength_v_ = 0;
};

/// Minimal edge path from `from` to `to` (A* from both ends): `feature_weighted` selects the feature_path cost,
/// otherwise plain length. Vertices in `blocked` (sorted ids) are avoided, ends excepted. Paths
/// costing more than `max_cost` are not searched (std::nullopt), which keeps a search for a
/// nearby vertex local when blocked vertices wall it off.
std::optional<std::vector<std::uint32_t>> shortest_edge_path(const PreparedMesh& mesh, std::uint32_t from, std::uint32_t to,
                                                             bool feature_weighted, const InitialLineOptions& options,
                                                             double feature_sign = 0,
                                                             const std::vector<std::uint32_t>* blocked = nullptr,
                                                             const Cancellation* cancel = nullptr,
                                                             double max_cost = HUGE_VAL);


inline double FeaturePathCost::operator()(std::uint32_t v, std::uint32_t k) {
  const auto w = mesh_.neighbors()[k];
  if (strength_of_ != v) strength_of_ = v, strength_v_ = mesh_.feature_strength(v, sign_);
  // A crease edge of the line's kind is a feature whatever its ends' curvature says
  // (on skinny CAD triangles the vertex fields are unreliable, a dihedral angle is not).
  const auto crease = mesh_.curvature().crease[k];
  const bool on_crease = crease != 0 && (sign_ == 0 || crease == sign_);
  // A chord across a face (CurvatureField::chord), or a crease of the other kind: no feature. On
  // a noisy mesh a crease's sign is not: noise folds the skinny faces along a crease, so a short
  // edge of a convex crease can read concave, and a line refused it detours over noise-marked
  // edges beside the crease (a wing nut's line, 1 edge length off it); there it weighs as its
  // vertices' field says.
  const bool chord = !on_crease && ((crease != 0 && !noisy_) || mesh_.curvature().chord[k]);
  double strength = on_crease ? 1.0 : chord ? 0.0 : 0.5 * (strength_v_ + mesh_.feature_strength(w, sign_));
  if (!on_crease && !chord) strength = std::max(strength, fold_strength(k));
  return mesh_.neighbor_edge_lengths()[k] * (floor_ + (1 - floor_) * (1 - strength));
}

inline double FeaturePathCost::fold_strength(std::uint32_t k) const {
  const auto& folds = mesh_.curvature().fold;
  if (folds.empty()) return 0;
  const double fold = folds[k] / double(CurvatureField::kFoldScale);
  const double share = sign_ == 0 ? std::abs(fold) : fold * sign_;
  return std::clamp((share - kFoldFeatureShare) / (1 - kFoldFeatureShare), 0.0, 1.0);
}

/// +1 when every key sits on a ridge (H above 5% of the curvature scale), -1 when every key sits
/// in a valley, 0 otherwise or when `options.sign_aware` is off.
double keys_feature_sign(const PreparedMesh& mesh, const std::vector<std::uint32_t>& keys, const InitialLineOptions& options);

/// Sum of Euclidean edge lengths along a vertex path.
double path_length(const PreparedMesh& mesh, const std::vector<std::uint32_t>& path, bool closed = false);

}  // namespace featureline

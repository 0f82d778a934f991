// What the stages refining one line share, decided once per line by detect_feature_line from the
// request, its keys (or trace) and the prepared mesh. Options configure a stage; this reports
// what the line is, so no stage re-derives it or reads it from an option overwritten per line.
#pragma once

namespace featureline {

struct LineContext {
  /// The feature the line follows: +1 ridges (C > 0 attracts), -1 valleys, 0 either (|C|, the
  /// paper's). SnakeOptions::feature_sign when the request sets it, else the traced feature's
  /// sign, else the keys' when InitialLineOptions::sign_aware.
  double feature_sign = 0;
  /// The mesh's estimated noise is at or above FeatureLineOptions::exact_crease_noise: crease
  /// runs are re-fitted rather than kept exactly, and the automatic strip layout tolerates a
  /// smaller dropped share (StripOptions::max_dropped_share_noisy).
  bool noisy_mesh = false;
};

}  // namespace featureline

// Colour maps, free of three.js so they can be checked on their own.
// Colours are sRGB components in [0, 1]; the viewer converts them to linear for WebGL.

// A diverging map (blue - light grey - red), sampled at evenly spaced stops over [-1, 1].
export const DIVERGING_STOPS = [
  [0.230, 0.299, 0.754],
  [0.552, 0.690, 0.996],
  [0.866, 0.866, 0.866],
  [0.958, 0.604, 0.483],
  [0.706, 0.016, 0.150],
];

// t in [-1, 1] (clamped) -> [r, g, b].
export function diverging(t) {
  const x = (Math.min(1, Math.max(-1, Number.isFinite(t) ? t : 0)) + 1) / 2 * (DIVERGING_STOPS.length - 1);
  const i = Math.min(DIVERGING_STOPS.length - 2, Math.floor(x));
  const f = x - i;
  const a = DIVERGING_STOPS[i];
  const b = DIVERGING_STOPS[i + 1];
  return [a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f, a[2] + (b[2] - a[2]) * f];
}

// CSS linear-gradient of the diverging map, for the legend.
export function divergingCss() {
  const stops = DIVERGING_STOPS.map((c, i) => {
    const [r, g, b] = c.map((v) => Math.round(v * 255));
    return `rgb(${r} ${g} ${b}) ${(100 * i) / (DIVERGING_STOPS.length - 1)}%`;
  });
  return `linear-gradient(to right, ${stops.join(', ')})`;
}

// The q-quantile (0..1) of |values| (finite ones only); 0 when there are none.
export function absPercentile(values, q) {
  const abs = [];
  for (const v of values) if (Number.isFinite(v)) abs.push(Math.abs(v));
  if (abs.length === 0) return 0;
  abs.sort((a, b) => a - b);
  const pos = Math.min(1, Math.max(0, q)) * (abs.length - 1);
  const lo = Math.floor(pos);
  const hi = Math.min(abs.length - 1, lo + 1);
  return abs[lo] + (abs[hi] - abs[lo]) * (pos - lo);
}

// The symmetric range [-r, r] used for the curvature colours: the 95th percentile of |k| (the server's dominant signed principal curvature)
// (robust to the few extreme values at spikes and boundaries), never 0.
export function curvatureRange(values) {
  const r = absPercentile(values, 0.95);
  if (r > 0) return r;
  const max = absPercentile(values, 1);
  return max > 0 ? max : 1;
}

export function rgbCss([r, g, b]) {
  return `rgb(${Math.round(r * 255)} ${Math.round(g * 255)} ${Math.round(b * 255)})`;
}

// Labelling: faces connected across uncut edges, slivers merged, parts measured and ordered.
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>

#include "engine/errors.h"
#include "engine/segmentation/stages.h"

namespace featureline {
namespace {

/// Flood fill: faces joined across the links of `across`. Returns the number of labels (in order
/// of each label's lowest face).
int flood_fill(const std::vector<Triangle>& across, std::vector<int>& labels) {
  labels.assign(across.size(), -1);
  int count = 0;
  std::vector<std::uint32_t> stack;
  for (std::uint32_t s = 0; s < across.size(); ++s) {
    if (labels[s] >= 0) continue;
    labels[s] = count;
    stack.assign(1, s);
    while (!stack.empty()) {
      const auto f = stack.back();
      stack.pop_back();
      for (int k = 0; k < 3; ++k) {
        const auto g = across[f][k];
        if (g == kNoIndex || labels[g] >= 0) continue;
        labels[g] = count;
        stack.push_back(g);
      }
    }
    ++count;
  }
  return count;
}

/// `across` without the links over the cut edges.
std::vector<Triangle> sever(const CutMesh& cut) {
  std::vector<Triangle> across = *cut.face_neighbors;
  const auto& tris = *cut.triangles;
  for (const auto& edge : cut.cuts) {
    const auto a = std::uint32_t(edge.first >> 32);  // the lower end; its faces hold the edge
    for (auto it = cut.vertex_faces->begin(a); it != cut.vertex_faces->end(a); ++it)
      for (int k = 0; k < 3; ++k)
        if (edge_key(tris[*it][k], tris[*it][(k + 1) % 3]) == edge.first) across[*it][k] = kNoIndex;
  }
  return across;
}

std::string percent(double fraction) {
  std::ostringstream out;
  out.precision(fraction < 0.001 ? 2 : 3);
  out << 100 * fraction << "%";
  return out.str();
}

/// Length of cut boundary between each pair of labels (lower label first).
std::map<std::pair<int, int>, double> shared_boundary(const CutMesh& cut, const std::vector<int>& labels) {
  const auto& tris = *cut.triangles;
  const auto& p = *cut.positions;
  std::map<std::pair<int, int>, double> shared;
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto g = (*cut.face_neighbors)[f][k];
      if (g == kNoIndex || g < f || labels[g] == labels[f]) continue;
      const auto a = tris[f][k], b = tris[f][(k + 1) % 3];
      shared[{std::min(labels[f], labels[g]), std::max(labels[f], labels[g])}] += (p[a] - p[b]).norm();
    }
  return shared;
}

/// Joins each segment below min_segment_area_fraction into the neighbour it shares the most cut
/// boundary with (smallest first); relabels 0..n-1 and returns how many were merged.
std::size_t merge_tiny_segments(const CutMesh& cut, double min_fraction, std::vector<int>& labels, int& count) {
  std::vector<double> area(static_cast<std::size_t>(count), 0.0);
  double total = 0;
  for (std::uint32_t f = 0; f < cut.triangles->size(); ++f) {
    const double a = triangle_area(*cut.positions, (*cut.triangles)[f]);
    area[std::size_t(labels[f])] += a;
    total += a;
  }
  const auto shared = shared_boundary(cut, labels);
  UnionFind sets(static_cast<std::size_t>(count));
  std::vector<int> by_area(static_cast<std::size_t>(count));
  std::iota(by_area.begin(), by_area.end(), 0);
  std::sort(by_area.begin(), by_area.end(), [&](int a, int b) { return area[std::size_t(a)] < area[std::size_t(b)]; });
  std::size_t merged = 0;
  for (int r : by_area) {
    const auto root = sets.find(std::uint32_t(r));
    if (area[root] >= min_fraction * total) continue;
    std::map<std::uint32_t, double> neighbours;
    for (const auto& [pair, length] : shared) {
      const auto a = sets.find(std::uint32_t(pair.first)), b = sets.find(std::uint32_t(pair.second));
      if (a != b && (a == root || b == root)) neighbours[a == root ? b : a] += length;
    }
    if (neighbours.empty()) continue;  // a separate component of the mesh: nothing to join
    const auto best = std::max_element(neighbours.begin(), neighbours.end(),
                                       [](const auto& x, const auto& y) { return x.second < y.second; });
    sets.unite(root, best->first);
    area[best->first] += area[root];
    ++merged;
  }
  std::vector<int> compact(static_cast<std::size_t>(count), -1);
  int n = 0;
  for (int r = 0; r < count; ++r)
    if (sets.is_root(std::uint32_t(r))) compact[std::size_t(r)] = n++;
  for (auto& l : labels) l = compact[sets.find(std::uint32_t(l))];
  count = n;
  return merged;
}

/// Faces, area and bounding box per label; first_face: each label's lowest face.
std::vector<Segment> measure_segments(const CutMesh& cut, const std::vector<int>& labels, int count,
                                      std::vector<std::uint32_t>& first_face) {
  const auto& tris = *cut.triangles;
  const auto& p = *cut.positions;
  std::vector<Segment> segments(static_cast<std::size_t>(count));
  first_face.assign(std::size_t(count), kNoIndex);
  for (auto& s : segments) {
    s.bbox_min = {HUGE_VAL, HUGE_VAL, HUGE_VAL};
    s.bbox_max = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  }
  for (std::uint32_t f = 0; f < tris.size(); ++f) {
    auto& s = segments[std::size_t(labels[f])];
    if (first_face[std::size_t(labels[f])] == kNoIndex) first_face[std::size_t(labels[f])] = f;
    ++s.faces;
    s.area += triangle_area(p, tris[f]);
    for (auto v : tris[f])
      for (int d = 0; d < 3; ++d) {
        s.bbox_min[d] = std::min(s.bbox_min[d], p[v][d]);
        s.bbox_max[d] = std::max(s.bbox_max[d], p[v][d]);
      }
  }
  return segments;
}

/// Adds the cut boundary lengths to `segments`; returns which lines cut an edge between segments.
std::vector<char> measure_boundaries(const CutMesh& cut, const std::vector<int>& labels, std::size_t line_count,
                                     std::vector<Segment>& segments) {
  const auto& tris = *cut.triangles;
  const auto& p = *cut.positions;
  std::vector<char> line_separates(line_count, 0);
  for (std::uint32_t f = 0; f < tris.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      const auto g = (*cut.face_neighbors)[f][k];
      if (g == kNoIndex || g < f || labels[g] == labels[f]) continue;
      const auto a = tris[f][k], b = tris[f][(k + 1) % 3];
      const double length = (p[a] - p[b]).norm();
      segments[std::size_t(labels[f])].boundary_length += length;
      segments[std::size_t(labels[g])].boundary_length += length;
      const auto it = cut.cuts.find(edge_key(a, b));
      if (it != cut.cuts.end()) line_separates[std::size_t(it->second)] = 1;
    }
  return line_separates;
}

/// Renumbers labels by decreasing area (ties: the segment holding the lower face first).
void order_by_area(const std::vector<int>& labels, const std::vector<Segment>& segments,
                   const std::vector<std::uint32_t>& first_face, SegmentationResult& result) {
  const int count = int(segments.size());
  std::vector<int> order(static_cast<std::size_t>(count));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    if (segments[std::size_t(a)].area != segments[std::size_t(b)].area)
      return segments[std::size_t(a)].area > segments[std::size_t(b)].area;
    return first_face[std::size_t(a)] < first_face[std::size_t(b)];
  });
  std::vector<int> rank(static_cast<std::size_t>(count));
  for (int r = 0; r < count; ++r) rank[std::size_t(order[std::size_t(r)])] = r;
  result.labels.resize(labels.size());
  for (std::size_t f = 0; f < labels.size(); ++f) result.labels[f] = rank[std::size_t(labels[f])];
  for (int r = 0; r < count; ++r) {
    result.segments.push_back(segments[std::size_t(order[std::size_t(r)])]);
    result.segments.back().label = r;
    result.total_area += result.segments.back().area;
  }
}

[[noreturn]] void throw_no_region(std::size_t line_count, const CutReport& report) {
  std::ostringstream msg;
  msg << "the lines close no region: cutting along " << (line_count == 1 ? "the line" : "them")
      << " leaves every part of the mesh in one piece";
  if (!report.loose_ends.empty()) {
    msg << " (" << report.loose_ends.front();
    if (report.loose_ends.size() > 1) msg << "; and " << report.loose_ends.size() - 1 << " more loose end(s)";
    msg << "); an open line must end on the mesh boundary or on another line";
  } else {
    msg << " (a loop around a handle or a line along the boundary separates nothing)";
  }
  throw GeometryError(msg.str());
}

}  // namespace

LabelReport label_segments(const CutMesh& cut, std::size_t line_count, const SegmentationOptions& options,
                           const CutReport& report, SegmentationResult& result) {
  // Faces connected across uncut edges; what the cuts added to the mesh's own components.
  std::vector<int> labels;
  const int base = flood_fill(*cut.face_neighbors, labels);
  int count = flood_fill(sever(cut), labels);
  if (count <= base) throw_no_region(line_count, report);
  LabelReport out;
  if (options.merge_tiny_segments && options.min_segment_area_fraction > 0) {
    out.merged = merge_tiny_segments(cut, options.min_segment_area_fraction, labels, count);
    if (count <= base)
      throw GeometryError("the lines close no region larger than min_segment_area_fraction (" +
                          std::to_string(options.min_segment_area_fraction) +
                          " of the area): every region they close was merged back into its neighbour");
  }
  std::vector<std::uint32_t> first_face;
  auto segments = measure_segments(cut, labels, count, first_face);
  out.line_separates = measure_boundaries(cut, labels, line_count, segments);
  order_by_area(labels, segments, first_face, result);
  result.cut_edges = cut.cuts.size();
  return out;
}

void add_segmentation_warnings(const std::vector<FeatureLineResult>& lines, const SegmentationOptions& options,
                               const CutReport& report, const LabelReport& labelling, SegmentationResult& result) {
  for (const auto& e : report.loose_ends) result.warnings.push_back(e + "; it cuts into a region without closing it");
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (!labelling.line_separates[i])
      result.warnings.push_back("line " + std::to_string(i) + " separates no segments from each other (it " +
                                (lines[i].closed ? "runs inside one segment" : "is open and ends inside a segment") + ")");
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (report.gaps[i] > 0)
      result.warnings.push_back("line " + std::to_string(i) + " jumps " + std::to_string(report.gaps[i]) +
                                " time(s) between parts of the mesh that share no edge (a seam of duplicated "
                                "vertices or separate components); it is not cut across those gaps");
  if (report.fallbacks > 0)
    result.warnings.push_back(std::to_string(report.fallbacks) +
                              " piece(s) of the lines between consecutive refined points could not be followed "
                              "across faces and were cut along mesh edges instead");
  if (labelling.merged > 0)
    result.warnings.push_back(std::to_string(labelling.merged) +
                              " segment(s) below min_segment_area_fraction were merged into the neighbour they share "
                              "the most cut boundary with");
  for (const auto& s : result.segments) {
    const double fraction = result.total_area > 0 ? s.area / result.total_area : 0;
    if (fraction < options.min_segment_area_fraction) {
      std::ostringstream msg;
      msg << "segment " << s.label << " is tiny: " << percent(fraction) << " of the area (" << s.faces
          << " face(s)), below min_segment_area_fraction " << options.min_segment_area_fraction
          << "; lines that nearly meet or cross, or a line doubling back on itself, leave such slivers";
      result.warnings.push_back(msg.str());
    }
  }
}

}  // namespace featureline

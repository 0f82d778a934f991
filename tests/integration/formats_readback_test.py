#!/usr/bin/python3
"""Files of api/export_formats.h read back by readers that are not ours.

The gtest ExportFormatsSample (tests/api/export_formats_test.cpp, path in $EXPORT_SAMPLE_TEST)
writes real feature lines and segmentations in every interchange format, with expected.json
beside them holding the JSON answers they came from. Each file is read here with an
independent reader from Debian's packages (scripts/setup.sh installs them):

  lines.obj            VTK's vtkOBJReader (the `l` polylines; ParaView's reader) and meshio
                       (the `v` records, as doubles)
  lines.ply            Open3D's read_line_set (the `edge` element)
  lines.polylines.txt  no packaged reader (CGAL's is C++ only): parsed by its grammar, one text
                       line per polyline, "N x1 y1 z1 ... xN yN zN"
  lines.csv            Python's csv module (RFC 4180 rows) and numpy.genfromtxt
  segmentation_*.ply   meshio (faces with red, green, blue and label) and Open3D
  segmentation_*.obj   meshio (`g` groups) and VTK (GroupIds)

and its counts, ids, labels, colours and coordinates are compared with expected.json.
Coordinates read as doubles must be equal bit for bit (the writer prints the shortest form that
reads back); VTK keeps points as 32-bit floats, so there they agree to float precision.

Run by ctest (integration.formats_readback) with Debian's interpreter: its modules live in
/usr/lib/python3/dist-packages, which another python3 on PATH does not read.
"""

import csv
import json
import os
import subprocess
import sys
import tempfile
import unittest

MISSING = []
try:
    import numpy as np
except ImportError:
    MISSING.append("python3-numpy")
try:
    import meshio
except ImportError:
    MISSING.append("python3-meshio")
try:
    import open3d
except ImportError:
    MISSING.append("python3-open3d")
try:
    import vtk
except ImportError:
    MISSING.append("python3-vtk9")

SAMPLES = None  # folder of the files and expected.json, written once in setUpModule
EXPECTED = None


def setUpModule():
    global SAMPLES, EXPECTED
    if MISSING:
        raise RuntimeError("missing Debian packages " + " ".join(MISSING) + " (scripts/setup.sh installs them)")
    program = os.environ.get("EXPORT_SAMPLE_TEST")
    if not program:
        raise RuntimeError("EXPORT_SAMPLE_TEST must name the export_formats_test executable")
    SAMPLES = tempfile.mkdtemp(prefix="featureline_formats_")
    run = subprocess.run([program, "--gtest_filter=ExportFormatsSample.*"], env={**os.environ, "FEATURELINE_EXPORT_SAMPLES": SAMPLES},
                         capture_output=True, text=True, timeout=120)
    if run.returncode != 0:
        raise RuntimeError("the sample writer failed:\n" + run.stdout + run.stderr)
    with open(os.path.join(SAMPLES, "expected.json")) as f:
        EXPECTED = json.load(f)


def tearDownModule():
    if SAMPLES:
        for name in os.listdir(SAMPLES):
            os.remove(os.path.join(SAMPLES, name))
        os.rmdir(SAMPLES)


def path(key):
    return os.path.join(SAMPLES, EXPECTED["files"][key])


def expected_lines():
    """[(closed, [[x, y, z], ...])] as the JSON answers carry them (refined.points)."""
    return [(line["closed"], line["refined"]["points"]) for line in EXPECTED["lines"]]


def vtk_points(data):
    return [list(data.GetPoint(i)) for i in range(data.GetNumberOfPoints())]


def vtk_cells(cells):
    out, ids = [], vtk.vtkIdList()
    cells.InitTraversal()
    while cells.GetNextCell(ids):
        out.append([ids.GetId(i) for i in range(ids.GetNumberOfIds())])
    return out


def assert_same(test, got, want, what):
    """Equal sequences; a failure names the first difference (unittest's diff of lists this long
    takes minutes)."""
    if got == want:
        return
    if len(got) != len(want):
        test.fail(f"{what}: {len(got)} items, expected {len(want)}")
    first = next(i for i, (g, w) in enumerate(zip(got, want)) if g != w)
    test.fail(f"{what}: item {first} is {got[first]!r}, expected {want[first]!r}")


class FloatClose:
    """Points compared to 32-bit float precision (VTK's point type)."""

    @staticmethod
    def assert_close(test, got, want):
        test.assertEqual(len(got), len(want))
        for g, w in zip(got, want):
            for a, b in zip(g, w):
                test.assertLessEqual(abs(a - b), 1e-6 * max(1.0, abs(b)), f"{g} vs {w}")


class LinesObj(unittest.TestCase):
    def test_vtk_reads_one_polyline_per_line(self):
        reader = vtk.vtkOBJReader()
        reader.SetFileName(path("lines.obj"))
        reader.Update()
        data = reader.GetOutput()
        lines = expected_lines()
        polylines = vtk_cells(data.GetLines())
        self.assertEqual(len(polylines), len(lines))
        self.assertEqual(data.GetNumberOfPolys(), 0)
        first = 0
        for (closed, points), ids in zip(lines, polylines):
            want = list(range(first, first + len(points))) + ([first] if closed else [])
            assert_same(self, ids, want, "polyline ids")  # a closed line ends on its first vertex
            first += len(points)
        FloatClose.assert_close(self, vtk_points(data), [p for _, points in lines for p in points])

    def test_meshio_reads_the_vertices_as_doubles(self):
        mesh = meshio.read(path("lines.obj"))
        assert_same(self, mesh.points.tolist(), [p for _, points in expected_lines() for p in points], "vertices")


class LinesPly(unittest.TestCase):
    def test_open3d_reads_the_edges_and_the_closing_edge(self):
        line_set = open3d.io.read_line_set(path("lines.ply"))
        lines = expected_lines()
        assert_same(self, np.asarray(line_set.points).tolist(), [p for _, points in lines for p in points], "vertices")
        want, first = [], 0
        for closed, points in lines:
            n = len(points)
            want += [[first + k, first + (k + 1) % n] for k in range(n if closed else n - 1)]
            first += n
        assert_same(self, np.asarray(line_set.lines).tolist(), want, "edges")


class LinesCgalPolylines(unittest.TestCase):
    def test_grammar_count_then_points_closed_repeats_first(self):
        with open(path("lines.polylines")) as f:
            text = f.read()
        self.assertTrue(text.endswith("\n"))
        rows = text.splitlines()
        lines = expected_lines()
        self.assertEqual(len(rows), len(lines))
        for row, (closed, points) in zip(rows, lines):
            tokens = row.split()
            n = int(tokens[0])
            self.assertEqual(len(tokens), 1 + 3 * n, "N then exactly N points")
            values = [float(t) for t in tokens[1:]]
            got = [values[3 * i:3 * i + 3] for i in range(n)]
            assert_same(self, got, points + ([points[0]] if closed else []), "points")


class LinesCsv(unittest.TestCase):
    def test_csv_rows_are_the_refined_points_with_faces_and_barycentrics(self):
        with open(path("lines.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        want = []
        for i, line in enumerate(EXPECTED["lines"]):
            refined = line["refined"]
            for k, (p, face, b) in enumerate(zip(refined["points"], refined["faces"], refined["barycentric"])):
                want.append([i, "true" if line["closed"] else "false", k] + p + [face] + b)
        got = [[int(r["line"]), r["closed"], int(r["point"]), float(r["x"]), float(r["y"]), float(r["z"]), int(r["face"]),
                float(r["b0"]), float(r["b1"]), float(r["b2"])] for r in rows]
        assert_same(self, got, want, "rows")
        table = np.genfromtxt(path("lines.csv"), delimiter=",", names=True, dtype=None, encoding="utf-8")
        self.assertEqual(len(table), len(want))
        self.assertEqual([float(x) for x in table["x"]], [row[3] for row in want])


class Segmentation(unittest.TestCase):
    def each_mode(self):
        self.assertEqual(sorted(EXPECTED["segmentations"]), ["remesh", "snap"])
        for mode, answer in sorted(EXPECTED["segmentations"].items()):
            yield mode, answer

    def check_parts(self, answer, labels):
        """Label set 0..K-1 and faces per label as the answer's segments say."""
        segments = answer["segments"]
        self.assertEqual(set(labels), set(range(len(segments))))
        counts = {s["label"]: 0 for s in segments}
        for label in labels:
            counts[label] += 1
        self.assertEqual(counts, {s["label"]: s["faces"] for s in segments})

    def test_ply_faces_colours_and_labels(self):
        for mode, answer in self.each_mode():
            with self.subTest(mode=mode):
                mesh = meshio.read(path(f"segmentation_{mode}.ply"))
                surface = answer["surface"]
                assert_same(self, mesh.points.tolist(), surface["vertices"], "vertices")
                self.assertEqual([block.type for block in mesh.cells], ["triangle"])
                assert_same(self, mesh.cells[0].data.tolist(), surface["faces"], "faces")
                labels = mesh.cell_data["label"][0].tolist()
                assert_same(self, labels, answer["labels"], "labels")
                self.check_parts(answer, labels)
                # The answer's palette (sRGB in [0, 1]) in 8 bits, one colour per part, all distinct.
                palette = {s["label"]: [round(c * 255) for c in s["color"]] for s in answer["segments"]}
                rgb = np.column_stack([mesh.cell_data[c][0] for c in ("red", "green", "blue")]).tolist()
                assert_same(self, rgb, [palette[label] for label in labels], "face colours")
                self.assertEqual(len({tuple(c) for c in palette.values()}), len(palette))

                triangles = open3d.io.read_triangle_mesh(path(f"segmentation_{mode}.ply"))
                assert_same(self, np.asarray(triangles.vertices).tolist(), surface["vertices"], "Open3D vertices")
                assert_same(self, np.asarray(triangles.triangles).tolist(), surface["faces"], "Open3D faces")

    def test_obj_groups_hold_each_part(self):
        for mode, answer in self.each_mode():
            with self.subTest(mode=mode):
                surface, labels = answer["surface"], answer["labels"]
                mesh = meshio.read(path(f"segmentation_{mode}.obj"))
                assert_same(self, mesh.points.tolist(), surface["vertices"], "vertices")
                # One group per part in label order, its faces in face order.
                groups = [int(ids[0]) for ids in mesh.cell_data["obj:group_ids"]]
                self.assertEqual(groups, list(range(len(answer["segments"]))))
                for label, block in zip(groups, mesh.cells):
                    want = [f for f, l in zip(surface["faces"], labels) if l == label]
                    assert_same(self, block.data.tolist(), want, f"faces of part {label}")

                reader = vtk.vtkOBJReader()
                reader.SetFileName(path(f"segmentation_{mode}.obj"))
                reader.Update()
                data = reader.GetOutput()
                self.assertEqual(data.GetNumberOfPolys(), len(labels))
                group_ids = data.GetCellData().GetArray("GroupIds")
                vtk_labels = [int(group_ids.GetTuple1(i)) for i in range(group_ids.GetNumberOfTuples())]
                self.check_parts(answer, vtk_labels)
                FloatClose.assert_close(self, vtk_points(data), surface["vertices"])


if __name__ == "__main__":
    unittest.main(verbosity=2)

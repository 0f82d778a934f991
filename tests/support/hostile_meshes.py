#!/usr/bin/env python3
"""Small files that expand into large meshes, for the memory tests (tests/integration/).

  hostile_meshes.py repeated-ply FACES OUT    one triangle repeated FACES times (binary PLY)
  hostile_meshes.py repeated-glb PRIMS OUT    one primitive of 10,000 copies of a triangle,
                                              repeated PRIMS times over one accessor
  hostile_meshes.py draco FACES POINTS OUT    a Draco 2.2 header declaring FACES and POINTS
                                              (sequential encoding), then junk
  hostile_meshes.py huge-off OUT              a triangle with a 1e300 coordinate
"""
import json
import struct
import sys


def repeated_ply(faces, out):
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
            "property float x\nproperty float y\nproperty float z\n"
            f"element face {faces}\nproperty list uchar int vertex_indices\nend_header\n")
    with open(out, "wb") as f:
        f.write(head.encode())
        f.write(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0))
        f.write(struct.pack("<B3i", 3, 0, 1, 2) * faces)


def repeated_glb(primitives, out):
    copies = 10_000
    positions = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    indices = struct.pack("<3I", 0, 1, 2) * copies
    binary = positions + indices
    gltf = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(positions)},
            {"buffer": 0, "byteOffset": len(positions), "byteLength": len(indices)},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5125, "count": 3 * copies, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}] * primitives}],
        "nodes": [{"mesh": 0}],
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    text = json.dumps(gltf).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(text) + 8 + len(binary)
    with open(out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(text), b"JSON") + text)
        f.write(struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def varint(value):
    out = bytearray()
    while True:
        byte = value & 0x7F
        value >>= 7
        out.append(byte | (0x80 if value else 0))
        if not value:
            return bytes(out)


def draco(faces, points, out):
    with open(out, "wb") as f:
        f.write(b"DRACO" + bytes([2, 2, 1, 0, 0, 0]) + varint(faces) + varint(points) + b"\1" * 64)


def huge_off(out):
    with open(out, "w") as f:
        f.write("OFF\n3 1 0\n1e300 0 0\n0 1 0\n0 0 1\n3 0 1 2\n")


if __name__ == "__main__":
    kind, args = sys.argv[1], sys.argv[2:]
    if kind == "repeated-ply":
        repeated_ply(int(args[0]), args[1])
    elif kind == "repeated-glb":
        repeated_glb(int(args[0]), args[1])
    elif kind == "draco":
        draco(int(args[0]), int(args[1]), args[2])
    elif kind == "huge-off":
        huge_off(args[0])
    else:
        sys.exit(__doc__)

#!/usr/bin/env python3
"""Writes the small binary fixtures of tests/data/formats (PLY/STL binary, GLB, glTF) and the
binary members of tests/data/malformed. Standard library only; run from anywhere:
    python3 tests/data/formats/make_formats.py
The text fixtures (OBJ, ASCII PLY/STL, OFF, JSON) are written by hand next to this script."""
import base64, json, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))
BAD = os.path.join(HERE, "..", "malformed")

CUBE_V = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
CUBE_Q = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
CUBE_T = [t for q in CUBE_Q for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_T = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]


def write(path, data):
    with open(path, "wb") as f:
        f.write(data)


def ply_binary(endian, name):
    e = "<" if endian == "little" else ">"
    head = ("ply\nformat binary_%s_endian 1.0\ncomment cube, quads\n"
            "element vertex 8\nproperty uchar flag\nproperty float x\nproperty double y\n"
            "property float z\nproperty short extra\n"
            "element face 6\nproperty list uint int vertex_indices\nproperty float quality\n"
            "end_header\n" % endian).encode()
    body = b"".join(struct.pack(e + "BfdfH", 7, x, y, z, 1) for x, y, z in CUBE_V)
    body += b"".join(struct.pack(e + "I4if", 4, *q, 0.5) for q in CUBE_Q)
    write(os.path.join(HERE, name), head + body)
    return head + body


def stl_binary(header):
    data = header.ljust(80, b" ")[:80] + struct.pack("<I", len(CUBE_T))
    for t in CUBE_T:
        data += struct.pack("<3f", 0, 0, 0)
        for i in t:
            data += struct.pack("<3f", *CUBE_V[i])
        data += b"\0\0"
    return data


def gltf_model(binary):
    """Two meshes: a tetrahedron (uint16 indices) under a translated parent with a scaled child,
    and a non-indexed tetrahedron on an unnamed node with a matrix."""
    pos = b"".join(struct.pack("<3f", *v) for v in TET_V)
    idx = b"".join(struct.pack("<3H", *t) for t in TET_T)
    idx += b"\0\0" * (len(idx) % 4 != 0)
    flat = b"".join(struct.pack("<3f", *TET_V[i]) for t in TET_T for i in t)
    blob = pos + idx + flat
    doc = {
        "asset": {"version": "2.0", "generator": "make_formats.py"},
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"name": "parent", "translation": [10, 0, 0], "children": [1]},
            {"name": "tet_child", "scale": [2, 2, 2], "mesh": 0},
            {"matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1], "mesh": 1},
        ],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]},
            {"primitives": [{"attributes": {"POSITION": 2}}]},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 12, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 1]},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
            {"buffer": 0, "byteOffset": len(pos), "byteLength": 24},
            {"buffer": 0, "byteOffset": len(pos) + len(idx), "byteLength": len(flat)},
        ],
        "buffers": [{"byteLength": len(blob)}],
    }
    if not binary:
        doc["buffers"][0]["uri"] = ("data:application/octet-stream;base64," +
                                    base64.b64encode(blob).decode())
        return json.dumps(doc, indent=1).encode()
    js = json.dumps(doc).encode()
    js += b" " * ((4 - len(js) % 4) % 4)
    blob += b"\0" * ((4 - len(blob) % 4) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    return (b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(js)) + b"JSON" + js +
            struct.pack("<I", len(blob)) + b"BIN\0" + blob)


def main():
    ply_binary("little", "cube_binary_le.ply")
    be = ply_binary("big", "cube_binary_be.ply")
    write(os.path.join(HERE, "cube_binary_solid_header.stl"),
          stl_binary(b"solid cube exported by a tool that writes binary STL"))
    glb = gltf_model(True)
    write(os.path.join(HERE, "two_nodes.glb"), glb)
    write(os.path.join(HERE, "two_nodes.gltf"), gltf_model(False))

    write(os.path.join(BAD, "glb_truncated.glb"), glb[:100])
    write(os.path.join(BAD, "glb_bad_version.glb"), glb[:4] + struct.pack("<I", 1) + glb[8:])
    write(os.path.join(BAD, "glb_chunk_overflow.glb"),
          glb[:12] + struct.pack("<I", 1 << 30) + glb[16:])
    write(os.path.join(BAD, "ply_binary_truncated.ply"), be[:len(be) - 30])
    write(os.path.join(BAD, "stl_binary_truncated.stl"), stl_binary(b"solid x")[:-7])
    write(os.path.join(BAD, "garbage.bin"), bytes((i * 73 + 11) % 256 for i in range(64)))
    write(os.path.join(BAD, "empty_file.txt"), b"")

    ext = json.loads(gltf_model(False))
    ext["buffers"][0]["uri"] = "cube.bin"
    write(os.path.join(BAD, "gltf_external_buffer.gltf"), json.dumps(ext).encode())
    lines = json.loads(gltf_model(False))
    lines["meshes"][1]["primitives"][0]["mode"] = 1
    write(os.path.join(BAD, "gltf_lines_primitive.gltf"), json.dumps(lines).encode())
    oob = json.loads(gltf_model(False))
    oob["accessors"][0]["count"] = 400
    write(os.path.join(BAD, "gltf_accessor_overflow.gltf"), json.dumps(oob).encode())


if __name__ == "__main__":
    main()

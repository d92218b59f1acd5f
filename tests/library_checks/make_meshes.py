"""Writes a scene JSON's triangles, repeated K times along x, as OBJ, OFF, binary PLY (double
coordinates) and binary STL: the large files the reader comparison times
(tests/library_checks/openmesh_io.cpp against gvd's readers).

    python3 tests/library_checks/make_meshes.py SCENE.json OUT_BASE K
"""
import json, struct, sys
d = json.load(open(sys.argv[1])); base = sys.argv[2]
V = []; F = []; groups = []
for o in d['objects']:
    off = len(V); V += o['vertices']; groups.append((o['label'], len(F)))
    F += [[a + off, b + off, c + off] for a, b, c in o['triangles']]
# repeat to make it large: k copies shifted along x
k = int(sys.argv[3]) if len(sys.argv) > 3 else 1
V2 = []; F2 = []
span = max(v[0] for v in V) - min(v[0] for v in V) + 1
for c in range(k):
    off = len(V2); V2 += [[v[0] + c * span, v[1], v[2]] for v in V]; F2 += [[a + off, b + off, cc + off] for a, b, cc in F]
V, F = V2, F2
with open(base + '.obj', 'w') as f:
    for v in V: f.write('v %.17g %.17g %.17g\n' % tuple(v))
    for t in F: f.write('f %d %d %d\n' % (t[0] + 1, t[1] + 1, t[2] + 1))
with open(base + '.off', 'w') as f:
    f.write('OFF\n%d %d 0\n' % (len(V), len(F)))
    for v in V: f.write('%.17g %.17g %.17g\n' % tuple(v))
    for t in F: f.write('3 %d %d %d\n' % tuple(t))
with open(base + '.ply', 'wb') as f:
    f.write(('ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty double x\nproperty double y\nproperty double z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n' % (len(V), len(F))).encode())
    for v in V: f.write(struct.pack('<3d', *v))
    for t in F: f.write(struct.pack('<B3i', 3, *t))
with open(base + '.stl', 'wb') as f:
    f.write(b'\0' * 80); f.write(struct.pack('<I', len(F)))
    for t in F:
        f.write(struct.pack('<3f', 0, 0, 0))
        for i in t: f.write(struct.pack('<3f', *V[i]))
        f.write(b'\0\0')
print(len(V), len(F))

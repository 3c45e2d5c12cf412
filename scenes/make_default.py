#!/usr/bin/env python3
"""Writes scenes/default.obj: the small scene embedded in cellbih.

An open room (floor, ceiling, three walls) holding a sphere, a torus, a box
and a column; 5,472 triangles in 9 groups (geometry ids). Deterministic:
run it again and the file is the same.  Usage: python3 make_default.py > default.obj
"""
import math

verts, groups = [], []


def v(p):
    verts.append(p)
    return len(verts)


def quad_grid(name, origin, du, dv, n):
    faces = []
    idx = [[v(tuple(origin[k] + du[k] * i / n + dv[k] * j / n for k in range(3)))
            for j in range(n + 1)] for i in range(n + 1)]
    for i in range(n):
        for j in range(n):
            a, b, c, d = idx[i][j], idx[i + 1][j], idx[i + 1][j + 1], idx[i][j + 1]
            faces += [(a, b, c), (a, c, d)]
    groups.append((name, faces))


def sphere(name, c, r, slices, stacks):
    faces = []
    ring = lambda j: [v((c[0] + r * math.sin(math.pi * j / stacks) * math.cos(2 * math.pi * i / slices),
                         c[1] + r * math.cos(math.pi * j / stacks),
                         c[2] + r * math.sin(math.pi * j / stacks) * math.sin(2 * math.pi * i / slices)))
                      for i in range(slices)]
    top, bottom = v((c[0], c[1] + r, c[2])), v((c[0], c[1] - r, c[2]))
    rings = [ring(j) for j in range(1, stacks)]
    for i in range(slices):
        i2 = (i + 1) % slices
        faces.append((top, rings[0][i2], rings[0][i]))
        for j in range(len(rings) - 1):
            a, b, cc, d = rings[j][i], rings[j][i2], rings[j + 1][i2], rings[j + 1][i]
            faces += [(a, b, cc), (a, cc, d)]
        faces.append((bottom, rings[-1][i], rings[-1][i2]))
    groups.append((name, faces))


def torus(name, c, R, r, major, minor):
    idx = [[v((c[0] + (R + r * math.cos(2 * math.pi * j / minor)) * math.cos(2 * math.pi * i / major),
               c[1] + r * math.sin(2 * math.pi * j / minor),
               c[2] + (R + r * math.cos(2 * math.pi * j / minor)) * math.sin(2 * math.pi * i / major)))
            for j in range(minor)] for i in range(major)]
    faces = []
    for i in range(major):
        for j in range(minor):
            a, b = idx[i][j], idx[(i + 1) % major][j]
            cc, d = idx[(i + 1) % major][(j + 1) % minor], idx[i][(j + 1) % minor]
            faces += [(a, b, cc), (a, cc, d)]
    groups.append((name, faces))


def column(name, c, profile, segments):
    rings = [[v((c[0] + r * math.cos(2 * math.pi * i / segments), c[1] + y,
                 c[2] + r * math.sin(2 * math.pi * i / segments))) for i in range(segments)]
             for r, y in profile]
    faces = []
    for k in range(len(rings) - 1):
        for i in range(segments):
            i2 = (i + 1) % segments
            faces += [(rings[k][i], rings[k + 1][i], rings[k + 1][i2]), (rings[k][i], rings[k + 1][i2], rings[k][i2])]
    for end, flip in ((0, True), (len(rings) - 1, False)):
        center = v((c[0], c[1] + profile[end][1], c[2]))
        for i in range(segments):
            a, b = rings[end][i], rings[end][(i + 1) % segments]
            faces.append((center, a, b) if flip else (center, b, a))
    groups.append((name, faces))


S = 10.0
quad_grid("floor", (0, 0, 0), (S, 0, 0), (0, 0, S), 8)
quad_grid("ceiling", (0, S, 0), (0, 0, S), (S, 0, 0), 8)
quad_grid("back_wall", (0, 0, 0), (0, S, 0), (S, 0, 0), 8)
quad_grid("left_wall", (0, 0, 0), (0, 0, S), (0, S, 0), 8)
quad_grid("right_wall", (S, 0, 0), (0, S, 0), (0, 0, S), 8)
sphere("sphere", (3.0, 2.0, 4.0), 2.0, 40, 24)
torus("torus", (7.0, 1.0, 6.5), 1.6, 0.6, 48, 20)
for name, lo, hi in [("box", (5.5, 0.0, 1.5), (8.5, 3.0, 3.5))]:
    n = 6
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    quad_grid(name, (x0, y0, z0), (x1 - x0, 0, 0), (0, y1 - y0, 0), n)
    faces = groups.pop()[1]
    for o, du, dv in [((x0, y0, z1), (0, y1 - y0, 0), (x1 - x0, 0, 0)), ((x0, y0, z0), (0, y1 - y0, 0), (0, 0, z1 - z0)),
                      ((x1, y0, z0), (0, 0, z1 - z0), (0, y1 - y0, 0)), ((x0, y0, z0), (0, 0, z1 - z0), (x1 - x0, 0, 0)),
                      ((x0, y1, z0), (x1 - x0, 0, 0), (0, 0, z1 - z0))]:
        quad_grid(name, o, du, dv, n)
        faces += groups.pop()[1]
    groups.append((name, faces))
column("column", (1.8, 0.0, 8.2), [(0.9, 0.0), (0.7, 0.4), (0.55, 0.8), (0.5, 2.5), (0.5, 4.5),
                                   (0.5, 6.5), (0.55, 7.2), (0.7, 7.6), (0.9, 8.0), (0.9, 8.3)], 32)

print("# cellbih default scene, written by scenes/make_default.py")
for p in verts:
    print("v %.6f %.6f %.6f" % p)
for name, faces in groups:
    print("g " + name)
    for f in faces:
        print("f %d %d %d" % f)

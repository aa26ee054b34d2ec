#!/usr/bin/env python3
"""Unseen-mesh sweep: copies of meshes the engine has never been tuned on, and a summary of a
batch over them.

  bench/variants.py make OUT MESH...     writes, per mesh (ASCII OFF or OBJ, 50-60k faces),
                                         MESH-jitter.off   vertices moved by a Gaussian of 0.12
                                                           mean edge lengths
                                         MESH-aniso.off    rotated, then scaled 1 : 2.5 : 0.6
                                         MESH-perm.off     vertices and faces shuffled, corners
                                                           rotated (the same surface relabelled)
                                         MESH-holes5.off   5 % of the faces deleted (hundreds of
                                                           holes, pinched vertices, islands)
                                         MESH-mirror.off   x negated and every face reversed
                                                           (the mirror image, still outward)
                                         MESH-far.off      scaled by 1e-3 and moved 1e4
                                                           diameters from the origin
                                         MESH-bighole.off  a ball of 3 % of the faces around
                                                           one face removed (one large hole)
                                         MESH-split.off    10 % of the faces split at their
                                                           centroid (valence 3, obtuse slivers)
                                         MESH-stretch10.off  the longest axis scaled by 10 (a
                                                           rod: needle triangles everywhere)
  bench/variants.py summary RESULTS      totals of `holoflow batch OUT -o RESULTS` (see
                                         bench/README, "Unseen meshes")

Deterministic: every copy is seeded by its mesh's name.
"""
import json
import math
import os
import random
import sys
import zlib


def read_mesh(path):
    """(vertices, faces) of an ASCII OFF or OBJ file; None for anything else."""
    vertices, faces = [], []
    if path.endswith('.off'):
        with open(path, errors='replace') as f:
            lines = [l.split('#')[0].split() for l in f]
        lines = [l for l in lines if l]
        if not lines or lines[0][0] != 'OFF':
            return None  # COFF, NOFF, binary: left out
        header = lines[0][1:] or lines[1]  # counts on the OFF line or the next
        body = lines[1:] if lines[0][1:] else lines[2:]
        nv, nf = int(header[0]), int(header[1])
        vertices = [[float(t) for t in line[:3]] for line in body[:nv]]
        for line in body[nv:nv + nf]:
            n = int(line[0])
            faces.append([int(t) for t in line[1:1 + n]])  # colour values after them are dropped
        return vertices, faces
    if path.endswith('.obj'):
        with open(path, errors='replace') as f:
            for line in f:
                fields = line.split()
                if not fields:
                    continue
                if fields[0] == 'v':
                    vertices.append([float(t) for t in fields[1:4]])
                elif fields[0] == 'f':
                    ids = [int(t.split('/')[0]) for t in fields[1:]]
                    faces.append([i - 1 if i > 0 else len(vertices) + i for i in ids])
        return vertices, faces
    return None


def write_off(path, vertices, faces):
    with open(path, 'w') as f:
        f.write('OFF\n%d %d 0\n' % (len(vertices), len(faces)))
        for v in vertices:
            f.write('%.17g %.17g %.17g\n' % tuple(v))
        for face in faces:
            f.write('%d %s\n' % (len(face), ' '.join(map(str, face))))


def mean_edge_length(vertices, faces):
    total, count = 0.0, 0
    for face in faces:
        for a, b in zip(face, face[1:] + face[:1]):
            total += math.dist(vertices[a], vertices[b])
            count += 1
    return total / max(count, 1)


def make(out, paths):
    os.makedirs(out, exist_ok=True)
    for path in paths:
        try:
            mesh = read_mesh(path)
        except (ValueError, IndexError) as e:
            print('skipped %s: %s' % (path, e))
            continue
        if mesh is None:
            print('skipped %s: not ASCII OFF or OBJ' % path)
            continue
        vertices, faces = mesh
        if not 50 <= len(faces) <= 60000:
            continue
        stem = os.path.splitext(os.path.basename(path))[0]
        rng = random.Random(zlib.crc32(stem.encode()))
        sigma = 0.12 * mean_edge_length(vertices, faces)
        write_off(os.path.join(out, stem + '-jitter.off'),
                  [[x + rng.gauss(0, sigma) for x in v] for v in vertices], faces)
        c, s = math.cos(0.7), math.sin(0.7)
        write_off(os.path.join(out, stem + '-aniso.off'),
                  [[c * x - s * y, 2.5 * (s * x + c * y), 0.6 * z] for x, y, z in vertices], faces)
        order = list(range(len(vertices)))
        rng.shuffle(order)
        new_id = {old: new for new, old in enumerate(order)}
        shuffled = [[new_id[i] for i in face] for face in faces]
        rng.shuffle(shuffled)
        rotated = []
        for face in shuffled:
            k = rng.randrange(len(face))
            rotated.append(face[k:] + face[:k])
        write_off(os.path.join(out, stem + '-perm.off'), [vertices[i] for i in order], rotated)
        write_off(os.path.join(out, stem + '-holes5.off'), vertices, [f for f in faces if rng.random() > 0.05])
        write_off(os.path.join(out, stem + '-mirror.off'), [[-x, y, z] for x, y, z in vertices],
                  [face[::-1] for face in faces])
        lo = [min(v[i] for v in vertices) for i in range(3)]
        hi = [max(v[i] for v in vertices) for i in range(3)]
        diameter = math.dist(lo, hi)
        write_off(os.path.join(out, stem + '-far.off'),
                  [[1e-3 * x + 1e4 * 1e-3 * diameter for x in v] for v in vertices], faces)
        axis = max(range(3), key=lambda i: hi[i] - lo[i])
        write_off(os.path.join(out, stem + '-stretch10.off'),
                  [[x * 10 if i == axis else x for i, x in enumerate(v)] for v in vertices], faces)
        write_off(os.path.join(out, stem + '-bighole.off'), vertices, without_ball(faces, rng, 0.03))
        split_vertices, split_faces = list(vertices), []
        for face in faces:
            if len(face) == 3 and rng.random() < 0.1:
                c = len(split_vertices)
                split_vertices.append([sum(vertices[i][k] for i in face) / 3 for k in range(3)])
                split_faces += [[face[0], face[1], c], [face[1], face[2], c], [face[2], face[0], c]]
            else:
                split_faces.append(face)
        write_off(os.path.join(out, stem + '-split.off'), split_vertices, split_faces)


def without_ball(faces, rng, fraction):
    """faces less a breadth-first ball (across shared vertices) of `fraction` of them."""
    at_vertex = {}
    for f, face in enumerate(faces):
        for v in face:
            at_vertex.setdefault(v, []).append(f)
    seed = rng.randrange(len(faces))
    removed, queue = {seed}, [seed]
    for f in queue:
        if len(removed) >= fraction * len(faces):
            break
        for v in faces[f]:
            for g in at_vertex[v]:
                if g not in removed:
                    removed.add(g)
                    queue.append(g)
    return [face for f, face in enumerate(faces) if f not in removed]


def summary(results):
    """Totals over a batch folder: failures, and per quality measure the models off target."""
    with open(os.path.join(results, 'summary.json')) as f:
        rows = json.load(f)
    failed = [(r['model'], r['error']['kind']) for r in rows if r['status'] != 'ok']
    totals = {'artifacts': 0, 'failed_fans': 0, 'failed_fan_weight': 0, 'flipped_uv_triangles': 0,
              'unfinished_trajectories': 0}
    off = {key: [] for key in totals}
    off['rectangle_error_max > 1e-3'] = []
    off['other_patches'] = []  # type other, and cylinders left in layout mode
    off['collapsed_area >= 0.01'] = []  # limbs whose uv is under 1e-6 of the mean scale
    off['filled_holes'] = []   # not a defect: how many models had holes filled
    for r in rows:
        if r['status'] != 'ok':
            continue
        with open(os.path.join(results, r['model'], 'segmentation.json')) as f:
            report = json.load(f)
        parts = report.get('components') or [report]
        values = {
            'artifacts': sum(p['artifacts'] for p in parts),
            'failed_fans': sum(p['zero_fans']['failed'] for p in parts),
            # what the fan refinements minimise (zeros' orders; absent before it was reported)
            'failed_fan_weight': sum(p['zero_fans'].get('failed_weight', 0) for p in parts),
            'flipped_uv_triangles': sum(p['flipped_uv_triangles'] for p in parts),
            'unfinished_trajectories': sum(p['unfinished_trajectories'] for p in parts),
        }
        for key, value in values.items():
            totals[key] += value
            if value:
                off[key].append((r['model'], value))
        rect = max(p['rectangle_error_max'] for p in parts)
        if rect > 1e-3:
            off['rectangle_error_max > 1e-3'].append((r['model'], round(rect, 3)))
        # Layout mode opens every cylinder: one left is a defect too.
        other = sum(p['patch_types'].get('other', 0) for p in parts)
        if report.get('mode') == 'layout':
            other += sum(p['patch_types'].get('cylinder', 0) for p in parts)
        if other:
            off['other_patches'].append((r['model'], other))
        collapsed = report.get('collapsed_area', 0)  # absent before it was reported
        if collapsed >= 0.01:
            off['collapsed_area >= 0.01'].append((r['model'], round(collapsed, 3)))
        filled = sum(p.get('filled_holes', {}).get('holes', 0) for p in parts)
        if filled:
            off['filled_holes'].append((r['model'], filled))
    print('%d models, %d ok, failed: %s' % (len(rows), len(rows) - len(failed), failed))
    for key, value in totals.items():
        print('%s: %d in all' % (key, value))
    for key, models in off.items():
        print('%s: %d models %s' % (key, len(models), sorted(models, key=lambda m: -m[1])[:12]))


if __name__ == '__main__':
    if len(sys.argv) >= 3 and sys.argv[1] == 'make':
        make(sys.argv[2], sys.argv[3:])
    elif len(sys.argv) == 3 and sys.argv[1] == 'summary':
        summary(sys.argv[2])
    else:
        sys.exit(__doc__)

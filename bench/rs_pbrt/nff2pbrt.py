#!/usr/bin/env python3
"""Writes an NFF scene (as SPD's programs write it) as a pbrt-v3 scene for rs_pbrt's Whitted
integrator, to race Strahl against it (`race.sh`). For timing only, not for pixels:

- materials are pbrt's `uber`: NFF's Kd times the colour as diffuse, Ks as glossy and mirror
  colour, T as transmission, the Phong exponent as roughness 1/shine;
- a cone (`c` with two radii) becomes a cylinder of their mean radius (pbrt-v3 has no
  truncated cone);
- NFF's point lights become pbrt point lights of one fixed intensity (pbrt's fall off with
  distance, NFF's do not), and the background colour is left out;
- polygons are fanned into triangles; a patch's normals (`pp`) are dropped.

Usage: nff2pbrt.py SCENE.nff OUT_STEM SIZE DEPTH  (writes OUT_STEM.pbrt, which renders to
OUT_STEM.png at SIZE x SIZE with ray depth DEPTH)."""
import math
import sys


def numbers(path):
    """The file's whitespace-separated words, in order (NFF's records span lines freely)."""
    with open(path) as f:
        for line in f:
            yield from line.split()


def read(path):
    """The camera, the lights and the shapes (with material switches) of an NFF file."""
    words = numbers(path)
    num = lambda: float(next(words))
    point = lambda: (num(), num(), num())
    camera, lights, shapes = {}, [], []
    for w in words:
        if w == 'v':
            continue
        if w in ('from', 'at', 'up'):
            camera[w] = point()
        elif w in ('angle', 'hither'):
            camera[w] = num()
        elif w == 'resolution':
            num(), num()
        elif w == 'b':
            point()
        elif w == 'l':
            lights.append(point())
        elif w == 'f':
            shapes.append(('material', tuple(num() for _ in range(8))))
        elif w == 's':
            shapes.append(('sphere', (point(), num())))
        elif w == 'c':
            base, rb, apex, ra = point(), num(), point(), num()
            shapes.append(('cylinder', (base, apex, (rb + ra) / 2)))
        elif w in ('p', 'pp'):
            corners = []
            for _ in range(int(next(words))):
                corners.append(point())
                if w == 'pp':
                    point()
            shapes.append(('polygon', corners))
        else:
            sys.exit(f'{path}: unknown NFF record {w!r}')
    return camera, lights, shapes


def material(r, g, b, kd, ks, shine, t, ior):
    return ('Material "uber" "rgb Kd" [%g %g %g] "rgb Ks" [%g %g %g] "rgb Kr" [%g %g %g] '
            '"rgb Kt" [%g %g %g] "float index" [%g] "float roughness" [%g]' % (
                r * kd, g * kd, b * kd, ks, ks, ks, ks, ks, ks, t, t, t,
                ior if ior > 0 else 1.0, 1.0 / max(shine, 1.0)))


def cylinder(base, apex, radius):
    """A pbrt cylinder from `base` to `apex`: pbrt's runs along z from 0 to its height."""
    axis = [apex[i] - base[i] for i in range(3)]
    height = math.sqrt(sum(c * c for c in axis))
    if height == 0:
        return []
    z = [c / height for c in axis]
    across = math.hypot(z[0], z[1])
    lines = ['AttributeBegin', 'Translate %g %g %g' % base]
    if across > 1e-9:
        # Turn z onto the axis about z × axis.
        lines.append('Rotate %g %g %g 0' % (math.degrees(math.atan2(across, z[2])), -z[1], z[0]))
    elif z[2] < 0:
        lines.append('Rotate 180 1 0 0')
    lines.append('Shape "cylinder" "float radius" [%g] "float zmin" [0] "float zmax" [%g]'
                 % (radius, height))
    lines.append('AttributeEnd')
    return lines


def write(camera, lights, shapes, stem, size, depth):
    out = [
        'Scale -1 1 1',  # pbrt's camera space is left-handed; this keeps the image unmirrored
        'LookAt %g %g %g  %g %g %g  %g %g %g' % (camera['from'] + camera['at'] + camera['up']),
        'Camera "perspective" "float fov" [%g]' % camera['angle'],
        'Film "image" "integer xresolution" [%d] "integer yresolution" [%d] '
        '"string filename" "%s.png"' % (size, size, stem),
        'Sampler "halton" "integer pixelsamples" [1]',
        'Integrator "whitted" "integer maxdepth" [%d]' % depth,
        'WorldBegin',
    ]
    out += ['LightSource "point" "rgb I" [1000 1000 1000] "point from" [%g %g %g]' % p
            for p in lights]
    corners, indices = [], []

    def flush():
        if indices:
            out.append('Shape "trianglemesh" "integer indices" [%s] "point P" [%s]' % (
                ' '.join(map(str, indices)), ' '.join('%g %g %g' % c for c in corners)))
            corners.clear()
            indices.clear()

    for kind, v in shapes:
        if kind == 'material':
            flush()
            out.append(material(*v))
        elif kind == 'sphere':
            out += ['AttributeBegin', 'Translate %g %g %g' % v[0],
                    'Shape "sphere" "float radius" [%g]' % v[1], 'AttributeEnd']
        elif kind == 'cylinder':
            out += cylinder(*v)
        else:
            first = len(corners)
            corners.extend(v)
            for k in range(1, len(v) - 1):
                indices.extend((first, first + k, first + k + 1))
    flush()
    out.append('WorldEnd')
    with open(stem + '.pbrt', 'w') as f:
        f.write('\n'.join(out) + '\n')


if __name__ == '__main__':
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    write(*read(sys.argv[1]), sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))

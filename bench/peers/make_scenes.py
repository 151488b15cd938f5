#!/usr/bin/python3
"""Writes the peer-comparison scenes twice, as Nori XML for Alphorn and as pbrt-v3 scene files,
with the same triangles, materials, light, camera and filter, so the two renderers compute the
same image.

    make_scenes.py OUT_DIR [--size N]

Scenes (each a Cornell box, x and z in [-1, 1], y in [0, 2], a diffuse sphere back left, a glass
sphere front right, a 0.5 x 0.5 one-sided quad light under the ceiling, box pixel filter):
  box          plain, for path tracing
  box_photons  the same box with Alphorn's progressive photon mapper (pbrt renders box with SPPM)
  fog          the same box filled with homogeneous fog, camera inside it

Every surface is written as explicit world-space triangles (the spheres are the repository's
scenes/meshes/sphere.obj, scaled and moved here), so neither renderer uses an analytic shape the
other lacks. The integrator and sampler are chosen when rendering: Alphorn's by `-D` values
($integrator, $sampler; $photons, $radius for box_photons), pbrt's by the header compare.py puts
before each scene body (pbrt-v3 wants them before WorldBegin).
"""
import argparse
import os

HERE = os.path.dirname(os.path.abspath(__file__))
SPHERE_OBJ = os.path.join(HERE, "..", "..", "scenes", "meshes", "sphere.obj")

WHITE = (0.725, 0.71, 0.68)
RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
LIGHT_RADIANCE = (17.0, 12.0, 4.0)
GLASS_IOR = 1.5
FOG_SIGMA_S, FOG_SIGMA_A, FOG_G = 0.25, 0.02, 0.3


def quad(corner, edge_u, edge_v, normal):
    """Two triangles of the parallelogram corner + s edge_u + t edge_v, all normals `normal`."""
    p = [corner,
         tuple(c + a for c, a in zip(corner, edge_u)),
         tuple(c + a + b for c, a, b in zip(corner, edge_u, edge_v)),
         tuple(c + b for c, b in zip(corner, edge_v))]
    return {"P": p, "N": [normal] * 4, "faces": [(0, 1, 2), (0, 2, 3)]}


def sphere(center, radius):
    """sphere.obj (unit sphere with per-vertex normals), scaled and moved; vertices deduplicated
    by (position, normal) index pairs."""
    positions, normals, faces, index = [], [], [], {}
    obj_v, obj_n = [], []
    with open(SPHERE_OBJ) as f:
        for line in f:
            parts = line.split()
            if not parts:
                continue
            if parts[0] == "v":
                obj_v.append(tuple(float(x) for x in parts[1:4]))
            elif parts[0] == "vn":
                obj_n.append(tuple(float(x) for x in parts[1:4]))
            elif parts[0] == "f":
                tri = []
                for corner in parts[1:4]:
                    fields = corner.split("/")
                    key = (int(fields[0]) - 1, int(fields[2]) - 1)
                    if key not in index:
                        index[key] = len(positions)
                        v, n = obj_v[key[0]], obj_n[key[1]]
                        positions.append(tuple(c + radius * x for c, x in zip(center, v)))
                        normals.append(n)
                    tri.append(index[key])
                faces.append(tuple(tri))
    return {"P": positions, "N": normals, "faces": faces}


def box_shapes():
    """(name, mesh, material) of every surface; material is ("diffuse", rgb), ("glass",),
    or ("light", radiance)."""
    return [
        ("floor", quad((-1, 0, -1), (0, 0, 2), (2, 0, 0), (0, 1, 0)), ("diffuse", WHITE)),
        ("ceiling", quad((-1, 2, -1), (2, 0, 0), (0, 0, 2), (0, -1, 0)), ("diffuse", WHITE)),
        ("back", quad((-1, 0, -1), (2, 0, 0), (0, 2, 0), (0, 0, 1)), ("diffuse", WHITE)),
        ("left", quad((-1, 0, -1), (0, 2, 0), (0, 0, 2), (1, 0, 0)), ("diffuse", RED)),
        ("right", quad((1, 0, -1), (0, 0, 2), (0, 2, 0), (-1, 0, 0)), ("diffuse", GREEN)),
        ("light", quad((-0.25, 1.98, -0.25), (0.5, 0, 0), (0, 0, 0.5), (0, -1, 0)),
         ("light", LIGHT_RADIANCE)),
        ("diffuse_sphere", sphere((-0.42, 0.33, -0.35), 0.33), ("diffuse", WHITE)),
        ("glass_sphere", sphere((0.42, 0.33, 0.3), 0.33), ("glass",)),
    ]


def fmt(values):
    return ", ".join("%g" % v for v in values)


def pbrt_fmt(values):
    return " ".join("%g" % v for v in values)


def write_obj(path, mesh):
    with open(path, "w") as f:
        f.write("# written by bench/peers/make_scenes.py\n")
        for p in mesh["P"]:
            f.write("v %.9g %.9g %.9g\n" % p)
        for n in mesh["N"]:
            f.write("vn %.9g %.9g %.9g\n" % n)
        for a, b, c in mesh["faces"]:
            f.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))


# The progressive photon mapper as pbrt's SPPM runs: one photon pass per pass, radius shrinking
# with alpha 2/3 (SPPM's gamma), direct light by next-event estimation at the visible point.
PHOTON_INTEGRATOR = """  <integrator type="photonmapper">
    <boolean name="progressive" value="true"/>
    <float name="alpha" value="0.666667"/>
    <integer name="photonCount" value="$photons"/>
    <float name="surfacePhotonRadius" value="$radius"/>
  </integrator>"""


def write_alphorn(out, name, size, fog, integrator='  <integrator type="$integrator"/>'):
    lines = ['<?xml version="1.0" encoding="utf-8"?>',
             "<!-- written by bench/peers/make_scenes.py; $names are set by -D -->",
             "<scene>", integrator,
             '  <sampler type="$sampler"><integer name="sampleCount" value="1"/></sampler>',
             '  <camera type="perspective">',
             '    <transform name="toWorld"><lookat origin="0, 1, 3.9" target="0, 1, 0" up="0, 1, 0"/></transform>',
             '    <float name="fov" value="38"/>',
             '    <integer name="width" value="%d"/><integer name="height" value="%d"/>' % (size, size),
             '    <rfilter type="box"/>']
    if fog:
        lines += ['    <medium type="homogeneous">',
                  '      <color name="sigmaS" value="%g"/>' % FOG_SIGMA_S,
                  '      <color name="sigmaA" value="%g"/>' % FOG_SIGMA_A,
                  '      <phase type="hg"><float name="g" value="%g"/></phase>' % FOG_G,
                  "    </medium>"]
    lines.append("  </camera>")
    for shape, mesh, material in box_shapes():
        obj = "meshes/%s.obj" % shape
        write_obj(os.path.join(out, obj), mesh)
        lines.append('  <mesh type="obj"><string name="filename" value="%s"/>' % obj)
        if material[0] == "diffuse":
            lines.append('    <bsdf type="diffuse"><color name="albedo" value="%s"/></bsdf>'
                         % fmt(material[1]))
        elif material[0] == "glass":
            lines.append('    <bsdf type="dielectric"><float name="intIOR" value="%g"/>'
                         '<float name="extIOR" value="1"/></bsdf>' % GLASS_IOR)
        else:
            lines.append('    <bsdf type="diffuse"><color name="albedo" value="0"/></bsdf>')
            lines.append('    <emitter type="area"><color name="radiance" value="%s"/></emitter>'
                         % fmt(material[1]))
        lines.append("  </mesh>")
    lines.append("</scene>")
    with open(os.path.join(out, name + ".xml"), "w") as f:
        f.write("\n".join(lines) + "\n")


def write_pbrt(out, name, fog):
    """The scene without its integrator, sampler and film: compare.py prepends a header choosing
    them (pbrt-v3 wants them before WorldBegin)."""
    lines = ["# written by bench/peers/make_scenes.py",
             # Nori and Mitsuba look down the camera's +z with +x to the left of the image; pbrt's
             # +x is to the right: mirror x so both show the red wall on the left.
             "Scale -1 1 1",
             "LookAt 0 1 3.9  0 1 0  0 1 0"]
    if fog:
        # The camera's medium is the one named when the camera is declared.
        lines += ['MakeNamedMedium "fog" "string type" "homogeneous" "rgb sigma_a" [%s] '
                  '"rgb sigma_s" [%s] "float scale" [1] "float g" [%g]'
                  % (pbrt_fmt([FOG_SIGMA_A] * 3), pbrt_fmt([FOG_SIGMA_S] * 3), FOG_G),
                  'MediumInterface "fog" "fog"']
    lines += ['Camera "perspective" "float fov" [38]',
              'PixelFilter "box" "float xwidth" [0.5] "float ywidth" [0.5]',
              "WorldBegin"]
    if fog:
        lines.append('MediumInterface "fog" "fog"')
    for shape, mesh, material in box_shapes():
        lines.append("AttributeBegin  # " + shape)
        if material[0] == "diffuse":
            lines.append('Material "matte" "rgb Kd" [%s] "float sigma" [0]' % pbrt_fmt(material[1]))
        elif material[0] == "glass":
            lines.append('Material "glass" "float index" [%g]' % GLASS_IOR)
        else:
            lines.append('Material "matte" "rgb Kd" [0 0 0]')
            lines.append('AreaLightSource "diffuse" "rgb L" [%s]' % pbrt_fmt(material[1]))
        points = " ".join("%.9g %.9g %.9g" % p for p in mesh["P"])
        normals = " ".join("%.9g %.9g %.9g" % n for n in mesh["N"])
        indices = " ".join("%d %d %d" % f for f in mesh["faces"])
        lines.append('Shape "trianglemesh" "integer indices" [%s] "point P" [%s] "normal N" [%s]'
                     % (indices, points, normals))
        lines.append("AttributeEnd")
    lines.append("WorldEnd")
    with open(os.path.join(out, name + ".pbrt-body"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", help="output folder")
    parser.add_argument("--size", type=int, default=256, help="image width and height, pixels")
    args = parser.parse_args()
    os.makedirs(os.path.join(args.out, "meshes"), exist_ok=True)
    for name, fog in (("box", False), ("fog", True)):
        write_alphorn(args.out, name, args.size, fog)
        write_pbrt(args.out, name, fog)
    write_alphorn(args.out, "box_photons", args.size, False, PHOTON_INTEGRATOR)
    print("scenes written to", args.out)


if __name__ == "__main__":
    main()

"""Blender-written subdivision surfaces for the fit's rules (issue 34).

Runs inside Blender 5.0.1's Python module (`pip install bpy==5.0.1`, Python 3.11):

    python make_rules_set.py OUT_DIR

and writes, with Blender's own OBJ and PLY exporters at their defaults, one file per
rule the subdivision fit must know: semi-sharp edge creases, vertex creases, the
boundary options, the end caps' quality, the limit surface off, triangle and n-gon
control meshes, and UV smoothing options; creases also over two levels, fewer than
the Quality's. Nothing is displaced: every position is
Blender's evaluation of its Subdivision Surface modifier. The files are made at run
time and never committed (the project ships no Blender output); `rules_set.sh` codes
them. Blender is deterministic here: two runs give the same bytes.
"""
import math
import sys

import bpy

# `--quality N` sets every modifier's quality (OpenSubdiv's isolation level) that the
# recipe leaves at Blender's default, 3: at 6 or more every written vertex of four
# levels is an exact limit point, with no end-cap patch between.
QUALITY = int(sys.argv[sys.argv.index("--quality") + 1]) if "--quality" in sys.argv else None


def fresh():
    bpy.ops.wm.read_factory_settings(use_empty=True)


def crease_edges(me, pick, value):
    attr = me.attributes.get("crease_edge") or me.attributes.new("crease_edge", "FLOAT", "EDGE")
    for e in me.edges:
        a, b = (me.vertices[i].co for i in e.vertices)
        if pick(a, b):
            attr.data[e.index].value = value


def crease_vertices(me, pick, value):
    attr = me.attributes.get("crease_vert") or me.attributes.new("crease_vert", "FLOAT", "POINT")
    for v in me.vertices:
        if pick(v.co):
            attr.data[v.index].value = value


# `--control` also writes NAME.control.txt beside each OBJ: its control mesh in the
# OBJ's frame and its creases (examples/rules_probe.rs reads it).
CONTROL = "--control" in sys.argv
LAST_CONTROL = []


def note_control(ob):
    """The control mesh of `ob` before its modifier, in the OBJ exporter's frame
    (file x, y, z = Blender x, z, -y), with its edge and vertex creases."""
    me = ob.data
    w = ob.matrix_world
    lines = []
    for v in me.vertices:
        p = w @ v.co
        lines.append(f"v {p.x:.9f} {p.z:.9f} {-p.y:.9f}")
    ec = me.attributes.get("crease_edge")
    if ec is not None:
        for e in me.edges:
            if ec.data[e.index].value > 0:
                lines.append(f"e {e.vertices[0]} {e.vertices[1]} {ec.data[e.index].value:.9f}")
    vc = me.attributes.get("crease_vert")
    if vc is not None:
        for v in me.vertices:
            if vc.data[v.index].value > 0:
                lines.append(f"c {v.index} {vc.data[v.index].value:.9f}")
    LAST_CONTROL[:] = lines


def subdivide(ob, levels, **options):
    bpy.context.view_layer.objects.active = ob
    note_control(ob)
    m = ob.modifiers.new("Subdivision", "SUBSURF")
    m.levels = levels
    m.render_levels = levels
    if QUALITY is not None and "quality" not in options:
        m.quality = QUALITY
    for key, value in options.items():
        setattr(m, key, value)
    bpy.ops.object.modifier_apply(modifier=m.name)


def export(out, name, ply=False):
    if ply:
        bpy.ops.wm.ply_export(filepath=f"{out}/{name}.ply")
    else:
        bpy.ops.wm.obj_export(filepath=f"{out}/{name}.obj")
        if CONTROL:
            with open(f"{out}/{name}.control.txt", "w") as f:
                f.write("\n".join(LAST_CONTROL) + "\n")


def rim(a, b):
    return abs(a.z - b.z) < 1e-6


def cylinder(crease, levels=4):
    bpy.ops.mesh.primitive_cylinder_add(vertices=8, radius=0.6, depth=1.6, end_fill_type="NGON")
    ob = bpy.context.active_object
    if crease is not None:
        crease_edges(ob.data, rim, crease)
    bpy.ops.object.shade_smooth()
    return ob


def mixed_cube(out, levels):
    """A cube with its top edges creased at 0.6 and two bottom corners at 0.9."""
    fresh()
    bpy.ops.mesh.primitive_cube_add(size=1.4)
    ob = bpy.context.active_object
    crease_edges(ob.data, lambda a, b: a.z > 0 and b.z > 0, 0.6)
    crease_vertices(ob.data, lambda co: co.z < 0 and co.x < 0, 0.9)
    bpy.ops.object.shade_smooth()
    subdivide(ob, levels)
    export(out, f"cube_mixed_creases_cc{levels}")


def main(out):
    # Semi-sharp edge creases (OpenSubdiv's sharpness is Blender's 10 c^2 here).
    for crease in (0.3, 0.5, 0.7):
        fresh()
        ob = cylinder(crease)
        subdivide(ob, 4)
        export(out, f"cylinder8_crease{int(crease * 10):02d}_cc4")
    # The same over Blender's default render levels (2), below its default Quality
    # (3): OpenSubdiv evaluates the limit one level further, where the sharpness left
    # is smooth. Creased rims, and a cube with edge and vertex creases.
    for crease in (0.5, 0.7):
        fresh()
        ob = cylinder(crease)
        subdivide(ob, 2)
        export(out, f"cylinder8_crease{int(crease * 10):02d}_cc2")
    mixed_cube(out, 2)
    # Vertex creases: a cube's eight corners, and one corner of a box sharp.
    for crease in (0.5, 1.0):
        fresh()
        bpy.ops.mesh.primitive_cube_add(size=1.4)
        ob = bpy.context.active_object
        crease_vertices(ob.data, lambda co: True, crease)
        bpy.ops.object.shade_smooth()
        subdivide(ob, 4)
        export(out, f"cube_vcrease{int(crease * 10):02d}_cc4")
    # Edge and vertex creases together, mixed sharpness on one mesh.
    mixed_cube(out, 4)
    # Open boundaries: the boundary option, a grid of 4 x 4 quads, bent.
    for smooth in ("PRESERVE_CORNERS", "ALL"):
        fresh()
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=2)
        ob = bpy.context.active_object
        for v in ob.data.vertices:
            v.co.z = 0.3 * math.sin(2.0 * v.co.x) * math.cos(1.5 * v.co.y)
        bpy.ops.object.shade_smooth()
        subdivide(ob, 4, boundary_smooth=smooth)
        export(out, f"sheet_boundary_{smooth.lower()}_cc4")
    # The end caps' quality and the limit surface off.
    for quality, limit in ((1, True), (6, True), (3, False)):
        fresh()
        ob = cylinder(None)
        subdivide(ob, 4, quality=quality, use_limit_surface=limit)
        export(out, f"cylinder8_quality{quality}{'' if limit else '_nolimit'}_cc4")
    # Triangle and n-gon control meshes.
    fresh()
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=1, radius=1)
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    subdivide(ob, 4)
    export(out, "icosahedron_smooth_cc4")
    fresh()
    bpy.ops.mesh.primitive_cone_add(vertices=12, radius1=1, radius2=0.3, depth=1.5, end_fill_type="NGON")
    ob = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    subdivide(ob, 4)
    export(out, "cone12_ngon_cc4")
    # Blender's "Simple" subdivision (bilinear: positions and UVs linear in each face).
    fresh()
    bpy.ops.mesh.primitive_monkey_add(size=2)
    ob = bpy.context.active_object
    subdivide(ob, 3, subdivision_type="SIMPLE")
    export(out, "suzanne_simple_cc3")
    # Suzanne: quads and triangles, open at the eyes' sockets, with UVs; every UV
    # smoothing option Blender has, and a binary PLY (cut at the UV seams).
    for uv in (
        "PRESERVE_BOUNDARIES",
        "SMOOTH_ALL",
        "NONE",
        "PRESERVE_CORNERS",
        "PRESERVE_CORNERS_AND_JUNCTIONS",
        "PRESERVE_CORNERS_JUNCTIONS_AND_CONCAVE",
    ):
        fresh()
        bpy.ops.mesh.primitive_monkey_add(size=2)
        ob = bpy.context.active_object
        bpy.ops.object.editmode_toggle()
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=0.01)
        bpy.ops.object.editmode_toggle()
        bpy.ops.object.shade_smooth()
        subdivide(ob, 3, uv_smooth=uv)
        export(out, f"suzanne_uv_{uv.lower()}_cc3")
        if uv == "PRESERVE_BOUNDARIES":
            export(out, "suzanne_cc3", ply=True)


if __name__ == "__main__":
    main(sys.argv[-1])

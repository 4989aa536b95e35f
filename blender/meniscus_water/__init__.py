"""Meniscus Water — a Blender add-on that turns an SPH particle sequence into a liquid surface, one mesh per frame.

Pick a particle sequence (any format Meniscus reads: BGEO, VTK, VTU/VTP, PLY, XYZ, CSV, RealFlow; a file of it,
a pattern with {}, a folder or a .pvd) in the 3D view's sidebar (N → Meniscus), press "Import". The add-on
builds the iso-surface mesh of the current frame with the `meniscus` package (`reconstruct_surface`: marching
cubes on the GPU through Vulkan, or on the CPU), on every frame change, keeping the last few frames in a cache.
Each mesh carries the SPH-interpolated particle velocity as the point attribute `velocity` (Cycles' motion
blur reads it), a water material (glass-like Principled BSDF: transmission 1, IOR 1.33), and optionally the
diffuse particles of `meniscus diffuse --export` files as a point cloud. "Bake" writes a frame range as one USD
stage (time-sampled mesh with velocities) or as a sequence of OpenVDB level sets.

Blender frame N shows the particle file numbered N. The particle radius and frame rate come from the files as
`meniscus mesh` takes them (a SPlisHSPlasH scene.json beside them, else the radius is estimated), unless set.
Meshing runs on the GPU when Vulkan offers one, else on the CPU's cores; the panel says which and why.
Installed as a Blender extension (`tools/blender-extension` builds the zip, which carries the `meniscus` wheel:
Edit → Preferences → Get Extensions → Install from Disk), Blender installs the package itself.
"""

bl_info = {
    "name": "Meniscus Water",
    "author": "Meniscus",
    "version": (0, 1, 0),
    "blender": (4, 2, 0),
    "location": "View3D > Sidebar > Meniscus",
    "description": "SPH particle sequences as a liquid surface mesh per frame (GPU or CPU), USD and VDB bakes",
    "category": "Import-Export",
}

import collections
import os
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

OBJECT = "Meniscus Water"
DIFFUSE = "Meniscus Diffuse"


def _meniscus():
    try:
        import meniscus
    except ImportError as e:  # a clear message in the UI instead of a traceback
        raise RuntimeError("the `meniscus` Python package is not installed in Blender's Python "
                           f"(pip install the meniscus wheel; README): {e}") from e
    return meniscus


class _State:
    """What the add-on knows of the imported sequence (not saved with the .blend: rebuilt by Import)."""

    def __init__(self):
        self.frames = {}
        self.radius = None
        self.cache = collections.OrderedDict()
        self.key = None
        self.last_seconds = 0.0
        self.device = None  # (use the GPU, what the panel says), probed once


STATE = _State()


class MeniscusWaterSettings(bpy.types.PropertyGroup):
    source: bpy.props.StringProperty(
        name="Particles", subtype="FILE_PATH",
        description="A particle file of the sequence, a pattern with {} for the frame number, a folder or a .pvd")
    radius: bpy.props.FloatProperty(
        name="Radius", default=0.0, min=0.0, precision=4,
        description="Particle radius (0: from a scene.json beside the files, else estimated, as the CLI does)")
    cube_size: bpy.props.FloatProperty(
        name="Cube size", default=0.5, min=0.1, max=8.0, description="Marching-cubes edge in particle radii")
    support: bpy.props.FloatProperty(
        name="Kernel support", default=4.0, min=1.0, max=16.0,
        description="Kernel support in particle radii (as [iso] support; splashsurf's 2 × smoothing length)")
    threshold: bpy.props.FloatProperty(name="Iso value", default=0.6, min=0.01, max=0.99)
    use_gpu: bpy.props.BoolProperty(
        name="GPU", default=True,
        description="Extract on the GPU (Vulkan) when there is one (the panel says); off: on the CPU (all cores)")
    cache_frames: bpy.props.IntProperty(name="Cache", default=4, min=0, max=64, description="Meshes kept in memory")
    material: bpy.props.BoolProperty(name="Water material", default=True)
    diffuse: bpy.props.StringProperty(
        name="Diffuse", subtype="FILE_PATH",
        description="Optional: diffuse particles of `meniscus diffuse --export`, a pattern with {} (shown as points)")
    bake_format: bpy.props.EnumProperty(
        name="Bake to", items=[("USD", "USD stage", "One .usda with every frame as a time sample"),
                               ("VDB", "OpenVDB", "One level set .vdb per frame")], default="USD")
    bake_path: bpy.props.StringProperty(name="Bake path", subtype="FILE_PATH", default="//water.usd")


def meshing_device(s):
    """Where meshing runs: (on the GPU, the panel's line). The Vulkan device is probed once: a GPU meshes there; no
    device, or only a CPU driver (lavapipe, whose GPU path is an emulation slower than the CPU mesher), meshes on
    the CPU's cores."""
    if not s.use_gpu:
        return False, "CPU (GPU off)"
    if STATE.device is None:
        m = _meniscus()
        try:
            info = m.device_info()
        except Exception as e:  # no Vulkan loader or device: the CPU path needs neither
            STATE.device = (False, f"CPU: no Vulkan device ({e})")
        else:
            if info.get("device_type") == "CPU":
                STATE.device = (False, f"CPU: the only Vulkan device is {info['name']}, a CPU driver")
            else:
                STATE.device = (True, f"GPU: {info['name']}")
    return STATE.device


def _settings(scene):
    return scene.meniscus_water


def _key(s):
    return (s.source, s.radius, s.cube_size, s.support, s.threshold, s.use_gpu)


def load_sequence(s):
    """Resolve the sequence and its radius (as the CLI does)."""
    m = _meniscus()
    src = bpy.path.abspath(s.source)
    if not src:
        raise RuntimeError("pick a particle file or pattern first")
    seq = m.sequence(src)
    STATE.frames = dict(seq["frames"])
    STATE.radius = s.radius if s.radius > 0 else seq["radius"]
    if not STATE.radius:
        raise RuntimeError(f"{src}: cannot estimate the particle radius; set Radius")
    STATE.cache.clear()
    STATE.key = _key(s)
    return seq


def surface(s, number):
    """The mesh of frame `number`: (vertices, triangles, normals, velocities, edges), cached."""
    if STATE.key != _key(s):
        load_sequence(s)
    if number in STATE.cache:
        STATE.cache.move_to_end(number)
        return STATE.cache[number]
    m = _meniscus()
    t0 = time.perf_counter()
    data = m.load(STATE.frames[number])
    pos = data["positions"]
    vel = data.get("velocity", data.get("velocities", data.get("v")))
    if pos.shape[0] == 0:
        mesh = (np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint32), np.zeros((0, 3), np.float32),
                np.zeros((0, 3), np.float32), None)
    else:
        if vel is None or getattr(vel, "shape", None) != pos.shape:
            vel = np.zeros_like(pos)
        mesh = m.reconstruct_surface(pos, particle_radius=STATE.radius, support=s.support,
                                     cube_size=s.cube_size, iso_surface_threshold=s.threshold,
                                     gpu=meshing_device(s)[0],
                                     velocities=vel)
        mesh = (*mesh, m.mesh_edges(mesh[1]))
    STATE.last_seconds = time.perf_counter() - t0
    if s.cache_frames > 0:
        STATE.cache[number] = mesh
        while len(STATE.cache) > s.cache_frames:
            STATE.cache.popitem(last=False)
    return mesh


def fill_mesh(me, vertices, triangles, normals, velocities, edges=None):
    """Replace `me`'s geometry by the triangle mesh, with the field's normals as its custom normals and the
    `velocity` point attribute. Written through the mesh's attributes (`.corner_vert`, `custom_normal`): the
    per-loop properties and `normals_split_custom_set_from_vertices` cost 1 s more on a 720k-vertex frame. With
    `edges` ((E×2 vertex pairs, one edge per corner), as `reconstruct_surface(..., edges=True)` gives them) the
    edges are set directly instead of Blender deriving them (0.28 s on that frame)."""
    me.clear_geometry()
    n, t = len(vertices), len(triangles)
    me.vertices.add(n)
    me.vertices.foreach_set("co", np.ascontiguousarray(vertices, np.float32).ravel())
    if edges is not None and t:
        edge_verts, corner_edge = edges
        me.edges.add(len(edge_verts))
        me.attributes[".edge_verts"].data.foreach_set("value", np.ascontiguousarray(edge_verts, np.int32).ravel())
    me.loops.add(3 * t)
    me.attributes[".corner_vert"].data.foreach_set("value", np.ascontiguousarray(triangles, np.int32).ravel())
    if edges is not None and t:
        me.attributes[".corner_edge"].data.foreach_set("value", np.ascontiguousarray(corner_edge, np.int32).ravel())
    me.polygons.add(t)
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * t, 3, dtype=np.int32))
    me.update(calc_edges=edges is None)
    for name, values in (("custom_normal", normals), ("velocity", velocities)):
        attr = me.attributes.get(name) or me.attributes.new(name, "FLOAT_VECTOR", "POINT")
        if n:
            attr.data.foreach_set("vector", np.ascontiguousarray(values, np.float32).ravel())


def water_material():
    mat = bpy.data.materials.get("Meniscus Water") or bpy.data.materials.new("Meniscus Water")
    if mat.node_tree is None:  # Blender < 5 makes materials without nodes
        mat.use_nodes = True
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.8, 0.93, 1.0, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.02
    bsdf.inputs["IOR"].default_value = 1.33
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    return mat


def _points_group():
    ng = bpy.data.node_groups.get("Meniscus Points")
    if ng:
        return ng
    ng = bpy.data.node_groups.new("Meniscus Points", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    gi, go = ng.nodes.new("NodeGroupInput"), ng.nodes.new("NodeGroupOutput")
    to_points = ng.nodes.new("GeometryNodeMeshToPoints")
    radius = ng.nodes.new("GeometryNodeInputNamedAttribute")
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "radius"
    ng.links.new(gi.outputs[0], to_points.inputs["Mesh"])
    ng.links.new(radius.outputs["Attribute"], to_points.inputs["Radius"])
    ng.links.new(to_points.outputs[0], go.inputs[0])
    return ng


def update_diffuse(scene, number):
    s = _settings(scene)
    pattern = bpy.path.abspath(s.diffuse) if s.diffuse else ""
    obj = bpy.data.objects.get(DIFFUSE)
    if not pattern:
        return
    if obj is None:
        me = bpy.data.meshes.new(DIFFUSE)
        obj = bpy.data.objects.new(DIFFUSE, me)
        obj.rotation_euler = (np.pi / 2, 0.0, 0.0)
        scene.collection.objects.link(obj)
        mod = obj.modifiers.new("points", "NODES")
        mod.node_group = _points_group()
    me = obj.data
    me.clear_geometry()
    path = pattern.replace("{}", f"{number:04d}")
    if not os.path.isfile(path):
        return
    d = _meniscus().load(path)
    pos = d["positions"]
    me.vertices.add(len(pos))
    me.vertices.foreach_set("co", pos.ravel())
    size = 0.5 * (STATE.radius or 0.01)
    r = me.attributes.new("radius", "FLOAT", "POINT")
    r.data.foreach_set("value", np.full(len(pos), size, np.float32))
    for name in ("velocity", "type"):
        if name in d and len(pos):
            vals = np.asarray(d[name], np.float32)
            kind = "FLOAT_VECTOR" if vals.ndim == 2 else "FLOAT"
            a = me.attributes.new(name, kind, "POINT")
            a.data.foreach_set("vector" if vals.ndim == 2 else "value", vals.ravel())
    me.update()


def update_frame(scene, number=None):
    """Show frame `number` (default: the scene's current frame) on the water object."""
    s = _settings(scene)
    obj = bpy.data.objects.get(OBJECT)
    if obj is None or not s.source:
        return
    number = scene.frame_current if number is None else number
    if STATE.key != _key(s):
        load_sequence(s)
    if number not in STATE.frames:
        fill_mesh(obj.data, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)))
        return
    fill_mesh(obj.data, *surface(s, number))
    update_diffuse(scene, number)


@persistent
def on_frame_change(scene, depsgraph=None):
    try:
        update_frame(scene)
    except Exception as e:  # never break playback; say why
        print(f"Meniscus Water: frame {scene.frame_current}: {e}")


class MENISCUS_OT_import(bpy.types.Operator):
    """Import the particle sequence as a liquid surface mesh, rebuilt on every frame change"""
    bl_idname = "meniscus.import_sequence"
    bl_label = "Import"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        scene = context.scene
        s = _settings(scene)
        try:
            seq = load_sequence(s)
        except Exception as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        numbers = sorted(STATE.frames)
        scene.frame_start, scene.frame_end = numbers[0], numbers[-1]
        if seq.get("fps"):
            scene.render.fps, scene.render.fps_base = round(seq["fps"]), round(seq["fps"]) / seq["fps"]
        if scene.frame_current not in STATE.frames:
            scene.frame_current = numbers[0]
        obj = bpy.data.objects.get(OBJECT)
        if obj is None:
            obj = bpy.data.objects.new(OBJECT, bpy.data.meshes.new(OBJECT))
            # Particle files are y up (Meniscus' loaders make them so), Blender is z up: turn the object as
            # Blender's USD and Alembic importers do.
            obj.rotation_euler = (np.pi / 2, 0.0, 0.0)
            scene.collection.objects.link(obj)
        if s.material and not obj.data.materials:
            obj.data.materials.append(water_material())
        if on_frame_change not in bpy.app.handlers.frame_change_post:
            bpy.app.handlers.frame_change_post.append(on_frame_change)
        try:
            update_frame(scene)
        except Exception as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"{len(numbers)} frames, radius {STATE.radius:g} ({seq['radius_from']}); "
                              f"frame {scene.frame_current}: {len(obj.data.vertices)} vertices in "
                              f"{STATE.last_seconds:.2f} s")
        return {"FINISHED"}


class MENISCUS_OT_bake(bpy.types.Operator):
    """Write the scene's frame range as a USD stage or OpenVDB level sets"""
    bl_idname = "meniscus.bake"
    bl_label = "Bake"

    def execute(self, context):
        scene = context.scene
        s = _settings(scene)
        m = _meniscus()
        try:
            if STATE.key != _key(s):
                load_sequence(s)
            numbers = [n for n in sorted(STATE.frames) if scene.frame_start <= n <= scene.frame_end]
            path = bpy.path.abspath(s.bake_path)
            if s.bake_format == "USD":
                stage = m.UsdStage(path, fps=scene.render.fps / scene.render.fps_base)
                for n in numbers:
                    v, t, nrm, vel, _ = surface(s, n)
                    stage.add_mesh(n, v, t, nrm, vel)
                stage.finish()
            else:
                stem, ext = os.path.splitext(path)
                for n in numbers:
                    pos = m.load(STATE.frames[n])["positions"]
                    m.write_vdb(f"{stem}_{n:04d}{ext or '.vdb'}", pos, particle_radius=STATE.radius,
                                support=s.support, cube_size=s.cube_size,
                                iso_surface_threshold=s.threshold)
        except Exception as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"baked {len(numbers)} frames to {path}")
        return {"FINISHED"}


class MENISCUS_PT_panel(bpy.types.Panel):
    bl_label = "Meniscus Water"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Meniscus"

    def draw(self, context):
        s = _settings(context.scene)
        col = self.layout.column()
        col.prop(s, "source")
        col.prop(s, "radius")
        col.prop(s, "cube_size")
        col.prop(s, "support")
        col.prop(s, "threshold")
        col.prop(s, "use_gpu")
        try:
            col.label(text="Meshing on " + meshing_device(s)[1])
        except RuntimeError as e:  # the package missing: say so where the user looks
            col.label(text=str(e))
        col.prop(s, "cache_frames")
        col.prop(s, "material")
        col.prop(s, "diffuse")
        col.operator(MENISCUS_OT_import.bl_idname)
        col.separator()
        col.prop(s, "bake_format")
        col.prop(s, "bake_path")
        col.operator(MENISCUS_OT_bake.bl_idname)


CLASSES = (MeniscusWaterSettings, MENISCUS_OT_import, MENISCUS_OT_bake, MENISCUS_PT_panel)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.meniscus_water = bpy.props.PointerProperty(type=MeniscusWaterSettings)


def unregister():
    if on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)
    del bpy.types.Scene.meniscus_water
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)

"""Makes the shipped meshes (reference_images/meshes/*.ply) inside Blender 3.4:

  blender -b --factory-startup --python reference_images/meshes/make_meshes.py

Every mesh is made here from Blender primitives or from a formula (no third-party model), so
they are ours to ship under the project's licence (README.md beside this file). Each is
triangulated before it is written, so that Blender's Cycles and shadefit's Assimp reader see the
same triangles (a quad split two ways would not be the same surface), scaled to fit a unit
sphere about the origin, and written as binary PLY without normals: both renderers compute the
same angle-weighted vertex normals from the triangles.
"""
import math
import os

import bmesh
import bpy
import mathutils

OUT = os.path.dirname(os.path.abspath(__file__))


def Finish(obj, name):
  bpy.context.view_layer.objects.active = obj
  for mod in obj.modifiers:
    bpy.ops.object.modifier_apply(modifier=mod.name)
  bm = bmesh.new()
  bm.from_mesh(obj.data)
  bmesh.ops.triangulate(bm, faces=bm.faces[:], quad_method="BEAUTY", ngon_method="BEAUTY")
  # Fit the unit sphere: centre the bounding box, scale its farthest vertex to radius 1.
  lo = mathutils.Vector([min(v.co[i] for v in bm.verts) for i in range(3)])
  hi = mathutils.Vector([max(v.co[i] for v in bm.verts) for i in range(3)])
  centre = (lo + hi) / 2
  radius = max((v.co - centre).length for v in bm.verts)
  for v in bm.verts:
    v.co = (v.co - centre) / radius
  bm.to_mesh(obj.data)
  bm.free()
  path = os.path.join(OUT, name + ".ply")
  for o in bpy.context.scene.objects:
    o.select_set(o == obj)
  bpy.ops.export_mesh.ply(filepath=path, use_selection=True, use_mesh_modifiers=False,
                          use_normals=False, use_uv_coords=False, use_colors=False,
                          use_ascii=False, axis_forward="Y", axis_up="Z")
  print(f"[meshes] {name}: {len(obj.data.polygons)} triangles -> {path}")
  bpy.data.objects.remove(obj)


def Suzanne():
  bpy.ops.mesh.primitive_monkey_add(size=2.0)
  obj = bpy.context.active_object
  mod = obj.modifiers.new("subsurf", "SUBSURF")
  mod.levels = 2
  mod.render_levels = 2
  Finish(obj, "suzanne")


def Torus():
  bpy.ops.mesh.primitive_torus_add(major_radius=0.7, minor_radius=0.3, major_segments=96,
                                   minor_segments=48, rotation=(math.radians(70), 0, 0))
  Finish(bpy.context.active_object, "torus")


def TorusKnot(p=2, q=3, segments=480, sides=24, tube=0.18):
  """A (p, q) torus knot (trefoil for 2, 3) as a tube: concave everywhere it passes itself."""
  def Curve(t):
    r = 0.55 + 0.3 * math.cos(q * t)
    return mathutils.Vector((r * math.cos(p * t), r * math.sin(p * t), 0.3 * math.sin(q * t)))
  bm = bmesh.new()
  rings = []
  for i in range(segments):
    t = 2 * math.pi * i / segments
    c, ahead = Curve(t), Curve(t + 1e-3)
    tangent = (ahead - c).normalized()
    normal = tangent.cross(mathutils.Vector((0, 0, 1))).normalized()
    binormal = tangent.cross(normal)
    ring = []
    for j in range(sides):
      a = 2 * math.pi * j / sides
      ring.append(bm.verts.new(c + tube * (math.cos(a) * normal + math.sin(a) * binormal)))
    rings.append(ring)
  for i in range(segments):
    r0, r1 = rings[i], rings[(i + 1) % segments]
    for j in range(sides):
      bm.faces.new((r0[j], r1[j], r1[(j + 1) % sides], r0[(j + 1) % sides]))
  bmesh.ops.recalc_face_normals(bm, faces=bm.faces[:])
  mesh = bpy.data.meshes.new("knot")
  bm.to_mesh(mesh)
  bm.free()
  obj = bpy.data.objects.new("knot", mesh)
  bpy.context.scene.collection.objects.link(obj)
  obj.rotation_euler = (math.radians(75), 0, math.radians(20))
  bpy.context.view_layer.objects.active = obj
  obj.select_set(True)
  bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
  Finish(obj, "torus-knot")


bpy.ops.wm.read_factory_settings(use_empty=True)
Suzanne()
Torus()
TorusKnot()

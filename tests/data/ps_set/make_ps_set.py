"""Makes tests/data/ps_set: a synthetic photometric-stereo data set in the common layout, rendered
by Cycles with its normal pass, so that the truth is known (tests/cli/import_set_test.cpp):

  blender -b --factory-startup --python tests/data/ps_set/make_ps_set.py

Two objects (suzanne/, torus/: the shipped meshes of reference_images/meshes) in a Principled GGX
red plastic (roughness 0.3), an orthographic camera on -Y looking at +Y (+Z up), 12 sun lights
from a spread of directions toward the camera with coloured strengths, direct light only. Written
per object: 001.png ... 012.png (16-bit PNG, linear: display device None), light_directions.txt
and light_intensities.txt in the camera frame (x right, y up, z toward the camera), mask.png,
normal.npy (the normal pass turned into the camera frame; float32, H x W x 3).

The benchmark's larger set (BENCHMARKS.md, photo jobs; not shipped) comes from the same script:

  PS_SET_OUT=/tmp/ps96 PS_SET_WIDTH=612 PS_SET_HEIGHT=512 PS_SET_LIGHTS=96 PS_SET_OBJECTS=suzanne \
    blender -b --factory-startup --python tests/data/ps_set/make_ps_set.py

96 lights are 8 elevations (20 to 76 degrees) x 12 azimuths.
"""
import math
import os
import shutil

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
MESHES = os.path.join(HERE, "..", "..", "..", "reference_images", "meshes")
WIDTH = int(os.environ.get("PS_SET_WIDTH", "96"))
HEIGHT = int(os.environ.get("PS_SET_HEIGHT", "96"))
OUT = os.environ.get("PS_SET_OUT", HERE)
OBJECTS = os.environ.get("PS_SET_OBJECTS", "suzanne,torus").split(",")
# (azimuth about the view axis, elevation from the image plane toward the camera), strength RGB.
LIGHT_COUNT = int(os.environ.get("PS_SET_LIGHTS", "12"))
if LIGHT_COUNT == 12:
  LIGHTS = [(a, e) for e in (35, 60) for a in range(0, 360, 60)]
else:
  assert LIGHT_COUNT % 12 == 0, "PS_SET_LIGHTS: a multiple of 12"
  LIGHTS = [(a + 15 * (i % 2), 20 + 8 * i) for i in range(LIGHT_COUNT // 12)
            for a in range(0, 360, 30)]
COLOURS = [(1.0, 1.0, 1.0), (1.0, 0.9, 0.8), (0.8, 0.9, 1.0)]


def CameraToWorld(v):  # camera frame (x right, y up, z to the camera) -> Blender world
  return (v[0], -v[2], v[1])


def Render(obj_name, out_dir):
  bpy.ops.wm.read_factory_settings(use_empty=True)
  scene = bpy.context.scene
  bpy.ops.import_mesh.ply(filepath=os.path.join(MESHES, obj_name + ".ply"))
  obj = bpy.context.selected_objects[0]
  for p in obj.data.polygons:
    p.use_smooth = True
  obj.cycles.shadow_terminator_offset = 0.0
  obj.cycles.shadow_terminator_geometry_offset = 0.0
  mat = bpy.data.materials.new("m")
  mat.use_nodes = True
  bsdf = mat.node_tree.nodes["Principled BSDF"]
  bsdf.inputs["Base Color"].default_value = (0.8, 0.05, 0.05, 1)
  bsdf.inputs["Roughness"].default_value = 0.3
  bsdf.inputs["Specular"].default_value = 0.5
  bsdf.distribution = "GGX"
  obj.data.materials.append(mat)
  cam_data = bpy.data.cameras.new("cam")
  cam_data.type = "ORTHO"
  cam_data.ortho_scale = 2.2
  cam = bpy.data.objects.new("cam", cam_data)
  cam.location = (0, -6, 0)
  cam.rotation_euler = (math.radians(90), 0, 0)
  scene.collection.objects.link(cam)
  scene.camera = cam
  scene.render.engine = "CYCLES"
  scene.cycles.device = "CPU"
  scene.cycles.samples = 16
  scene.cycles.use_adaptive_sampling = False
  scene.cycles.use_denoising = False
  scene.cycles.max_bounces = 0
  scene.cycles.pixel_filter_type = "GAUSSIAN"
  scene.cycles.filter_width = 0.01
  scene.render.resolution_x = WIDTH
  scene.render.resolution_y = HEIGHT
  scene.render.resolution_percentage = 100
  scene.render.film_transparent = True
  scene.display_settings.display_device = "None"  # linear values into the PNG
  scene.render.image_settings.file_format = "PNG"
  scene.render.image_settings.color_depth = "16"
  scene.render.image_settings.color_mode = "RGB"
  world = bpy.data.worlds.new("w")
  world.use_nodes = True
  world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
  scene.world = world
  scene.view_layers[0].use_pass_normal = True
  os.makedirs(out_dir, exist_ok=True)
  dirs, ints = [], []
  sun = bpy.data.lights.new("sun", "SUN")
  sun.angle = 0.0
  sun_obj = bpy.data.objects.new("sun", sun)
  scene.collection.objects.link(sun_obj)
  for k, (az, el) in enumerate(LIGHTS):
    a, e = math.radians(az), math.radians(el)
    d = (math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e))
    colour = COLOURS[k % 3]
    strength = 2.0 + 0.5 * (k % 2)
    sun.color = colour
    sun.energy = strength
    # A sun shines along its -Z: point -Z away from the light direction.
    w = CameraToWorld(d)
    sun_obj.rotation_mode = "QUATERNION"
    from mathutils import Vector
    sun_obj.rotation_quaternion = Vector(w).to_track_quat("Z", "Y")
    scene.render.filepath = os.path.join(out_dir, f"{k + 1:03d}.png")
    bpy.ops.render.render(write_still=True)
    dirs.append(d)
    ints.append(tuple(strength * c for c in colour))
  with open(os.path.join(out_dir, "light_directions.txt"), "w") as f:
    for d in dirs:
      f.write("%.9f %.9f %.9f\n" % d)
  with open(os.path.join(out_dir, "light_intensities.txt"), "w") as f:
    for i in ints:
      f.write("%.9f %.9f %.9f\n" % i)
  # Normals and alpha: one more render into a float EXR through the compositor.
  scene.use_nodes = True
  tree = scene.node_tree
  for n in list(tree.nodes):
    tree.nodes.remove(n)
  rl = tree.nodes.new("CompositorNodeRLayers")
  comp = tree.nodes.new("CompositorNodeComposite")
  tree.links.new(rl.outputs["Normal"], comp.inputs["Image"])
  tree.links.new(rl.outputs["Alpha"], comp.inputs["Alpha"])
  scene.render.image_settings.file_format = "OPEN_EXR"
  scene.render.image_settings.color_depth = "32"
  scene.render.image_settings.color_mode = "RGBA"
  tmp = os.path.join(out_dir, "normal_pass.exr")
  scene.render.filepath = tmp
  bpy.ops.render.render(write_still=True)
  img = bpy.data.images.load(tmp)
  px = np.array(img.pixels[:], dtype=np.float32).reshape(HEIGHT, WIDTH, 4)[::-1]  # top row first
  alpha = px[..., 3]
  world_n = px[..., :3]
  cam_n = np.stack([world_n[..., 0], world_n[..., 2], -world_n[..., 1]], axis=-1)
  mask = alpha > 0.999  # whole pixels only: partly covered ones mix the background
  cam_n[~mask] = 0
  norm = np.linalg.norm(cam_n, axis=-1, keepdims=True)
  cam_n = np.where(norm > 0, cam_n / np.maximum(norm, 1e-12), 0).astype(np.float32)
  np.save(os.path.join(out_dir, "normal.npy"), cam_n)
  mask_img = bpy.data.images.new("mask", WIDTH, HEIGHT, alpha=False)
  m = np.repeat(mask[::-1, :, None].astype(np.float32), 4, axis=2)
  m[..., 3] = 1
  mask_img.pixels = m.ravel().tolist()
  mask_img.filepath_raw = os.path.join(out_dir, "mask.png")
  mask_img.file_format = "PNG"
  mask_img.save()
  os.remove(tmp)


for name in OBJECTS:
  Render(name, os.path.join(OUT, name))
print("[ps_set] done")

"""Render shadefit's Cycles reference images from a manifest of scene TOML files.

Run inside Blender (3.4 measured; see docs/references.md, "Cycles references"):

    blender -b --factory-startup --python reference_images/cycles/gen.py -- \
        --manifest reference_images/cycles/manifest.toml --out reference_images/cycles \
        [--overwrite] [--only NAME ...]

Every manifest entry names a scene in OUR format (docs/scenes.md) and a Cycles material. For each
entry the scene is rebuilt from an empty factory scene, rendered, and written as
`<name>.exr` (linear float32 RGBA, ZIP, alpha = coverage) plus `<name>.json` (every setting that
produced it). All entries of one run render inside this one Blender process, because each Blender
start costs about 3 s, more than many of the renders themselves.

Existing outputs are kept unless --overwrite: a reference is a fixed artefact, and re-rendering it
by accident would silently change what the fits are compared against.

Why each Cycles setting has its value is said where it is set (`ConfigureCycles`).
"""

import argparse
import hashlib
import json
import math
import os
import sys
import time

import bpy  # Only available inside Blender; this script is not a plain-python module.
import mathutils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from toml_subset import LoadToml  # noqa: E402  (tomllib, or our subset reader on Python 3.10)
# Every key of a scene or material is checked, as our own loader does (scene_keys.py).
from scene_keys import MATERIAL_KEYS, CheckKeys, ValidateScene  # noqa: E402

# ----------------------------------------------------------------------------------------------
# Scene construction
# ----------------------------------------------------------------------------------------------


def _V(x):
  return mathutils.Vector([float(c) for c in x])


def _Rgb(x):
  """Scalar or RGB list -> 3-tuple."""
  if isinstance(x, (int, float)):
    return (float(x),) * 3
  if len(x) != 3:
    raise ValueError(f"expected a scalar or RGB triple, got {x}")
  return tuple(float(c) for c in x)


def LookAtMatrix(position, look_at, up):
  """World matrix of an object whose local -Z points at look_at and local +Y is along up.

  Built by hand (not Vector.to_track_quat) so the roll is fixed by `up` exactly: columns are the
  local axes in world space, x = right, y = true up, z = backwards (Blender cameras look down -Z).
  """
  p = _V(position)
  f = (_V(look_at) - p).normalized()
  r = f.cross(_V(up))
  if r.length < 1e-9:
    raise ValueError("camera up is parallel to the view direction")
  r.normalize()
  u = r.cross(f)
  m = mathutils.Matrix.Identity(4)
  for row in range(3):
    m[row][0], m[row][1], m[row][2], m[row][3] = r[row], u[row], -f[row], p[row]
  return m


def _DirectionMatrix(direction):
  """Rotation whose local -Z is `direction` (a sun shines along its -Z)."""
  d = _V(direction).normalized()
  ref = mathutils.Vector((0, 0, 1)) if abs(d.z) < 0.9 else mathutils.Vector((0, 1, 0))
  return LookAtMatrix((0, 0, 0), d, ref)


def BuildCamera(scene, cam_cfg):
  data = bpy.data.cameras.new("camera")
  # VERTICAL fit: lens and ortho_scale then describe the vertical extent, matching fov_y and
  # height in our format whatever the aspect ratio (AUTO fits the larger dimension).
  data.sensor_fit = "VERTICAL"
  data.sensor_height = 24.0  # mm; only the ratio lens/sensor_height matters.
  data.shift_x = data.shift_y = 0.0
  data.clip_start = 1e-3
  data.clip_end = 1e6  # the "infinite" plane is a 1e4 m quad; keep all of it in view.
  kind = cam_cfg.get("type", "perspective")
  if kind == "perspective":
    data.type = "PERSP"
    fov = math.radians(float(cam_cfg["fov_y"]))
    data.lens_unit = "MILLIMETERS"
    data.lens = 0.5 * data.sensor_height / math.tan(0.5 * fov)
  elif kind == "orthographic":
    data.type = "ORTHO"
    data.ortho_scale = float(cam_cfg["height"])  # full vertical extent under VERTICAL fit
  else:
    raise ValueError(f"unknown camera type {kind}")
  obj = bpy.data.objects.new("camera", data)
  scene.collection.objects.link(obj)
  obj.matrix_world = LookAtMatrix(cam_cfg["position"], cam_cfg["look_at"],
                                  cam_cfg.get("up", [0, 0, 1]))
  scene.camera = obj
  w, h = cam_cfg["resolution"]
  scene.render.resolution_x, scene.render.resolution_y = int(w), int(h)
  scene.render.resolution_percentage = 100
  scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
  return int(cam_cfg.get("supersample", 1))


def BuildMaterial(cfg):
  kind = cfg["type"]
  CheckKeys(cfg, MATERIAL_KEYS.get(kind, {"?"}), f"material type {kind!r}")
  mat = bpy.data.materials.new("material")
  mat.use_nodes = True
  nt = mat.node_tree
  nt.nodes.clear()
  out = nt.nodes.new("ShaderNodeOutputMaterial")
  out.target = "CYCLES"
  if kind == "principled":
    b = nt.nodes.new("ShaderNodeBsdfPrincipled")
    b.distribution = cfg.get("distribution", "GGX")
    b.subsurface_method = "BURLEY"  # subsurface weight is 0; fixed so the JSON is explicit
    b.inputs["Base Color"].default_value = (*_Rgb(cfg["base_color"]), 1.0)
    names = {"metallic": "Metallic", "specular": "Specular", "roughness": "Roughness",
             "specular_tint": "Specular Tint", "anisotropic": "Anisotropic",
             "anisotropic_rotation": "Anisotropic Rotation", "sheen": "Sheen",
             "sheen_tint": "Sheen Tint", "clearcoat": "Clearcoat",
             "clearcoat_roughness": "Clearcoat Roughness", "ior": "IOR"}
    for key, socket in names.items():
      if key in cfg:
        b.inputs[socket].default_value = float(cfg[key])
    # Principled 3.4 defaults worth pinning: no sheen/clearcoat/transmission/subsurface.
    for socket in ("Subsurface", "Sheen", "Clearcoat", "Transmission", "Anisotropic"):
      if socket.lower() not in cfg:
        b.inputs[socket].default_value = 0.0
  elif kind == "diffuse":
    b = nt.nodes.new("ShaderNodeBsdfDiffuse")
    b.inputs["Color"].default_value = (*_Rgb(cfg["base_color"]), 1.0)
    b.inputs["Roughness"].default_value = float(cfg.get("roughness", 0.0))  # 0 = Lambert
  elif kind == "glossy":
    b = nt.nodes.new("ShaderNodeBsdfGlossy")
    b.distribution = cfg.get("distribution", "GGX")
    b.inputs["Color"].default_value = (*_Rgb(cfg["base_color"]), 1.0)
    b.inputs["Roughness"].default_value = float(cfg["roughness"])
  else:
    raise ValueError(f"unknown material type {kind}")
  nt.links.new(b.outputs["BSDF"], out.inputs["Surface"])
  inputs = {i.name: _SocketValue(i) for i in b.inputs
            if hasattr(i, "default_value") and i.enabled}
  inputs["_node"] = b.bl_idname
  for prop in ("distribution", "subsurface_method"):
    if hasattr(b, prop):
      inputs["_" + prop] = getattr(b, prop)
  return mat, inputs


def _SocketValue(socket):
  v = socket.default_value
  try:
    return [float(c) for c in v]
  except TypeError:
    return float(v)


def _SphereGeometryNodes(center, radius, mat):
  """An exact sphere: a one-vertex mesh turned into a point by Geometry Nodes.

  Cycles (since 3.1) intersects point-cloud points as true spheres, so normals and silhouette
  are analytic, as in our ray-cast sphere; a tessellated UV sphere would facet both.
  """
  mesh = bpy.data.meshes.new("sphere_seed")
  mesh.from_pydata([tuple(float(c) for c in center)], [], [])
  obj = bpy.data.objects.new("sphere", mesh)
  tree = bpy.data.node_groups.new("sphere_points", "GeometryNodeTree")
  tree.inputs.new("NodeSocketGeometry", "Geometry")
  tree.outputs.new("NodeSocketGeometry", "Geometry")
  gin = tree.nodes.new("NodeGroupInput")
  gout = tree.nodes.new("NodeGroupOutput")
  pts = tree.nodes.new("GeometryNodeMeshToPoints")
  pts.mode = "VERTICES"
  pts.inputs["Radius"].default_value = float(radius)
  setm = tree.nodes.new("GeometryNodeSetMaterial")
  setm.inputs["Material"].default_value = mat
  tree.links.new(gin.outputs[0], pts.inputs["Mesh"])
  tree.links.new(pts.outputs["Points"], setm.inputs["Geometry"])
  tree.links.new(setm.outputs["Geometry"], gout.inputs[0])
  mod = obj.modifiers.new("points", "NODES")
  mod.node_group = tree
  return obj


def _PlaneTangents(n):
  # docs/scenes.md: ref = +X unless the normal is near X, then +Y. "Near" = |n.x| > 0.9 here.
  ref = mathutils.Vector((0, 1, 0)) if abs(n.x) > 0.9 else mathutils.Vector((1, 0, 0))
  u = n.cross(ref).normalized()
  return u, n.cross(u)


def _Plane(cfg, mat):
  n = _V(cfg["normal"]).normalized()
  p = _V(cfg["point"])
  u, v = _PlaneTangents(n)
  # An infinite plane becomes a 1e4 m square: beyond every camera frustum we use, and small
  # enough that float32 vertex positions keep ~1 mm precision.
  hu, hv = cfg.get("half_size", [1e4, 1e4])
  corners = [p - hu * u - hv * v, p + hu * u - hv * v, p + hu * u + hv * v, p - hu * u + hv * v]
  mesh = bpy.data.meshes.new("plane")
  mesh.from_pydata([tuple(c) for c in corners], [], [(0, 1, 2, 3)])
  # Winding so the face normal is +n; verify rather than trust the corner order.
  mesh.update()
  if mesh.polygons[0].normal.dot(n) < 0:
    mesh.flip_normals()
  mesh.materials.append(mat)
  return bpy.data.objects.new("plane", mesh)


def _Mesh(cfg, mat, scene_dir):
  """A mesh file placed as shadefit places it (render/include/shadefit/render/mesh.h): scale,
  rotation about X then Y then Z (Blender's XYZ Euler), translation; smooth or flat shading from
  the triangles (the shipped PLY files carry no normals)."""
  path = os.path.normpath(os.path.join(scene_dir, cfg["file"]))
  bpy.ops.import_mesh.ply(filepath=path)
  obj = bpy.context.selected_objects[0]
  obj.location = _V(cfg.get("translate", [0, 0, 0]))
  obj.rotation_mode = "XYZ"
  obj.rotation_euler = [math.radians(a) for a in cfg.get("rotate", [0, 0, 0])]
  scale = cfg.get("scale", [1, 1, 1])
  obj.scale = [scale] * 3 if isinstance(scale, (int, float)) else scale
  smooth = cfg.get("normals", "auto") != "flat"
  for poly in obj.data.polygons:
    poly.use_smooth = smooth
  obj.data.use_auto_smooth = False
  # Shadow rays start at the surface, as shadefit's do: no terminator offsets.
  obj.cycles.shadow_terminator_offset = 0.0
  obj.cycles.shadow_terminator_geometry_offset = 0.0
  obj.data.materials.clear()
  obj.data.materials.append(mat)
  for c in obj.users_collection:
    c.objects.unlink(obj)
  return obj


def BuildObjects(scene, objects, mat, scene_dir="."):
  for k, o in enumerate(objects):
    if o["type"] == "sphere":
      obj = _SphereGeometryNodes(o["center"], o["radius"], mat)
    elif o["type"] == "plane":
      obj = _Plane(o, mat)
    elif o["type"] == "mesh":
      obj = _Mesh(o, mat, scene_dir)
    else:
      raise ValueError(f"objects[{k}]: unknown type {o['type']}")
    scene.collection.objects.link(obj)


def _Scaled(rgb):
  """Blender lights take energy (scalar) x colour; split an RGB power that way."""
  m = max(rgb)
  return (m, tuple(c / m for c in rgb) if m > 0 else (1.0, 1.0, 1.0))


def BuildLights(scene, lights, background):
  world = bpy.data.worlds.new("world")
  scene.world = world
  world.use_nodes = True
  nt = world.node_tree
  nt.nodes.clear()
  wout = nt.nodes.new("ShaderNodeOutputWorld")
  wout.target = "CYCLES"
  shaders = []  # world shaders that light the scene
  env_info = []
  for k, l in enumerate(lights):
    t = l["type"]
    if t == "point":
      data = bpy.data.lights.new(f"point{k}", "POINT")
      data.shadow_soft_size = 0.0  # radius 0: a true point light, as in our renderer
      if "power" in l:
        watts = _Rgb(l["power"])
      else:  # Cycles: intensity = power / (4 pi) W/sr for a radius-0 point light
        watts = tuple(4.0 * math.pi * c for c in _Rgb(l["intensity"]))
      data.energy, data.color = _Scaled(watts)
      data.cycles.max_bounces = 1024
      data.cycles.cast_shadow = True
      obj = bpy.data.objects.new(f"point{k}", data)
      obj.location = _V(l["position"])
    elif t == "directional":
      data = bpy.data.lights.new(f"sun{k}", "SUN")
      data.angle = 0.0  # a delta direction
      data.energy, data.color = _Scaled(_Rgb(l["irradiance"]))  # sun strength = W/m^2
      data.cycles.cast_shadow = True
      obj = bpy.data.objects.new(f"sun{k}", data)
      obj.matrix_world = _DirectionMatrix(l["direction"])
    elif t == "environment":
      tex = nt.nodes.new("ShaderNodeTexEnvironment")
      img = bpy.data.images.load(l["file"], check_existing=True)
      img.colorspace_settings.name = "Linear"  # HDR data is scene-linear radiance already
      tex.image = img
      tex.projection = "EQUIRECTANGULAR"
      # Linear (bilinear) lookup: Cycles' default for the node; Closest would alias and Cubic
      # changes the map's values between texels.
      tex.interpolation = "Linear"
      coord = nt.nodes.new("ShaderNodeTexCoord")
      mapping = nt.nodes.new("ShaderNodeMapping")
      mapping.vector_type = "POINT"
      mapping.inputs["Rotation"].default_value = (0.0, 0.0,
                                                  math.radians(float(l.get("rotation_z", 0.0))))
      bg = nt.nodes.new("ShaderNodeBackground")
      bg.inputs["Strength"].default_value = float(l.get("strength", 1.0))
      bg.inputs["Color"].default_value = (1, 1, 1, 1)
      nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
      nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
      nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
      shaders.append(bg.outputs["Background"])
      env_info.append({"file": l["file"], "size": list(img.size),
                       "sha256": _Sha256File(l["file"])})
      continue
    elif t == "uniform":
      bg = nt.nodes.new("ShaderNodeBackground")
      bg.inputs["Color"].default_value = (*_Rgb(l["radiance"]), 1.0)
      bg.inputs["Strength"].default_value = 1.0
      shaders.append(bg.outputs["Background"])
      continue
    elif t == "ambient":
      # The classic ambient term is a model parameter (ka), not light transport: Cycles has no
      # equivalent, and a reference must not pretend to contain it.
      raise ValueError(f"lights[{k}]: 'ambient' has no Cycles equivalent; "
                       "reference scenes must not use it")
    else:
      raise ValueError(f"lights[{k}]: unknown type {t}")
    scene.collection.objects.link(obj)

  if not shaders:
    bg = nt.nodes.new("ShaderNodeBackground")
    bg.inputs["Color"].default_value = (0, 0, 0, 1)
    bg.inputs["Strength"].default_value = 0.0
    shaders.append(bg.outputs["Background"])
  light_shader = shaders[0]
  for s in shaders[1:]:
    add = nt.nodes.new("ShaderNodeAddShader")
    nt.links.new(light_shader, add.inputs[0])
    nt.links.new(s, add.inputs[1])
    light_shader = add.outputs[0]

  transparent = bool(background.get("transparent", True))
  has_env = any(l["type"] in ("environment", "uniform") for l in lights)
  if not transparent and not has_env:
    # Our `color` is composited behind objects but lights nothing; in Cycles a world colour
    # would light the scene, so show it to camera rays only.
    path = nt.nodes.new("ShaderNodeLightPath")
    col = nt.nodes.new("ShaderNodeBackground")
    col.inputs["Color"].default_value = (*_Rgb(background.get("color", [0, 0, 0])), 1.0)
    col.inputs["Strength"].default_value = 1.0
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    nt.links.new(light_shader, mix.inputs[1])
    nt.links.new(col.outputs["Background"], mix.inputs[2])
    light_shader = mix.outputs["Shader"]
  nt.links.new(light_shader, wout.inputs["Surface"])
  return transparent, env_info


def ConfigureCycles(scene, samples, seed, supersample, transparent, bounces=1):
  scene.render.engine = "CYCLES"
  c = scene.cycles
  c.device = "CPU"
  c.samples = int(samples)
  c.seed = int(seed)
  c.use_animated_seed = False
  c.use_adaptive_sampling = False  # fixed sample count: reproducible noise, stated spp
  c.use_denoising = False  # a denoiser would bias the reference
  c.use_preview_denoising = False
  c.sample_clamp_direct = 0.0  # 0 = no clamping; clamping biases highlights and fireflies
  c.sample_clamp_indirect = 0.0
  c.blur_glossy = 0.0  # "filter glossy" would widen sharp highlights
  c.light_sampling_threshold = 0.0  # never skip a light for being dim (unbiased, less noise)
  c.caustics_reflective = True
  c.caustics_refractive = True
  # One convex object (or one plane) per scene: after the first surface a ray can only reach
  # lights or the world, so one bounce of each kind is all the transport there is. The second
  # path segment is what carries the BSDF-sampled half of MIS for the environment; bounces >= 1
  # keep it, more would change nothing.
  # Objects (meshes) are rendered with bounces = 0, direct light only, so that a shading model is
  # judged on what it models; one reference per object set gives the full transport beside them.
  c.max_bounces = int(bounces)
  c.diffuse_bounces = int(bounces)
  c.glossy_bounces = int(bounces)
  c.transmission_bounces = 0
  c.volume_bounces = 0
  c.transparent_max_bounces = 0
  c.use_fast_gi = False
  # Pixel filter. supersample = 1 point-samples the pixel centre in our renderer; a Gaussian of
  # width 0.01 px is the narrowest Cycles filter (BOX would always cover the whole pixel).
  # supersample = N > 1 averages N x N stratified samples over the pixel = a 1 px box filter.
  if supersample <= 1:
    c.pixel_filter_type = "GAUSSIAN"
    c.filter_width = 0.01
  else:
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
  scene.render.film_transparent = transparent  # alpha = coverage, RGB premultiplied
  scene.render.threads_mode = "AUTO"  # all cores; results do not depend on the thread count
  scene.render.use_persistent_data = False
  scene.render.use_motion_blur = False
  # Colour management: EXR output is scene-linear and skips the view transform, but pin it to
  # identity anyway so nothing depends on the defaults.
  scene.display_settings.display_device = "sRGB"
  scene.view_settings.view_transform = "Standard"
  scene.view_settings.look = "None"
  scene.view_settings.exposure = 0.0
  scene.view_settings.gamma = 1.0
  scene.sequencer_colorspace_settings.name = "Linear"
  im = scene.render.image_settings
  im.file_format = "OPEN_EXR"
  im.color_mode = "RGBA"
  im.color_depth = "32"
  im.exr_codec = "ZIP"
  im.use_preview = False
  scene.render.use_file_extension = True
  scene.render.use_compositing = False
  scene.render.use_sequencer = False
  scene.render.dither_intensity = 0.0


def CyclesSettings(scene):
  c = scene.cycles
  keys = ["device", "samples", "seed", "use_animated_seed", "sampling_pattern",
          "use_adaptive_sampling", "use_denoising", "sample_clamp_direct",
          "sample_clamp_indirect", "blur_glossy", "light_sampling_threshold",
          "caustics_reflective", "caustics_refractive", "max_bounces", "diffuse_bounces",
          "glossy_bounces", "transmission_bounces", "volume_bounces", "transparent_max_bounces",
          "pixel_filter_type", "filter_width", "use_fast_gi"]
  out = {k: _Plain(getattr(c, k)) for k in keys if hasattr(c, k)}
  r = scene.render
  out["film_transparent"] = r.film_transparent
  out["view_transform"] = scene.view_settings.view_transform
  out["look"] = scene.view_settings.look
  out["exposure"] = scene.view_settings.exposure
  out["gamma"] = scene.view_settings.gamma
  out["image"] = {"file_format": r.image_settings.file_format,
                  "color_mode": r.image_settings.color_mode,
                  "color_depth": r.image_settings.color_depth,
                  "exr_codec": r.image_settings.exr_codec}
  cam = scene.camera.data
  out["camera"] = {"type": cam.type, "sensor_fit": cam.sensor_fit,
                   "sensor_height_mm": cam.sensor_height, "lens_mm": cam.lens,
                   "ortho_scale": cam.ortho_scale,
                   "matrix_world": [list(row) for row in scene.camera.matrix_world]}
  out["lights"] = [{"name": o.name, "type": o.data.type, "energy_W": o.data.energy,
                    "color": list(o.data.color),
                    "shadow_soft_size": getattr(o.data, "shadow_soft_size", None),
                    "angle": getattr(o.data, "angle", None),
                    "matrix_world": [list(row) for row in o.matrix_world]}
                   for o in scene.objects if o.type == "LIGHT"]
  if scene.world and scene.world.cycles:
    out["world_sampling_method"] = _Plain(scene.world.cycles.sampling_method)
  return out


def _Plain(v):
  return v if isinstance(v, (bool, int, float, str)) else str(v)


def _Sha256File(path):
  h = hashlib.sha256()
  with open(path, "rb") as f:
    for chunk in iter(lambda: f.read(1 << 20), b""):
      h.update(chunk)
  return h.hexdigest()


# ----------------------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------------------


# Hashed once at start: the process renders with the code it loaded, whatever happens on disk later.
# This file only: scene_keys.py and toml_subset.py accept or reject a scene but shape no output.
_GENERATOR_SHA256 = _Sha256File(os.path.abspath(__file__))


def RenderEntry(entry, manifest_dir, out_dir):
  name = entry["name"]
  scene_rel = entry["scene"]
  scene_path = os.path.normpath(os.path.join(manifest_dir, scene_rel))
  with open(scene_path, encoding="utf-8") as f:
    scene_text = f.read()
  scene_cfg = LoadToml(scene_path)
  ValidateScene(scene_cfg, scene_path)

  bpy.ops.wm.read_factory_settings(use_empty=True)  # empty scene: no cube, light or camera
  scene = bpy.context.scene
  mat, mat_inputs = BuildMaterial(entry["material"])
  supersample = BuildCamera(scene, scene_cfg["camera"])
  BuildObjects(scene, scene_cfg.get("objects", []), mat, os.path.dirname(scene_path))
  transparent, env_info = BuildLights(scene, scene_cfg.get("lights", []),
                                      scene_cfg.get("background", {}))
  ConfigureCycles(scene, entry["samples"], entry["seed"], supersample, transparent,
                  entry.get("bounces", 1))

  final_exr = os.path.join(out_dir, name + ".exr")
  final_json = os.path.join(out_dir, name + ".json")
  tmp_exr = os.path.join(out_dir, f".{name}.partial.exr")
  tmp_json = os.path.join(out_dir, f".{name}.partial.json")
  scene.render.filepath = tmp_exr
  t0 = time.perf_counter()
  bpy.ops.render.render(write_still=True)
  seconds = time.perf_counter() - t0
  if not os.path.exists(tmp_exr):
    raise RuntimeError(f"{name}: Blender wrote no image to {tmp_exr}")

  sidecar = {
      "name": name,
      "generator": "reference_images/cycles/gen.py",
      "generator_sha256": _GENERATOR_SHA256,
      "scene_file": scene_rel,
      "scene_sha256": hashlib.sha256(scene_text.encode("utf-8")).hexdigest(),
      "scene_toml": scene_text,
      "scene": scene_cfg,
      "material": entry["material"],
      "material_inputs": mat_inputs,
      "samples": int(entry["samples"]),
      "seed": int(entry["seed"]),
      "resolution": [scene.render.resolution_x, scene.render.resolution_y],
      "supersample": supersample,
      "pixel_filter": {"type": scene.cycles.pixel_filter_type,
                       "width_px": scene.cycles.filter_width},
      "cycles": CyclesSettings(scene),
      "environment_maps": env_info,
      "blender_version": bpy.app.version_string,
      "blender_build_hash": bpy.app.build_hash.decode("ascii", "replace"),
      "python_version": sys.version.split()[0],
      "render_seconds": round(seconds, 3),
      "render_threads": scene.render.threads,
      "notes": entry.get("notes", ""),
  }
  with open(tmp_json, "w", encoding="utf-8") as f:
    json.dump(sidecar, f, indent=1, sort_keys=True)
    f.write("\n")
  # EXR first, JSON last: a reference counts as present only when both exist (see --overwrite),
  # and each rename is atomic, so no reader ever sees a partial file.
  os.replace(tmp_exr, final_exr)
  os.replace(tmp_json, final_json)
  return seconds


def ParseArgs():
  argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
  p = argparse.ArgumentParser(prog="gen.py", description=__doc__.split("\n")[0])
  p.add_argument("--manifest", required=True)
  p.add_argument("--out", required=True)
  p.add_argument("--overwrite", action="store_true", help="re-render existing references")
  p.add_argument("--only", nargs="+", default=None, metavar="NAME")
  return p.parse_args(argv)


def Main():
  args = ParseArgs()
  manifest = LoadToml(args.manifest)
  entries = manifest.get("reference", [])
  names = [e["name"] for e in entries]
  if len(set(names)) != len(names):
    raise SystemExit("manifest: duplicate reference names")
  if args.only:
    missing = set(args.only) - set(names)
    if missing:
      raise SystemExit(f"--only: not in manifest: {sorted(missing)}")
    entries = [e for e in entries if e["name"] in args.only]
  os.makedirs(args.out, exist_ok=True)
  manifest_dir = os.path.dirname(os.path.abspath(args.manifest))
  total, rendered = 0.0, 0
  for e in entries:
    exr = os.path.join(args.out, e["name"] + ".exr")
    js = os.path.join(args.out, e["name"] + ".json")
    if not args.overwrite and os.path.exists(exr) and os.path.exists(js):
      print(f"[gen] keep   {e['name']}", flush=True)
      continue
    s = RenderEntry(e, manifest_dir, args.out)
    total += s
    rendered += 1
    print(f"[gen] render {e['name']}: {s:.2f} s", flush=True)
  print(f"[gen] rendered {rendered} reference(s) in {total:.1f} s of render time", flush=True)


if __name__ == "__main__":
  try:
    Main()
  except SystemExit:
    raise
  except BaseException:
    import traceback
    traceback.print_exc()
    sys.exit(1)  # Blender -b --python would otherwise exit 0 after a Python error

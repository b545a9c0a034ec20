"""Key checks for gen.py's scene and material tables (docs/scenes.md lists the keys).

Our scene format checks every key; so does the generator, so that a key it silently ignored can
never make a reference differ from what its TOML says. Plain Python, no bpy.
"""

SCENE_KEYS = {
    "camera": {"type", "position", "look_at", "up", "fov_y", "height", "resolution",
               "supersample"},
    "sphere": {"type", "center", "radius"},
    "plane": {"type", "point", "normal", "half_size"},
    "mesh": {"type", "file", "translate", "rotate", "scale", "normals"},
    "point": {"type", "position", "power", "intensity"},
    "directional": {"type", "direction", "irradiance"},
    "ambient": {"type", "radiance"},
    "environment": {"type", "file", "strength", "rotation_z", "samples"},
    "uniform": {"type", "radiance", "samples"},
    "background": {"transparent", "color"},
}

MATERIAL_KEYS = {
    # Principled BSDF inputs we expose; anything else keeps its 3.4 default (recorded in JSON).
    "principled": {"type", "base_color", "metallic", "specular", "roughness", "distribution",
                   "specular_tint", "anisotropic", "anisotropic_rotation", "sheen",
                   "sheen_tint", "clearcoat", "clearcoat_roughness", "ior"},
    "diffuse": {"type", "base_color", "roughness"},
    "glossy": {"type", "base_color", "roughness", "distribution"},
}


def CheckKeys(table, allowed, where):
  unknown = set(table) - allowed
  if unknown:
    raise ValueError(f"{where}: unknown key(s) {sorted(unknown)}")


def ValidateScene(scene, where):
  CheckKeys(scene, {"camera", "objects", "lights", "background"}, where)
  CheckKeys(scene["camera"], SCENE_KEYS["camera"], where + " [camera]")
  for k, o in enumerate(scene.get("objects", [])):
    CheckKeys(o, SCENE_KEYS.get(o["type"], set()) or {"?"}, f"{where} objects[{k}]")
  for k, l in enumerate(scene.get("lights", [])):
    CheckKeys(l, SCENE_KEYS.get(l["type"], set()) or {"?"}, f"{where} lights[{k}]")
  CheckKeys(scene.get("background", {}), SCENE_KEYS["background"], where + " [background]")

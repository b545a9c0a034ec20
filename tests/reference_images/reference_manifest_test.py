#!/usr/bin/env python3
"""Every Cycles reference in the manifest is shipped, complete, and matches what the manifest says.

Plain Python 3 (standard library only; no Blender, no numpy, no OpenImageIO), so it runs on every
machine that builds shadefit. Run by CTest as `reference_manifest`
(tests/reference_images/CMakeLists.txt):

    /usr/bin/python3 reference_manifest_test.py --manifest reference_images/cycles/manifest.toml

For each [[reference]] it checks that <name>.exr and <name>.json exist next to the manifest; that
the EXR starts with the OpenEXR magic 0x762f3101 and its header says RGBA float32, ZIP, at the
scene's resolution; and that the JSON sidecar records the same scene (file name and current
content), material, samples and seed. It also rejects strays (outputs no entry names, leftover
`.partial` files) and a set over the 40 MB budget.
"""

import argparse
import hashlib
import os
import struct
import sys

EXR_MAGIC = b"\x76\x2f\x31\x01"  # OpenEXR file layout: the first 4 bytes (20000630 as LE int32)
EXR_FLOAT = 2  # OpenEXR pixel type FLOAT (0 UINT, 1 HALF, 2 FLOAT)
EXR_ZIP = 3  # OpenEXR compression ZIP_COMPRESSION (16-scanline blocks)
BUDGET_BYTES = 40 * 1000 * 1000  # shipped EXR + JSON, all references together

_FAILURES = []


def Check(ok, what):
  if not ok:
    print(f"FAIL {what}")
    _FAILURES.append(what)
  return ok


def LoadToml(path, cycles_dir):
  try:
    import tomllib
  except ModuleNotFoundError:  # Python < 3.11: the generator's own subset reader (plain Python)
    sys.path.insert(0, cycles_dir)
    from toml_subset import LoadToml as Load
    return Load(path)
  with open(path, "rb") as f:
    return tomllib.load(f)


def ReadExrHeader(path):
  """Attributes of a single-part scanline EXR header: {name: (type, bytes)}."""
  with open(path, "rb") as f:
    data = f.read(1 << 16)
  if data[:4] != EXR_MAGIC:
    raise ValueError(f"bad magic {data[:4].hex()}")
  (version,) = struct.unpack_from("<I", data, 4)
  pos, attrs = 8, {}
  while data[pos] != 0:
    name_end = data.index(b"\0", pos)
    type_end = data.index(b"\0", name_end + 1)
    name = data[pos:name_end].decode()
    type_ = data[name_end + 1:type_end].decode()
    (size,) = struct.unpack_from("<i", data, type_end + 1)
    start = type_end + 5
    attrs[name] = (type_, data[start:start + size])
    pos = start + size
  attrs["_version"] = ("int", version)
  return attrs


def Channels(blob):
  out, pos = {}, 0
  while blob[pos] != 0:
    end = blob.index(b"\0", pos)
    name = blob[pos:end].decode()
    (pixel_type,) = struct.unpack_from("<i", blob, end + 1)
    out[name] = pixel_type
    pos = end + 1 + 16  # pixel type, pLinear + 3 reserved bytes, xSampling, ySampling
  return out


def CheckEntry(entry, cycles_dir):
  name = entry["name"]
  exr = os.path.join(cycles_dir, name + ".exr")
  js = os.path.join(cycles_dir, name + ".json")
  if not (Check(os.path.isfile(exr), f"{name}: {exr} missing")
          & Check(os.path.isfile(js), f"{name}: {js} missing")):
    return
  try:
    h = ReadExrHeader(exr)
  except (ValueError, IndexError, struct.error) as e:
    Check(False, f"{name}: not a readable EXR ({e})")
    return
  channels = Channels(h["channels"][1])
  Check(set(channels) == {"R", "G", "B", "A"}, f"{name}: channels {sorted(channels)} != RGBA")
  Check(all(t == EXR_FLOAT for t in channels.values()), f"{name}: channels not all float32")
  Check(h["compression"][1][0] == EXR_ZIP, f"{name}: compression {h['compression'][1][0]} != ZIP")
  x0, y0, x1, y1 = struct.unpack("<4i", h["dataWindow"][1])
  width, height = x1 - x0 + 1, y1 - y0 + 1

  import json
  with open(js, encoding="utf-8") as f:
    side = json.load(f)
  scene_path = os.path.normpath(os.path.join(cycles_dir, entry["scene"]))
  with open(scene_path, "rb") as f:
    scene_bytes = f.read()
  scene = LoadToml(scene_path, cycles_dir)
  want_res = list(scene["camera"]["resolution"])
  Check(side.get("name") == name, f"{name}: sidecar name {side.get('name')!r}")
  Check(side.get("scene_file") == entry["scene"],
        f"{name}: sidecar scene {side.get('scene_file')!r} != manifest {entry['scene']!r}")
  Check(side.get("scene_sha256") == hashlib.sha256(scene_bytes).hexdigest(),
        f"{name}: {entry['scene']} changed since the reference was rendered (re-render it)")
  Check(side.get("material") == entry["material"],
        f"{name}: sidecar material {side.get('material')} != manifest {entry['material']}")
  Check(side.get("samples") == entry["samples"], f"{name}: samples differ from the manifest")
  Check(side.get("seed") == entry["seed"], f"{name}: seed differs from the manifest")
  Check(side.get("resolution") == want_res and [width, height] == want_res,
        f"{name}: resolution sidecar {side.get('resolution')}, EXR {[width, height]}, "
        f"scene {want_res}")
  Check(isinstance(side.get("render_seconds"), (int, float)), f"{name}: no render_seconds")
  Check(str(side.get("blender_version", "")).startswith("3.4"),
        f"{name}: rendered with Blender {side.get('blender_version')!r}, facts measured on 3.4")


def main():
  p = argparse.ArgumentParser()
  p.add_argument("--manifest", required=True)
  args = p.parse_args()
  cycles_dir = os.path.dirname(os.path.abspath(args.manifest))
  manifest = LoadToml(args.manifest, cycles_dir)
  entries = manifest.get("reference", [])
  Check(len(entries) > 0, "manifest has no [[reference]] entries")
  names = [e["name"] for e in entries]
  Check(len(set(names)) == len(names), "duplicate names in the manifest")
  for e in entries:
    CheckEntry(e, cycles_dir)

  total = 0
  for f in sorted(os.listdir(cycles_dir)):
    full = os.path.join(cycles_dir, f)
    if f.endswith((".exr", ".json")):
      total += os.path.getsize(full)
      Check(".partial." not in f, f"leftover partial output {f}")
      Check(os.path.splitext(f)[0] in names, f"{f} is not in the manifest")
  Check(total <= BUDGET_BYTES, f"references take {total / 1e6:.1f} MB > 40 MB budget")

  if _FAILURES:
    print(f"FAILED: {len(_FAILURES)} problem(s) in {len(entries)} references")
    return 1
  print(f"PASSED: {len(entries)} references, {total / 1e6:.1f} MB")
  return 0


if __name__ == "__main__":
  sys.exit(main())

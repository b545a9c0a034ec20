"""Reader for the TOML subset of shadefit's scene and manifest files, for Pythons without tomllib.

Debian's Blender 3.4.1 runs on the system Python 3.11, which has tomllib; the official Blender
3.4 builds bundle Python 3.10, which does not. `LoadToml` uses tomllib when present, else
`LoadTomlSubset`, which covers exactly what our files use: comments, [table], [a.b] sub-tables
(of the last element when `a` is an array of tables), [[array.of.tables]], key = value with basic
strings, integers, floats, booleans, and (possibly multi-line) arrays of those. Inline tables,
literal strings, dates and dotted keys are not supported: use tomllib-era Python for those.

Plain Python, no bpy: the manifest test imports it too.
"""

import json


class TomlSubsetError(ValueError):
  pass


def _StripComment(line):
  out, in_str, esc = [], False, False
  for c in line:
    if in_str:
      out.append(c)
      if esc:
        esc = False
      elif c == "\\":
        esc = True
      elif c == '"':
        in_str = False
    elif c == '"':
      in_str = True
      out.append(c)
    elif c == "#":
      break
    else:
      out.append(c)
  return "".join(out).strip()


def _ParseValue(text, where):
  text = text.strip()
  if text.startswith('"'):
    if not text.endswith('"') or len(text) < 2:
      raise TomlSubsetError(f"{where}: unterminated string")
    return json.loads(text)  # TOML basic strings share JSON's escapes for our subset.
  if text in ("true", "false"):
    return text == "true"
  if text.startswith("["):
    if not text.endswith("]"):
      raise TomlSubsetError(f"{where}: unterminated array")
    inner, items, depth, cur, in_str = text[1:-1], [], 0, [], False
    for c in inner:
      if c == '"':
        in_str = not in_str
      if not in_str and c == "[":
        depth += 1
      if not in_str and c == "]":
        depth -= 1
      if c == "," and depth == 0 and not in_str:
        items.append("".join(cur))
        cur = []
      else:
        cur.append(c)
    items.append("".join(cur))
    return [_ParseValue(i, where) for i in items if i.strip()]
  try:
    return int(text.replace("_", ""))
  except ValueError:
    pass
  try:
    return float(text.replace("_", ""))
  except ValueError:
    raise TomlSubsetError(f"{where}: cannot parse value {text!r}") from None


def LoadTomlSubset(text, name="<toml>"):
  root = {}
  current = root
  lines = text.splitlines()
  i = 0
  while i < len(lines):
    line = _StripComment(lines[i])
    lineno = i + 1
    i += 1
    if not line:
      continue
    where = f"{name}:{lineno}"
    if line.startswith("[["):
      path = line[2:-2].strip().split(".")
      parent = _Descend(root, path[:-1], where)
      arr = parent.setdefault(path[-1], [])
      if not isinstance(arr, list):
        raise TomlSubsetError(f"{where}: {path[-1]} is not an array of tables")
      current = {}
      arr.append(current)
    elif line.startswith("["):
      path = line[1:-1].strip().split(".")
      parent = _Descend(root, path[:-1], where)
      if path[-1] in parent:
        raise TomlSubsetError(f"{where}: table {path[-1]} defined twice")
      current = parent[path[-1]] = {}
    else:
      key, sep, value = line.partition("=")
      if not sep:
        raise TomlSubsetError(f"{where}: expected key = value")
      value = value.strip()
      while value.startswith("[") and value.count("[") > value.count("]") and i < len(lines):
        value += " " + _StripComment(lines[i])  # multi-line array
        i += 1
      key = key.strip()
      if key in current:
        raise TomlSubsetError(f"{where}: duplicate key {key}")
      current[key] = _ParseValue(value, where)
  return root


def _Descend(root, path, where):
  node = root
  for p in path:
    node = node.setdefault(p, {})
    if isinstance(node, list):
      if not node:
        raise TomlSubsetError(f"{where}: empty array {p}")
      node = node[-1]
  return node


def LoadToml(path):
  with open(path, "rb") as f:
    data = f.read()
  try:
    import tomllib  # Python >= 3.11
    return tomllib.loads(data.decode("utf-8"))
  except ModuleNotFoundError:
    return LoadTomlSubset(data.decode("utf-8"), path)

"""A scene given as a dict, written as the TOML text shadefit's scene parser reads.

Only what scene files use: tables, arrays of tables, strings, booleans, integers, floats and
arrays of them (docs/scenes.md). Python 3.11's tomllib reads TOML but does not write it.
"""

import math
import numbers


def _key(k):
    k = str(k)
    if k and all(c.isalnum() or c in "-_" for c in k):
        return k
    return _string(k)


def _string(s):
    out = '"'
    for c in s:
        if c in '"\\':
            out += "\\" + c
        elif c == "\n":
            out += "\\n"
        elif ord(c) < 0x20:
            out += "\\u%04x" % ord(c)
        else:
            out += c
    return out + '"'


def _value(v, where):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, numbers.Integral):
        return str(int(v))
    if isinstance(v, numbers.Real):
        f = float(v)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return repr(f)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        return "{" + ", ".join(_key(k) + " = " + _value(x, where + "." + str(k))
                               for k, x in v.items()) + "}"
    if hasattr(v, "tolist"):  # numpy arrays and scalars
        return _value(v.tolist(), where)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, where) for x in v) + "]"
    raise TypeError(f"scene: {where}: cannot write a {type(v).__name__} as TOML")


def _is_table_array(v):
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def dumps(scene):
    """The TOML text of `scene`, a dict of dicts (tables) and lists of dicts (arrays of tables)."""
    if not isinstance(scene, dict):
        raise TypeError(f"scene: expected a dict, got {type(scene).__name__}")
    lines = []

    def emit(table, prefix):
        for k, v in table.items():
            if not isinstance(v, dict) and not _is_table_array(v):
                lines.append(f"{_key(k)} = {_value(v, prefix + str(k))}")
        for k, v in table.items():
            name = prefix + _key(k)
            if isinstance(v, dict):
                lines.append(f"\n[{name}]")
                emit(v, name + ".")
            elif _is_table_array(v):
                for item in v:
                    lines.append(f"\n[[{name}]]")
                    emit(item, name + ".")

    emit(scene, "")
    return "\n".join(lines).lstrip("\n") + "\n"

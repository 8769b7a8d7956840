"""Reading a scene file: the TOML document (a missing file or a syntax error named), the
command line's overrides set in it, and its tables checked against the schema, every error
naming the file, the line and the key path, with a close known name suggested."""
import difflib
import json
import re
from pathlib import Path

from .keypaths import dotted, line_of, parse_path
from .schema import REQUIRED, TYPES
from .toml import tomllib


def describe(value):
    kinds = {bool: "a boolean", int: "an integer", float: "a float", str: "a string",
             list: "an array", dict: "a table"}
    kind = next((name for t, name in kinds.items() if type(value) is t), type(value).__name__)
    if isinstance(value, dict):
        return kind
    text = json.dumps(value) if isinstance(value, (str, list, bool)) else repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    return f"{text} ({kind})"


def suggest(name, known):
    close = difflib.get_close_matches(str(name), [str(k) for k in known], n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


class Reader:
    """The parsed document with its key lines: checks tables against schemas and raises
    errors naming file, line and key path."""

    def __init__(self, path, data, lines, overridden):
        self.path, self.data, self.lines, self.overridden = str(path), data, lines, overridden

    def where(self, path) -> str:
        """``file:line: key.path``; a key the overrides set (``--set``), or one inside a
        table they set, as ``file: key.path (overridden)``: its line is not the value's.
        An error about a whole table names the overrides inside it too (a value given on
        the command line, refused by a check of the whole table)."""
        path = tuple(path)
        for k in range(len(path), 0, -1):
            if path[:k] in self.overridden:
                return f"{self.path}: {dotted(path)} (overridden)"
        inside = sorted((p for p in self.overridden if len(p) > len(path)
                         and tuple(p[:len(path)]) == path), key=dotted)
        note = (f" (with {', '.join(dotted(p) for p in inside)} overridden)"
                if inside else "")
        line = line_of(self.lines, path)
        return (f"{self.path}:{line}: {dotted(path)}{note}" if line else
                f"{self.path}: {dotted(path)}{note}")

    def error(self, path, message) -> ValueError:
        return ValueError(f"{self.where(path)}: {message}")

    def value(self, path, key, value, dim=None):
        """``value`` of ``key`` checked (type, choices, vector length, ``check``)."""
        expected, test = TYPES.get(key.type, (None, None))
        if test is not None and not test(value):
            if value == "" and key.type == "string":
                raise self.error(path, "expected a name, got an empty string"
                                 + (f" (one of {', '.join(key.choices)})" if key.choices else ""))
            raise self.error(path, f"expected {expected}, got {describe(value)}")
        if key.choices and value not in key.choices and key.check is None:
            raise self.error(path, f"unknown value {value!r}{suggest(value, key.choices)}: "
                             f"choose one of {', '.join(key.choices)}")
        if key.check is not None:
            try:
                key.check(value)
            except ValueError as err:
                raise self.error(path, str(err)) from None
        if key.type == "vector":
            if dim is not None and len(value) != dim:
                raise self.error(path, f"expected {dim} numbers (one per axis of the {dim}D "
                                 f"domain), got {len(value)}")
            return tuple(float(c) for c in value)
        if key.type in ("number", "positive", "non-negative", "fraction"):
            return float(value)
        return value

    def table(self, path, data, schema, dim=None, skip=()):
        """The table at ``path`` checked against ``schema``: unknown keys, missing required
        ones and each value; returns the values given (defaults are the caller's)."""
        if not isinstance(data, dict):
            raise self.error(path, f"expected a table, got {describe(data)}")
        for name in data:
            if name not in schema:
                raise self.error(path + (name,), f"unknown key{suggest(name, schema)}: "
                                 f"{dotted(path) or 'the file'} takes "
                                 f"{', '.join(schema)}")
        out = {}
        for name, key in schema.items():
            if name in skip:
                continue
            if name not in data:
                if key.default is REQUIRED:
                    raise self.error(path, f"missing required key {name!r} ({key.doc})")
                continue
            if key.type in TYPES:
                out[name] = self.value(path + (name,), key, data[name], dim)
            else:
                out[name] = data[name]
        return out

    def array_of_tables(self, path, data, what):
        if not (isinstance(data, list) and all(isinstance(t, dict) for t in data)):
            raise self.error(path, f"expected an array of tables ([[{dotted(path)}]]: "
                             f"{what}), got {describe(data)}")
        return data


def apply_overrides(data, overrides, file):
    """``data`` with ``overrides`` (key path or its text -> value; None removes the key)
    set; returns the key paths set (an error names the scene ``file``)."""
    done = set()
    for text, value in (overrides or {}).items():
        path = parse_path(text) if isinstance(text, str) else tuple(text)
        node = data
        for k, part in enumerate(path[:-1]):
            if isinstance(part, int):
                if not isinstance(node, list) or part >= len(node):
                    raise ValueError(f"{file}: override {dotted(path)}: {dotted(path[:k])} has no "
                                     f"element {part}")
                node = node[part]
            else:
                if not isinstance(node, dict):
                    raise ValueError(f"{file}: override {dotted(path)}: {dotted(path[:k])} is no "
                                     "table")
                node = node.setdefault(part, {})
        last = path[-1]
        if isinstance(last, int) or not isinstance(node, dict):
            raise ValueError(f"{file}: override {dotted(path)}: the last part must name a key "
                             "of a table")
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
        done.add(path)
    return done


def read_toml(path):
    """(text, document) of the TOML file ``path``; a missing file or a syntax error is a
    ValueError naming the file (and the line, column of the error)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"scene file {str(path)!r} " + ("is a directory" if path.is_dir()
                                                         else "does not exist"))
    try:
        text = path.read_bytes().decode("utf-8")
    except UnicodeDecodeError as err:
        raise ValueError(f"{path}: not UTF-8 text ({err.reason} at byte {err.start})") from None
    if text.startswith("\ufeff"):  # a byte-order mark (some Windows editors write one)
        text = text[1:]
    try:
        return text, tomllib.loads(text)
    except RecursionError:
        raise ValueError(f"{path}: invalid TOML: arrays or tables nested too deeply (a "
                         "scene file needs a few levels)") from None
    except tomllib.TOMLDecodeError as err:
        message = str(err)
        m = re.search(r"\s*\(at line (\d+), column (\d+)\)$", message)
        if m:
            raise ValueError(f"{path}:{m.group(1)}:{m.group(2)}: invalid TOML: "
                             f"{message[:m.start()]}") from None
        raise ValueError(f"{path}: invalid TOML: {message}") from None

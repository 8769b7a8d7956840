"""Key paths (``("body", 1, "material")``, written ``body[1].material``) and where their
keys stand in a TOML document: :func:`key_lines` finds the lines (tomllib reports none for
keys)."""
import re

from .toml import tomllib


def _scan(text, start=0):
    """Walk ``text`` from ``start`` outside strings: (code before any comment, index of the
    first ``=`` or -1, bracket depth change of [] and {}, the multi-line string delimiter
    left open or None)."""
    i, eq, depth, n = start, -1, 0, len(text)
    while i < n:
        c = text[i]
        if c == "#":
            return text[:i], eq, depth, None
        if c in "\"'":
            triple = text[i:i + 3]
            if triple in ('"""', "'''"):
                end = text.find(triple, i + 3)
                if end < 0:
                    return text, eq, depth, triple
                i = end + 3
                continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if (c == '"' and text[j] == "\\") else 1
            i = j + 1
            continue
        if c == "=" and eq < 0 and depth == 0:
            eq = i
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        i += 1
    return text, eq, depth, None


def _key_parts(key_text):
    """The parts of a (dotted, quoted) TOML key, read by tomllib; None if it is no key."""
    try:
        doc = tomllib.loads(f"{key_text} = 0")
    except tomllib.TOMLDecodeError:
        return None
    parts = []
    while isinstance(doc, dict) and len(doc) == 1:
        (name, doc), = doc.items()
        parts.append(name)
    return tuple(parts)


def key_lines(text) -> dict:
    """Line (1-based) of every table header and key of the TOML document ``text``, by key
    path: a tuple of names with the index of each array-of-tables element, e.g.
    ``("body", 1, "material")`` for ``material = ...`` under the second ``[[body]]``.

    A dotted key also gives its leading parts the line; keys inside an inline table and
    values of multi-line arrays and strings are not keys of their own (their key's line
    stands for them: see :func:`line_of`)."""
    lines, counts = {}, {}
    table = ()
    open_string, depth = None, 0
    for number, line in enumerate(text.splitlines(), 1):
        if open_string:  # inside a multi-line string value
            if open_string in line:
                rest = line[line.index(open_string) + 3:]
                open_string = None
                _, _, d, open_string = _scan(rest)
                depth += d
            continue
        if depth > 0:  # inside a multi-line array value
            _, _, d, open_string = _scan(line)
            depth += d
            continue
        code, eq, d, open_string = _scan(line)
        stripped = code.strip()
        if not stripped:
            continue
        if eq < 0 and stripped.startswith("["):
            array = stripped.startswith("[[") and stripped.endswith("]]")
            name = stripped[2:-2] if array else stripped[1:-1]
            parts = _key_parts(name.strip())
            if parts is None:
                continue
            path = ()
            for k, part in enumerate(parts):
                path += (part,)
                if array and k == len(parts) - 1:
                    counts[path] = counts.get(path, -1) + 1
                    path += (counts[path],)
                elif path in counts:
                    path += (counts[path],)
            table = path
            lines.setdefault(table, number)
            continue
        if eq > 0:
            parts = _key_parts(code[:eq].strip())
            if parts:
                for k in range(1, len(parts) + 1):
                    lines.setdefault(table + parts[:k], number)
            depth = max(d, 0)
    return lines


def line_of(lines, path):
    """The line of ``path`` or of its longest prefix found in ``lines`` (None: none)."""
    for k in range(len(path), 0, -1):
        if tuple(path[:k]) in lines:
            return lines[tuple(path[:k])]
    return None


def dotted(path) -> str:
    """``("body", 1, "material")`` -> ``body[1].material``."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def parse_path(text):
    """``body[1].material`` -> ``("body", 1, "material")`` (bare names only)."""
    path = []
    for segment in text.split("."):
        m = re.fullmatch(r"([A-Za-z0-9_-]+)((?:\[\d+\])*)", segment)
        if not m:
            raise ValueError(f"bad key path {text!r}: write names and indices such as "
                             "simulation.t_end or body[0].ppc")
        path.append(m.group(1))
        path.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
    return tuple(path)

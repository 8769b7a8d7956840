"""Files written whole: under a unique temporary name beside the file, then renamed over it.

A reader (or a run that fails half-way through writing) never sees a part-written file; a
failed write leaves no temporary file behind and says which file it could not write; two
writers of one file each write their own temporary file (the last rename wins, whole).
"""
import contextlib
import json
import os
import shutil
import tempfile

__all__ = ["replacing", "write_json", "OutputError", "check_output", "check_output_dir",
           "check_distinct", "PLOT_FORMATS"]


class OutputError(OSError):
    """An output that could not be written: ``str()`` names the file and the reason."""

    def __str__(self):
        return f"could not write {self.filename}: {self.strerror}"


@contextlib.contextmanager
def replacing(path, suffix=""):
    """Yield a unique temporary name in ``path``'s directory (ending in ``suffix``, for
    writers that choose the format by it); when the block ends without an error it
    replaces ``path``; the temporary file never stays.  An OSError becomes an
    :class:`OutputError` naming ``path``."""
    path = os.fspath(path)
    folder, name = os.path.split(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=folder or ".", prefix=f".{name}.", suffix=f".tmp{suffix}")
        os.close(fd)
    except OSError as exc:
        raise OutputError(exc.errno, exc.strerror, path) from None
    try:
        yield tmp
        os.replace(tmp, path)
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(exc.errno, exc.strerror, path) from None
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_json(path, doc):
    """``doc`` as indented, strict JSON at ``path``, written whole: a non-finite number
    (a displacement of a run that slid away, a NaN of a failed state) is written null, so
    that every JSON parser reads the record (Python's own would write Infinity and NaN,
    which strict parsers refuse)."""
    with replacing(path) as tmp, open(tmp, "w") as fh:
        json.dump(strict_json(doc), fh, indent=2, allow_nan=False)


def strict_json(value):
    """``value`` with every non-finite float replaced by None (dicts, lists, tuples and
    NumPy scalars and arrays walked through)."""
    import math

    import numpy as np

    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return strict_json(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


#: the least free space an output's directory must have before a run starts
MIN_FREE_BYTES = 1 << 20

#: the formats a plot may be written in (matplotlib's, by suffix)
PLOT_FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff",
                "webp", "pgf", "raw", "rgba")


def check_output(path, option, formats=None):
    """Refuse, before any work, an output ``path`` (given as ``option``, e.g. ``--json``)
    that cannot be written: an empty name, a directory, a missing directory, a directory
    where no file can be created (probed: ``/proc`` refuses it even to root), one with
    less than :data:`MIN_FREE_BYTES` free, a suffix not in ``formats``.  Returns the
    path."""
    text = os.fspath(path)
    if not text:
        raise ValueError(f"{option} needs a file name, got an empty one")
    if os.path.isdir(text):
        raise ValueError(f"{option} {text}: is a directory, not a file")
    folder = os.path.dirname(text) or "."
    if not os.path.isdir(folder):
        raise ValueError(f"{option} {text}: the directory {folder} does not exist")
    if formats is not None:
        suffix = os.path.splitext(text)[1].lstrip(".").lower()
        if suffix not in formats:
            raise ValueError(f"{option} {text}: the format is chosen by the suffix, one of "
                             f"{', '.join('.' + f for f in formats)}")
    if os.path.exists(text) and not os.path.isfile(text):
        # a device, a pipe, a socket: a rename over it would replace it (/dev/null!)
        raise ValueError(f"{option} {text}: is not a regular file (a device, pipe or socket); "
                         "outputs are written whole and renamed over the file")
    _probe(folder, option, text)
    if os.path.exists(text) and not os.access(text, os.W_OK):
        raise ValueError(f"{option} {text}: the file exists and is not writable")
    return text


def check_output_dir(path, option):
    """The directory ``path`` of an output series (given as ``option``), created if
    missing (its parent must exist), probed like :func:`check_output`."""
    text = os.fspath(path)
    if not text:
        raise ValueError(f"{option} needs a directory name, got an empty one")
    if os.path.exists(text) and not os.path.isdir(text):
        raise ValueError(f"{option} {text}: is a file, not a directory")
    if not os.path.exists(text):
        parent = os.path.dirname(os.path.normpath(text)) or "."
        if not os.path.isdir(parent):
            raise ValueError(f"{option} {text}: its parent directory {parent} does not exist")
        try:
            os.mkdir(text)
        except OSError as exc:
            raise ValueError(f"{option} {text}: cannot be created ({exc.strerror})") from None
    _probe(text, option, text)
    return text


def _probe(folder, option, text):
    try:
        fd, probe = tempfile.mkstemp(dir=folder, prefix=".timpm-probe-")
        os.close(fd)
        os.remove(probe)
    except OSError as exc:
        raise ValueError(f"{option} {text}: no file can be written in {folder} "
                         f"({exc.strerror})") from None
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if free < MIN_FREE_BYTES:
        raise ValueError(f"{option} {text}: {folder} has {free} bytes free (no space for "
                         "the output)")


def check_distinct(outputs, inputs=None):
    """Refuse outputs that name one file (``outputs``: option -> path, None for unset) or
    an input (``inputs``: what -> path): the later write would replace the other file."""
    seen = {}
    for what, path in (inputs or {}).items():
        if path:
            seen[os.path.realpath(os.fspath(path))] = what
    for option, path in outputs.items():
        if not path:
            continue
        real = os.path.realpath(os.fspath(path))
        if real in seen:
            raise ValueError(f"{option} {os.fspath(path)} names the same file as "
                             f"{seen[real]}: give each output its own file (and never an "
                             "input)")
        seen[real] = option

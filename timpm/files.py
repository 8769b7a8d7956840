"""Files written whole: under a temporary name beside the file, then renamed over it.

A reader (or a run that fails half-way through writing) never sees a part-written file;
a failed write leaves no temporary file behind.
"""
import contextlib
import json
import os

__all__ = ["replacing", "write_json"]


@contextlib.contextmanager
def replacing(path, tmp=None):
    """Yield the temporary name to write (default ``path`` + ``.tmp``); when the block
    ends without an error it replaces ``path``; the temporary file never stays."""
    tmp = f"{path}.tmp" if tmp is None else str(tmp)
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_json(path, doc):
    """``doc`` as indented JSON at ``path``, written whole."""
    with replacing(path) as tmp, open(tmp, "w") as fh:
        json.dump(doc, fh, indent=2)

"""Which Taichi runs timpm: the ``taichi`` package (1.7), or taichi-forge where that is the
one installed.

taichi-forge (PyPI ``taichi-forge``, imported as ``taichi_forge``) is a maintained fork of
Taichi with wheels for Python 3.10-3.14 (taichi 1.7.4 has none for 3.14).  Where
``taichi`` cannot be imported and ``taichi_forge`` can, this module makes every
``import taichi`` and ``import taichi.X`` (timpm's, the tests', a user's) return
taichi-forge's modules: one runtime, whichever name imported it.  ``TIMPM_TAICHI=forge``
asks for taichi-forge where both are installed (side-by-side measurements);
``TIMPM_TAICHI=taichi`` refuses the fork.

Imported by ``timpm/__init__.py`` before anything imports Taichi.
"""
import importlib
import importlib.abc
import importlib.util
import os
import sys

__all__ = ["NAME", "FORGE", "TaichiChoiceError"]

#: the distribution that runs timpm: "taichi" or "taichi-forge"
NAME = "taichi"
#: True when taichi-forge stands in for taichi
FORGE = False


class TaichiChoiceError(ImportError):
    """The Taichi that TIMPM_TAICHI asks for, or any Taichi, cannot be had."""


class _ForgeAlias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """``taichi`` and ``taichi.X`` found as ``taichi_forge`` and ``taichi_forge.X`` (the
    same module objects, not copies)."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname == "taichi" or fullname.startswith("taichi."):
            return importlib.util.spec_from_loader(fullname, self)
        return None

    def create_module(self, spec):
        return importlib.import_module("taichi_forge" + spec.name[len("taichi"):])

    def exec_module(self, module):
        pass  # executed under its own name already


def _choose() -> str:
    want = os.environ.get("TIMPM_TAICHI", "").strip().lower()
    if want not in ("", "taichi", "forge", "taichi-forge", "taichi_forge"):
        raise TaichiChoiceError(f"the environment variable TIMPM_TAICHI must be 'taichi' or "
                          f"'forge' (taichi-forge), got {want!r}")
    if "taichi" in sys.modules:  # imported before timpm: that one runs
        return "taichi-forge" if sys.modules["taichi"].__name__ == "taichi_forge" else "taichi"
    have_taichi = importlib.util.find_spec("taichi") is not None
    if want == "taichi" or (want == "" and have_taichi):
        if not have_taichi:
            raise TaichiChoiceError("TIMPM_TAICHI=taichi, but the taichi package is not installed "
                              "(pip install 'taichi>=1.7,<1.8')")
        return "taichi"
    if importlib.util.find_spec("taichi_forge") is None:
        if want:
            raise TaichiChoiceError("TIMPM_TAICHI=forge, but taichi-forge is not installed "
                              "(pip install taichi-forge)")
        raise TaichiChoiceError("timpm needs Taichi: neither taichi nor taichi-forge is installed "
                          "(pip install timpm brings the one for this Python)")
    return "taichi-forge"


if _choose() == "taichi-forge":
    NAME, FORGE = "taichi-forge", True
    if not any(isinstance(f, _ForgeAlias) for f in sys.meta_path):
        sys.meta_path.insert(0, _ForgeAlias())

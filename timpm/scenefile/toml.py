"""The TOML parser: :mod:`tomllib` (Python 3.11+), before 3.11 the tomli backport it came
from."""
try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # pragma: no cover - Python < 3.11: the tomli backport
    import tomli as tomllib

__all__ = ["tomllib"]

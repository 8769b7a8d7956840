"""argparse value types shared by the command-line entry points."""
import argparse
import math
import re

__all__ = ["param", "setting", "positive_int", "positive_float", "non_negative_int",
           "numbers_as_values", "add_runtime_arguments"]

#: what argparse takes for a negative number, not an option: -4, -.5, -1e-4, -inf, -nan
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$",
                              re.IGNORECASE)


def numbers_as_values(parser):
    """Let ``parser`` read every negative number as a value, so that the option's type
    refuses it clearly (argparse takes -1e-4 for an option: "expected one argument")."""
    parser._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


def param(text):
    """NAME=VALUE for problem parameters: a number, or a word for a parameter that is one
    (``analysis=undrained``; the problem refuses a word where it needs a number)."""
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    try:
        return name, float(value)
    except ValueError:
        return name, value


def setting(text):
    """NAME=VALUE where VALUE is a number (int or float) or a word (e.g. transfer=musl)."""
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    for kind in (int, float):
        try:
            return name, kind(value)
        except ValueError:
            pass
    return name, value


def scene_setting(text):
    """KEY=VALUE of a scene file's --set: the value read as TOML (a number, true, [1, 2],
    "text"), else as a bare string; empty removes the key."""
    try:  # Python 3.11+; before, the tomli backport (scenefile/toml.py)
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover
        import tomli as tomllib

    key, sep, value = text.partition("=")
    if not sep or not key:
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    if not value:
        return key, None
    try:
        return key, tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return key, value


def positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {value}")
    return value


def non_negative_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {value}")
    return value


def positive_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def add_runtime_arguments(parser):
    """``--threads`` and ``--arch``: where Taichi runs (see :func:`timpm.platform.runtime.init`)."""
    from .runtime import ARCHS

    parser.add_argument("--threads", type=positive_int, help="CPU threads for Taichi")
    parser.add_argument("--arch", choices=list(ARCHS),
                        help="Taichi's backend (default: TIMPM_ARCH, else cpu); a GPU "
                             "backend the machine lacks is an error, never a silent "
                             "fallback to the CPU")

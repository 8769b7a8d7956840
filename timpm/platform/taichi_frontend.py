"""Faster paths through Taichi's Python frontend, the same kernels out: what Taichi reads
again and again while it turns a kernel's Python into its IR (the source positions of
every AST node, each function's source at every call site, the decorator line at every
``@ti.func``), each cached by what it depends on: the same strings, the same IR, the same
offline-cache keys.  Installed by :mod:`timpm.platform.runtime`: the decorator line's check as
Taichi is imported (an import hook), the rest when Taichi starts.  Imports no Taichi
itself, so that runtime can install the hook before it imports Taichi.
"""
import functools
import importlib.abc
import importlib.machinery
import inspect
import linecache
import sys
import textwrap

__all__ = ["FastDecoratorsOnLoad", "memoize_source_positions", "read_decorator_line_once"]


def read_decorator_line_once(kernel_impl) -> None:
    """Taichi asks, at every ``@ti.func`` and ``@ti.kernel``, whether the decorator stands
    in a class body: it reads the decorating frame's source line with
    ``inspect.getframeinfo``, which looks the module up among all loaded modules each
    time (15 ms of each start over timpm's imports, more for each program built).  The
    same line, read through ``linecache`` at the same position: the same answer."""
    patterns = getattr(kernel_impl, "_KERNEL_CLASS_STACKFRAME_STMT_RES", None)
    position = getattr(inspect, "_get_code_position", None)
    if patterns is None or position is None or getattr(kernel_impl, "_timpm_fast", False):
        return  # another Taichi or Python: its own check

    def _inside_class(level_of_class_stackframe):
        try:
            frame = sys._getframe(level_of_class_stackframe)
        except ValueError:
            return False
        lineno = position(frame.f_code, frame.f_lasti)[0] or frame.f_lineno
        line = linecache.getline(frame.f_code.co_filename, lineno, frame.f_globals).strip()
        return any(pattern.match(line) for pattern in patterns)

    kernel_impl._inside_class = _inside_class
    kernel_impl._timpm_fast = True


class FastDecoratorsOnLoad(importlib.abc.MetaPathFinder):
    """Taichi's ``kernel_impl`` (``taichi.lang.kernel_impl``, or
    ``taichi_forge.lang.kernel_impl`` for taichi-forge) with
    :func:`read_decorator_line_once` applied as soon as it is loaded: Taichi's own modules
    define functions at their import too (93 frame lookups in taichi 1.7.4, 30-60 ms of
    every start; 294 in taichi-forge 0.7; a Taichi imported before timpm gets it after)."""

    def __init__(self, package: str = "taichi"):
        self.module = f"{package}.lang.kernel_impl"

    def find_spec(self, name, path=None, target=None):
        if name != self.module:
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or not hasattr(spec.loader, "exec_module"):
            return spec
        load = spec.loader.exec_module

        def exec_module(module):
            load(module)
            read_decorator_line_once(module)
        spec.loader.exec_module = exec_module
        return spec


class _FittingLineWrapper(textwrap.TextWrapper):
    """TextWrapper with a fast path for a line that fits (see memoize_source_positions)."""

    _SETTINGS = ("width", "initial_indent", "subsequent_indent", "expand_tabs",
                 "replace_whitespace", "fix_sentence_endings", "break_long_words",
                 "drop_whitespace", "break_on_hyphens", "tabsize", "max_lines", "placeholder")
    _wrapped: dict = {}

    def wrap(self, text):
        line = text.expandtabs(self.tabsize) if self.expand_tabs else text
        if self.replace_whitespace:
            line = line.translate(self.unicode_whitespace_trans)
        if (len(line) <= self.width and line.isascii() and line.isprintable()
                and self.drop_whitespace and not self.initial_indent
                and not self.subsequent_indent and self.max_lines is None):
            line = line.rstrip(" ")
            return [line] if line else []
        # a longer line: wrapped once per text and settings (a line holds many nodes)
        key = (text, *(getattr(self, name) for name in self._SETTINGS))
        lines = self._wrapped.get(key)
        if lines is None:
            lines = self._wrapped[key] = tuple(super().wrap(text))
        return list(lines)


class _MemoizedTextwrap:
    """``textwrap.fill`` and ``textwrap.dedent``, cached by their arguments."""
    fill = staticmethod(functools.lru_cache(maxsize=None)(textwrap.fill))
    dedent = staticmethod(functools.lru_cache(maxsize=None)(textwrap.dedent))


def memoize_source_positions() -> None:
    """Taichi's frontend formats the source position of every AST node it builds (file,
    line and the code with a ^^^ marker, wrapped by ``textwrap``): half of a kernel's
    Python-side compile time, paid again for every call site of an inlined ``ti.func``.
    The text depends only on the node's place in its source, so it is cached by that
    place: the same strings, the same IR, the same offline-cache keys."""
    from taichi.lang.ast import ast_transformer_utils as utils

    ctx_cls = utils.ASTTransformerContext
    if getattr(ctx_cls, "_timpm_memoized", False):
        return
    original = ctx_cls.get_pos_info
    cache = {}

    def get_pos_info(self, node):
        key = (self.file, self.lineno_offset, self.indent, self.func.func.__name__,
               node.lineno, node.end_lineno, node.col_offset, node.end_col_offset,
               type(node).__name__)
        text = cache.get(key)
        if text is None:
            text = cache[key] = original(self, node)
        return text

    ctx_cls.get_pos_info = get_pos_info
    ctx_cls._timpm_memoized = True
    # the wrapping of each source line and its ^^^ marker at 80 columns: a line that fits
    # (printable ASCII after TextWrapper's tab expansion and whitespace replacement) is one
    # line with its trailing blanks dropped, or none when blank: what TextWrapper gives
    if getattr(utils, "TextWrapper", None) is textwrap.TextWrapper:
        utils.TextWrapper = _FittingLineWrapper
    # and the source of each function, which Taichi reads (tokenizing its file) again for
    # every call site of an inlined ti.func
    from taichi.lang import kernel_impl

    for name in ("getsourcelines", "getsourcefile"):
        original_lookup = getattr(kernel_impl, name, None)
        if original_lookup is not None:
            setattr(kernel_impl, name, functools.lru_cache(maxsize=None)(original_lookup))
    # and each source line's tab expansion (``textwrap.fill`` at width 9999) and the
    # function's dedent, done again at every call site too: pure functions of the text
    if getattr(kernel_impl, "textwrap", None) is textwrap:
        kernel_impl.textwrap = _MemoizedTextwrap()

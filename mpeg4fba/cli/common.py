"""What several subcommands share: checks of an output path made before any work,
warnings summed up by kind, options that take a table entry by number or name, and
steps run under a progress bar (on a terminal only).

The checks raise :class:`click.BadParameter`, so a bad ``-o`` is a usage error (exit
status 2) found in a fraction of a second, not after a clone of 20 seconds; and an
output that is one of the inputs is refused instead of overwriting it.

Example
-------
>>> import os, tempfile
>>> d = tempfile.mkdtemp()
>>> face = os.path.join(d, "face.wrl")
>>> _ = open(face, "w").write("#VRML V2.0 utf8\\n")
>>> check_output(os.path.join(d, "face.png"), [face], suffixes=(".png",))
>>> try:
...     check_output(face, [(face, "FACE")])
... except click.BadParameter as e:
...     print(e.message.replace(face, "face.wrl"))
face.wrl is also an input (FACE): writing it would overwrite it; choose another name
"""
from __future__ import annotations

import os
import re
import sys
import time
from typing import Any, Callable, Iterable, Optional, Sequence, Tuple, Union

import click

__all__ = ["check_output", "check_output_folder", "same_file", "summarise_warnings", "number_spans",
           "TableEntry", "show_progress", "run_steps", "OUTPUT_HINT"]

PathLike = Union[str, "os.PathLike[str]"]
# An input is a path, or (path, what it is on the command line) for a clearer message.
Input = Union[None, PathLike, Tuple[Optional[PathLike], str]]

#: How click names the ``-o`` option in its messages.
OUTPUT_HINT = "'-o' / '--output'"


def same_file(a: PathLike, b: PathLike) -> bool:
    """Whether ``a`` and ``b`` are one file: the same path, or, when both exist, the same
    device and inode (so symlinks and hard links to it count too).

    >>> same_file("x/../a.wrl", "a.wrl"), same_file("a.wrl", "b.wrl")
    (True, False)
    """
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): compare the names
        return os.path.normcase(os.path.abspath(a)) == os.path.normcase(os.path.abspath(b))


def _inputs(inputs: Iterable[Input]) -> list:
    out = []
    for item in inputs:
        path, what = item if isinstance(item, tuple) else (item, "")
        if path is not None:
            out.append((os.fspath(path), what))
    return out


def _refuse_inputs(output: str, inputs: Iterable[Input], hint: str) -> None:
    for path, what in _inputs(inputs):
        if same_file(output, path):
            role = f" ({what})" if what else ""
            # through a link or another spelling: say which input it is
            alias = "" if os.path.abspath(output) == os.path.abspath(path) else \
                f", the same file as {path}"
            raise click.BadParameter(f"{output} is also an input{role}{alias}: writing it "
                                     f"would overwrite it; choose another name",
                                     param_hint=hint)


def _writable_folder(folder: str, hint: str) -> None:
    folder = folder or "."
    if not os.path.exists(folder):
        raise click.BadParameter(f"the folder {folder} does not exist", param_hint=hint)
    if not os.path.isdir(folder):
        raise click.BadParameter(f"{folder} is a file, not a folder", param_hint=hint)
    if not os.access(folder, os.W_OK | os.X_OK):
        raise click.BadParameter(f"can't write in the folder {folder} (permission denied)",
                                 param_hint=hint)


def check_output(output: PathLike, inputs: Iterable[Input] = (), *,
                 suffixes: Optional[Sequence[str]] = None, what: str = "the output",
                 note: str = "", hint: str = OUTPUT_HINT) -> None:
    """Refuse an output file before any work: one of ``inputs`` (also through links), a
    name not ending in one of ``suffixes`` (case-insensitive; ``what`` says what is
    written, ``note`` is added to that message), an existing folder, or a folder that is
    missing or not writable.

    >>> try:
    ...     check_output("x.jpg", suffixes=(".png",), what="a picture")
    ... except click.BadParameter as e:
    ...     print(e.message)
    x.jpg: a picture is written as .png
    """
    out = os.fspath(output)
    _refuse_inputs(out, inputs, hint)
    if suffixes is not None and not out.lower().endswith(tuple(suffixes)):
        raise click.BadParameter(f"{out}: {what} is written as {', '.join(suffixes)}{note}",
                                 param_hint=hint)
    if os.path.isdir(out):
        raise click.BadParameter(f"{out} is a folder; give a file name", param_hint=hint)
    _writable_folder(os.path.dirname(out), hint)


def check_output_folder(output: PathLike, inputs: Iterable[Input] = (), *,
                        hint: str = OUTPUT_HINT) -> None:
    """Refuse an output folder (made if missing, with its parents) before any work: an
    input, an existing file, or under a folder that can't be written.

    >>> import tempfile
    >>> check_output_folder(os.path.join(tempfile.mkdtemp(), "new", "frames"))
    """
    out = os.fspath(output)
    _refuse_inputs(out, inputs, hint)
    if os.path.exists(out):
        if not os.path.isdir(out):
            raise click.BadParameter(f"{out} is a file, not a folder", param_hint=hint)
        _writable_folder(out, hint)
        return
    parent = os.path.dirname(os.path.abspath(out))
    while not os.path.exists(parent):  # the nearest folder that exists must take new ones
        parent = os.path.dirname(parent)
    _writable_folder(parent, hint)


# -- warnings summed up ----------------------------------------------------------------------

_NUMBER = re.compile(r"\d+(?:\.\d+)*")


def number_spans(numbers: Iterable[int]) -> str:
    """Whole numbers as runs, in order.

    >>> number_spans([3, 4, 5, 9, 11, 12])
    '3-5, 9, 11-12'
    """
    runs: list = []
    for k in sorted(set(numbers)):
        if runs and runs[-1][1] == k - 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in runs)


def _spans(values: list) -> str:
    """``1-3, 14, 43-47`` for whole numbers; others listed as they are (at most 8)."""
    if all(v.isdigit() for v in values):
        return number_spans(int(v) for v in values)
    seen = list(dict.fromkeys(values))
    return ", ".join(seen[:8]) + (", ..." if len(seen) > 8 else "")


def summarise_warnings(messages: Iterable[str]) -> list:
    """One line per kind of message: messages that differ only in their numbers are one
    kind, shown once with a count.  When one number varies (``FAP 43``, ``FAP 44``) it
    is replaced by the list of its values; when several do (``a.wrl:3:5``,
    ``a.wrl:10:2``: the list would mix them up) the first message stands for the rest.
    A message of its own kind is kept as it is.  Order: first appearance.

    >>> summarise_warnings(["no tongue: FAP 43 not cloned", "no eyes", "no tongue: FAP 44 not cloned"])
    ['no tongue: FAP 43-44 not cloned (2 warnings like this)', 'no eyes']
    >>> summarise_warnings(["a.wrl:3:5: odd", "a.wrl:10:2: odd", "a.wrl:12:1: odd"])
    ['a.wrl:3:5: odd (and 2 more like this)']
    """
    kinds: dict = {}
    for message in messages:
        key = _NUMBER.sub("#", message)
        kinds.setdefault(key, []).append(message)
    lines = []
    for key, group in kinds.items():
        if len(group) == 1:
            lines.append(group[0])
            continue
        columns = list(zip(*(_NUMBER.findall(m) for m in group)))
        varying = [i for i, values in enumerate(columns) if len(set(values)) > 1]
        if len(varying) != 1:
            lines.append(f"{group[0]} (and {len(group) - 1} more like this)")
            continue
        pieces = _NUMBER.split(group[0])
        text = pieces[0]
        for i, piece in enumerate(pieces[1:]):
            text += _spans(list(columns[i])) if i == varying[0] else columns[i][0]
            text += piece
        lines.append(f"{text} ({len(group)} warnings like this)")
    return lines


# -- options ---------------------------------------------------------------------------------

class TableEntry(click.ParamType):
    """A click parameter: an entry of one of the standard's tables (``VISEMES``,
    ``EXPRESSIONS``) by number or name; its value is the number.  A miss names the
    nearest names.

    >>> from mpeg4fba.fba.tables import VISEMES
    >>> TableEntry(VISEMES).convert("aa", None, None), TableEntry(VISEMES).convert("10", None, None)
    (10, 10)
    """

    def __init__(self, table: Any, low: int = 0):
        self.table = table
        self.low = low
        self.name = table.what

    def get_metavar(self, param: Any = None, ctx: Any = None) -> str:
        return "N|NAME"

    def convert(self, value: Any, param: Optional[click.Parameter], ctx: Optional[click.Context]) -> int:
        if isinstance(value, int) or str(value).strip().isdigit():
            number = int(value)
        else:
            try:
                number = self.table[str(value)].number
            except KeyError as e:
                names = ", ".join(r.name for r in self.table if r.number >= self.low)
                self.fail(f"{e.args[0]} (the {self.table.what}s: {names})", param, ctx)
        numbers = [r.number for r in self.table if r.number >= self.low]
        if number not in numbers:
            self.fail(f"no {self.table.what} {number}: they are {min(numbers)}-{max(numbers)}",
                      param, ctx)
        return number


def show_progress() -> bool:
    """Whether to draw a progress bar: only when stderr is a terminal (a log or a pipe
    gets clean output, not even the bar's label)."""
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def run_steps(steps: Sequence[Tuple[str, Callable[[], None]]], label: str,
              times: Optional[dict] = None) -> dict:
    """Run ``(name, function)`` steps in order and return (or fill) ``times``, name ->
    seconds; on a terminal a progress bar on stderr names the step under way.

    >>> sorted(run_steps([("one", lambda: None), ("two", lambda: None)], "demo"))
    ['one', 'two']
    """
    times = {} if times is None else times

    def run(name: str, step: Callable[[], None]) -> None:
        t0 = time.perf_counter()
        step()
        times[name] = time.perf_counter() - t0

    if not show_progress():
        for name, step in steps:
            run(name, step)
        return times
    with click.progressbar(list(steps), label=label, file=sys.stderr,
                           item_show_func=lambda s: s[0] if s else "") as bar:
        for name, step in bar:
            run(name, step)
    return times

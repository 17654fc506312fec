"""The ``mpeg4fba`` command: a click group with one module per subcommand.

Errors the user can fix (bad VRML, bad values, unreadable files) print one line,
``mpeg4fba: error: <message>``, to stderr and exit with status 1; ``--verbose``
shows the traceback as well.  Usage errors exit with status 2, as click does.

Example
-------
>>> from click.testing import CliRunner
>>> result = CliRunner().invoke(main, ["info", "--example"])
>>> result.exit_code, "HeadMesh" in result.output
(0, True)
"""
from __future__ import annotations

import contextlib
import importlib
import sys
import traceback
import warnings
from typing import TYPE_CHECKING, Any, Iterator, Optional

import click

from .. import __version__
from ..vrml import VRMLError, inflate_limits

if TYPE_CHECKING:
    from ..vrml import Scene
from ..vrml.inflate import MAX_INFLATED, MAX_RATIO, RATIO_FREE

__all__ = ["main", "read_scene", "warnings_to_stderr"]


def _one_line(error: BaseException) -> str:
    """A message for an error, on one line."""
    if isinstance(error, OSError) and not isinstance(error, VRMLError) and error.strerror:
        where = f"{error.filename}: " if error.filename else ""
        text = f"{where}{error.strerror}"
    else:
        text = str(error) or type(error).__name__
    return " ".join(text.split())


#: Each subcommand's module (``mpeg4fba.cli.<name>``) and the first paragraph of its help:
#: ``--help`` lists them without importing them (scipy, the cloner, the renderer), and a
#: subcommand is imported when it runs.  ``tests/test_cli.py`` checks these against the
#: commands' own help.
COMMANDS = {
    "batch": "Clone, validate and play many faces at once on Dask (a local cluster, or an "
             "existing one with --scheduler).",
    "clone": "Clone the facial motion of SOURCE (default: the reference head) onto TARGET.",
    "convert": "Rewrite IN.wrl as canonical VRML97 in OUT.wrl (gzipped if OUT ends in .gz "
               "or .wrz); with --morph-targets, write the face that a neutral and its morph "
               "targets make.",
    "demo": "Clone the reference head's motion onto another head and write what it makes.",
    "info": "Node counts, PROTOs, ROUTEs, DEFs, meshes and bounding box of a VRML97 file; "
            "frames, fps, duration and per-FAP min/max of a .fap animation; meshes, FAT and "
            "bounding box of a face in a .glb, .gltf or .obj file.",
    "play": "Play STREAM on FACE and write the animation (the output's extension says how).",
    "points": "Find the MPEG-4 feature points on HEAD (.obj, .glb, .gltf, .wrl, .ply, .stl, .off) and write "
              "them.",
    "render": "Render FACE (neutral or posed) to a PNG or JPEG: one view, a turntable or a "
              "cloning grid.",
    "say": "Speak TEXT on FACE (default: the reference head), with sound.",
    "validate": "Check faces and FAP streams against the MPEG-4 FBA rules.",
}


def _short_help(text: str, limit: int) -> str:
    """The first sentence of ``text``, cut at a word to fit ``limit`` characters.

    >>> _short_help("Check faces against the rules. Then more.", 40)
    'Check faces against the rules.'
    >>> _short_help("Node counts, PROTOs, ROUTEs, DEFs, meshes and bounding box", 30)
    'Node counts, PROTOs...'
    """
    words = text.split()
    for i, word in enumerate(words):
        if word.endswith("."):
            words = words[:i + 1]
            break
    line = " ".join(words)
    if len(line) <= limit:
        return line
    out = ""
    for word in words:
        if len(out) + len(word) + 1 + 3 > limit:
            break
        out = f"{out} {word}" if out else word
    return out.rstrip(",;:") + "..."


class _Group(click.Group):
    """A click group that turns the errors users can fix into one line and exit code 1,
    and imports a subcommand only when it is used (:data:`COMMANDS`)."""

    def list_commands(self, ctx: click.Context) -> list:
        return sorted(set(COMMANDS) | set(self.commands))

    def get_command(self, ctx: click.Context, name: str) -> Optional[click.Command]:
        if name not in self.commands and name in COMMANDS:
            importlib.import_module(f"{__name__}.{name}")      # registers itself on main
        return self.commands.get(name)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        names = self.list_commands(ctx)
        if not names:
            return
        limit = formatter.width - 6 - max(len(n) for n in names)
        rows = []
        for name in names:
            cmd = self.commands.get(name)
            if cmd is not None and cmd.hidden:
                continue
            text = COMMANDS.get(name) or (cmd.help or "" if cmd is not None else "")
            rows.append((name, _short_help(text, limit)))
        with formatter.section("Commands"):
            formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        with warnings.catch_warnings():
            # A library's deprecation is ours to fix, never a reason for the user's
            # command to fail (as it does under -W error or a test runner's filter):
            # hidden, or shown once with --verbose.  tests/test_dependencies.py runs the
            # commands with --verbose and fails on any that is shown.
            action = "default" if ctx.params.get("verbose") else "ignore"
            for category in (DeprecationWarning, PendingDeprecationWarning):
                warnings.simplefilter(action, category)
            return self._invoke(ctx)

    def _invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except (VRMLError, ValueError, OSError) as e:
            if ctx.params.get("verbose") or (ctx.obj or {}).get("verbose"):
                traceback.print_exc(file=sys.stderr)
            click.echo(f"mpeg4fba: error: {_one_line(e)}", err=True)
            ctx.exit(1)
        except (click.exceptions.Exit, click.ClickException, click.Abort, KeyboardInterrupt):
            raise
        except Exception as e:  # noqa: BLE001 - a bug of ours: still one line, no traceback
            if ctx.params.get("verbose") or (ctx.obj or {}).get("verbose"):
                traceback.print_exc(file=sys.stderr)
            click.echo(f"mpeg4fba: error: {type(e).__name__}: {_one_line(e)} (an internal "
                       f"error; --verbose shows where)", err=True)
            ctx.exit(1)


_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


def _byte_size(ctx: click.Context, param: click.Parameter, value: Optional[str]) -> Optional[int]:
    """``4G``, ``512M``, ``100k``, ``2GiB`` or plain bytes -> bytes (binary units).

    >>> _byte_size(None, None, "4G"), _byte_size(None, None, "1.5MiB"), _byte_size(None, None, "10")
    (4294967296, 1572864, 10)
    """
    if value is None:
        return None
    text = value.strip().upper().removesuffix("B").removesuffix("I")
    number, unit = (text[:-1], text[-1]) if text[-1:] in _UNITS else (text, "")
    try:
        size = int(float(number) * _UNITS[unit])
    except (ValueError, OverflowError):
        size = 0
    if size <= 0:
        raise click.BadParameter(f"{value!r} is not a size in bytes > 0 (e.g. 4G, 512M, 1000000)")
    return size


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--verbose", "-v", is_flag=True, help="Show tracebacks and more detail.")
@click.option("--max-inflated", metavar="SIZE", callback=_byte_size,
              help=f"Most a gzipped input may inflate to, e.g. 4G (default {MAX_INFLATED >> 30}G).")
@click.option("--max-ratio", type=click.FloatRange(min=0), metavar="RATIO",
              help=f"Most a gzipped input may inflate per compressed byte, past "
                   f"{RATIO_FREE >> 20} MiB (default {MAX_RATIO}; 0: no limit).")
@click.version_option(__version__, "--version", "-V", prog_name="mpeg4fba")
@click.pass_context
def main(ctx: click.Context, verbose: bool, max_inflated: Optional[int] = None,
         max_ratio: Optional[float] = None) -> None:
    """MPEG-4 Face and Body Animation toolkit.

    \b
    Examples:
      mpeg4fba info face.wrl
      mpeg4fba convert face.wrl face.wrl.gz
    """
    ctx.ensure_object(dict)
    ctx.obj["verbose"] = verbose
    # every file the subcommand reads is bounded by these, without passing them down
    ctx.with_resource(inflate_limits(max_inflated, max_ratio))


def read_scene(path: str, lenient: bool = False) -> Scene:
    """Read a VRML file for a subcommand; lenient-reading warnings go to stderr, one line each.

    >>> import os, tempfile
    >>> p = os.path.join(tempfile.mkdtemp(), "a.wrl")
    >>> _ = open(p, "w").write("#VRML V2.0 utf8\\nGroup {}")
    >>> read_scene(p).nodes[0].type
    'Group'
    """
    from ..vrml import load

    with warnings_to_stderr():
        return load(path, strict=not lenient)


@contextlib.contextmanager
def warnings_to_stderr() -> Iterator[None]:
    """Show warnings raised inside the block as ``mpeg4fba: warning: <message>`` lines,
    one per kind (messages that differ only in numbers are summed up, with a count:
    see :func:`mpeg4fba.cli.common.summarise_warnings`).

    >>> with warnings_to_stderr():
    ...     warnings.warn("careful")
    """
    from .common import summarise_warnings

    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            yield
    finally:
        messages = []
        for w in caught:
            if issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning)):
                # a library's deprecation is for us, not the user: back to the filters
                # outside (the command group hides it, or shows it with --verbose)
                warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
            else:
                messages.append(" ".join(str(w.message).split()))
        for line in summarise_warnings(messages):
            click.echo(f"mpeg4fba: warning: {line}", err=True)


def verbose(ctx: Optional[click.Context] = None) -> bool:
    """Whether ``--verbose`` was given to the group."""
    ctx = ctx or click.get_current_context(silent=True)
    while ctx is not None:
        if isinstance(ctx.obj, dict) and "verbose" in ctx.obj:
            return bool(ctx.obj["verbose"])
        ctx = ctx.parent
    return False


__all__ += ["COMMANDS"]

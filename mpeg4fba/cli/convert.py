"""``mpeg4fba convert``: read a VRML97 file and write it back in canonical form.

The output is gzip-compressed when its name ends in ``.gz`` or ``.wrz``, and is
written through a temporary file, so a failure leaves no half-written file.

Example
-------
>>> import os, tempfile
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> d = tempfile.mkdtemp()
>>> _ = open(os.path.join(d, "in.wrl"), "w").write("#VRML V2.0 utf8\\nGroup { children [] }")
>>> out = os.path.join(d, "out.wrl")
>>> CliRunner().invoke(main, ["convert", os.path.join(d, "in.wrl"), out]).exit_code
0
>>> print(open(out).read(), end="")
#VRML V2.0 utf8
<BLANKLINE>
Group {
  children []
}
"""
from __future__ import annotations

import os

import click

from ..vrml import dump
from . import main, read_scene

__all__ = ["convert"]


@main.command(epilog="\b\nExamples:\n  mpeg4fba convert face.wrl face-clean.wrl"
                     "\n  mpeg4fba convert --lenient old.wrl face.wrl.gz")
@click.argument("source", metavar="IN.wrl")
@click.argument("target", metavar="OUT.wrl")
@click.option("--lenient", is_flag=True, help="Keep nodes and fields that are not VRML97 (warns).")
def convert(source: str, target: str, lenient: bool) -> None:
    """Rewrite IN.wrl as canonical VRML97 in OUT.wrl (gzipped if OUT ends in .gz or .wrz)."""
    scene = read_scene(source, lenient)
    dump(scene, target)
    n_nodes = sum(1 for _ in scene)
    size = os.path.getsize(target)
    packed = ", gzip" if target.endswith((".gz", ".wrz")) else ""
    click.echo(f"wrote {target}: {n_nodes} nodes, {len(scene.routes)} routes, "
               f"{size} bytes{packed}")

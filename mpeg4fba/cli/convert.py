"""``mpeg4fba convert``: read a VRML97 file and write it back in canonical form.

The output is gzip-compressed when its name ends in ``.gz`` or ``.wrz``, and is
written through a temporary file, so a failure leaves no half-written file.  It must
be a VRML name (``.wrl``, ``.wrz``, ``.wrl.gz``, ``.gz``, ``.vrml``) in a folder that
exists, and not the input (in-place rewriting is refused: write elsewhere, then rename).

With ``--morph-targets`` it builds a FAT-bearing face from a morph-target set instead:
``mpeg4fba convert --morph-targets NEUTRAL TARGET... -o OUT.wrl [--mapping FILE]``
(see :mod:`mpeg4fba.formats.morph_targets` for the file types and target names).

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
from typing import Optional, Sequence

import click

from ..vrml import dump
from . import main, read_scene, warnings_to_stderr
from .common import OUTPUT_HINT, check_output

#: What plain ``convert`` writes (VRML97, gzipped for .gz / .wrz).
VRML_OUT = (".wrl", ".wrz", ".wrl.gz", ".gz", ".vrml")

__all__ = ["convert"]


@main.command(epilog="\b\nExamples:\n  mpeg4fba convert face.wrl face-clean.wrl"
                     "\n  mpeg4fba convert --lenient old.wrl face.wrl.gz"
                     "\n  mpeg4fba convert --morph-targets neutral.obj open_jaw@1024.obj "
                     "viseme_PP.obj -o face.wrl"
                     "\n  mpeg4fba convert --morph-targets head.glb -o face.wrl --mapping names.tsv")
@click.argument("files", nargs=-1, metavar="IN.wrl OUT.wrl | --morph-targets NEUTRAL [TARGET...] -o OUT.wrl")
@click.option("-o", "--output", metavar="OUT.wrl", help="The file to write.")
@click.option("--morph-targets", is_flag=True,
              help="Build a face with a FAT from a neutral and morph targets (VRML, OBJ or glTF; "
                   "target files named like open_jaw@1024.obj, viseme_PP.obj, expression_joy.obj).")
@click.option("--mapping", metavar="FILE",
              help="With --morph-targets: JSON or TSV file of file (or glTF target) name -> "
                   "target name, for files whose names don't say what they show.")
@click.option("--lenient", is_flag=True, help="Keep nodes and fields that are not VRML97, IS bound to exposedFields, a missing header, nan values (warns).")
def convert(files: tuple, output: Optional[str], morph_targets: bool, mapping: Optional[str],
            lenient: bool) -> None:
    """Rewrite IN.wrl as canonical VRML97 in OUT.wrl (gzipped if OUT ends in .gz or .wrz);
    with --morph-targets, write the face that a neutral and its morph targets make."""
    if morph_targets:
        if not files:
            raise click.UsageError("--morph-targets needs the neutral face and its targets")
        if output is None:
            raise click.UsageError("--morph-targets needs -o OUT.wrl")
        check_output(output, [(files[0], "NEUTRAL")] + [(t, "TARGET") for t in files[1:]]
                     + [(mapping, "--mapping")],
                     suffixes=VRML_OUT + (".glb", ".gltf"), what="a face")
        _convert_morph_targets(files[0], files[1:], output, mapping, lenient)
        return
    if mapping is not None:
        raise click.UsageError("--mapping goes with --morph-targets")
    hint = OUTPUT_HINT if output is not None else "OUT.wrl"
    if output is not None:
        files = files + (output,)
    if len(files) != 2:
        raise click.UsageError(f"give IN.wrl and OUT.wrl (got {len(files)} file"
                               f"{'' if len(files) == 1 else 's'})")
    source, target = files
    # rewriting IN in place would lose its comments and layout for good: refused
    check_output(target, [(source, "IN")], suffixes=VRML_OUT, what="VRML97", hint=hint)
    scene = read_scene(source, lenient)
    dump(scene, target, strict=not lenient)
    n_nodes = sum(1 for _ in scene)
    size = os.path.getsize(target)
    packed = ", gzip" if target.endswith((".gz", ".wrz")) else ""
    click.echo(f"wrote {target}: {n_nodes} nodes, {len(scene.routes)} routes, "
               f"{size} bytes{packed}")


def _convert_morph_targets(neutral: str, targets: Sequence[str], output: str,
                           mapping: Optional[str], lenient: bool) -> None:
    from ..formats.morph_targets import read_morph_face
    try:
        from ..formats.wrl_face import save_face
    except ImportError:  # pragma: no cover - until the FAT codec is installed
        raise click.ClickException("writing a face needs mpeg4fba.formats.wrl_face, which "
                                   "this installation lacks") from None
    with warnings_to_stderr():
        face = read_morph_face(neutral, targets, mapping=mapping, lenient=lenient)
        save_face(face, output)
    fat = face.fat
    click.echo(f"wrote {output}: {len(face.meshes)} meshes, {len(fat.faps)} FAPs, "
               f"{len(fat.visemes)} visemes, {len(fat.expressions)} expressions")

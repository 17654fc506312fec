"""``mpeg4fba validate``: FBA compliance of face files (.wrl) and FAP streams (.fap).

Exit status: 0 when no file has an error-level finding (warnings allowed), 1 when one
has, 2 for a usage error.  ``--json`` prints one object per file for machines.

Example
-------
>>> from click.testing import CliRunner
>>> from mpeg4fba.cli import main
>>> r = CliRunner().invoke(main, ["validate", "no-such-file.wrl"])
>>> r.exit_code, "FBA100" in r.output
(1, True)
"""
from __future__ import annotations

import json
import sys

import click

from ..fba.tables import FAP
from ..formats.validate import validate as validate_target
from . import main

__all__ = ["validate"]


@main.command(epilog="\b\nExamples:\n  mpeg4fba validate face.wrl"
                     "\n  mpeg4fba validate face.wrl talk.fap --json"
                     "\n  mpeg4fba validate --ratios face.wrl")
@click.argument("files", nargs=-1, required=True, metavar="FILE...")
@click.option("--json", "as_json", is_flag=True, help="Print the reports as JSON.")
@click.option("--tolerance", default=0.05, show_default=True, type=click.FloatRange(0, 1),
              help="Relative error the numeric FAP check allows.")
@click.option("--ratios", is_flag=True, help="List the numeric check's ratio for every FAP.")
@click.option("--lenient", is_flag=True, help="Read VRML leniently (keep non-VRML97 nodes).")
def validate(files: tuple, as_json: bool, tolerance: float, ratios: bool, lenient: bool) -> None:
    """Check faces and FAP streams against the MPEG-4 FBA rules.

    Each finding has a stable code (FBA001...), a severity and a file:line.  Face files
    also get the numeric check: every FAP of the FAT, played alone, must move its
    feature point by value x FAPU/1024 along its direction (within --tolerance).
    """
    reports = [validate_target(f, tolerance=tolerance, strict=not lenient) for f in files]
    if as_json:
        click.echo(json.dumps([r.as_dict() for r in reports], indent=2))
    else:
        for r in reports:
            click.echo(_human(r, ratios, tolerance))
    sys.exit(1 if any(not r.ok for r in reports) else 0)


def _human(report, show_ratios: bool, tolerance: float) -> str:
    lines = [str(report)]
    measured = {k: v for k, v in report.ratios.items() if v is not None}
    if measured:
        off = [k for k, v in measured.items() if abs(v - 1) > tolerance]
        lines.append(f"  numeric FAP check: {len(measured)} FAPs measured, "
                     f"{len(measured) - len(off)} within tolerance")
        if show_ratios:
            for fap, ratio in sorted(measured.items()):
                lines.append(f"    FAP {fap:2d} {FAP[fap].name:24s} {ratio:8.4f}")
    return "\n".join(lines)

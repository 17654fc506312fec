"""mpeg4fba validate: each fixture triggers exactly its rule; exit codes; JSON; real data."""
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from mpeg4fba.cli import main
from mpeg4fba.fba.compliance import RULES
from mpeg4fba.formats.validate import validate

FIXTURES = Path(__file__).resolve().parents[1] / "spec_fixtures"
RULE_FILES = sorted(p for p in (FIXTURES / "validate").glob("FBA*.*") if p.suffix in (".wrl", ".glb"))
FAP_RULES = {"FBA101": "bad_token.fap", "FBA102": "out_of_range.fap",
             "FBA103": "frame_count_mismatch.fap"}


def test_clean_face_has_no_findings_and_every_fap_measures_one():
    r = validate(FIXTURES / "validate" / "clean.wrl")
    assert r.findings == [] and r.ok
    assert r.ratios[3] == pytest.approx(1.0) and r.ratios[49] == pytest.approx(1.0)


@pytest.mark.parametrize("path", RULE_FILES, ids=lambda p: p.stem)
def test_each_fixture_triggers_exactly_its_rule(path):
    code = path.stem[:6]
    r = validate(path)
    assert {f.code for f in r.findings} == {code}, [str(f) for f in r.findings]
    f = r.findings[0]
    assert f.severity == RULES[code].severity
    if code not in ("FBA002", "FBA003", "FBA015", "FBA017"):   # whole-face rules name no line
        assert f.line is not None and f.path == str(path)


@pytest.mark.parametrize("code, name", sorted(FAP_RULES.items()))
def test_stream_rules(code, name):
    r = validate(FIXTURES / "fap" / name)
    assert {f.code for f in r.findings} == {code}


def test_every_rule_has_a_fixture():
    covered = {p.stem[:6] for p in RULE_FILES} | set(FAP_RULES)
    assert covered == set(RULES)


def test_cli_exit_codes_and_output():
    run = CliRunner().invoke
    clean = str(FIXTURES / "validate" / "clean.wrl")
    r = run(main, ["validate", clean, "--ratios"])
    assert r.exit_code == 0 and "OK" in r.output and "open_jaw" in r.output
    warn = str(FIXTURES / "validate" / "FBA014_fap_off_its_measure.wrl")
    r = run(main, ["validate", warn])
    assert r.exit_code == 0 and "warning FBA014" in r.output     # warnings alone pass
    bad = str(FIXTURES / "validate" / "FBA007_vertex_index_out_of_range.wrl")
    r = run(main, ["validate", clean, bad])
    assert r.exit_code == 1 and f"{bad}:" in r.output and "error FBA007" in r.output
    r = run(main, ["validate"])
    assert r.exit_code == 2


def test_cli_json():
    bad = str(FIXTURES / "validate" / "FBA008_borders_without_zero.wrl")
    r = CliRunner().invoke(main, ["validate", "--json", bad])
    data = json.loads(r.output)
    assert data[0]["ok"] is False and data[0]["findings"][0]["code"] == "FBA008"
    assert data[0]["findings"][0]["line"] > 0


def test_tolerance_option():
    warn = str(FIXTURES / "validate" / "FBA014_fap_off_its_measure.wrl")
    r = CliRunner().invoke(main, ["validate", "--tolerance", "0.25", warn])
    assert "warning FBA014" not in r.output and r.exit_code == 0


def test_real_fap_streams_validate(shared_dir):
    for path in sorted((shared_dir / "data" / "xface").glob("*.fap")):
        r = validate(path)
        assert r.ok, str(r)
        assert {f.code for f in r.findings} <= {"FBA102"}

"""The format stamp of smid's JSON files in the Python package: what it returns carries the
stamp the CLI writes, a result.json it reads back, and one of another kind, of an unknown
format_version or without one is refused with smid.FormatError naming the file and the field
(docs/reference/outputs.md, "Format version")."""
import json
from pathlib import Path

import pytest

import smid

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "examples" / "paper.yaml"


def test_results_carry_the_stamp_and_a_saved_model_set_reads_back(tmp_path):
    r = smid.identify(PAPER)
    assert r.result["format"] == "smid.result" and r.result["format_version"] == 1
    assert r.result["smid_version"] == smid.__version__
    path = tmp_path / "result.json"
    r.model.save(path)
    back = smid.ModelSet.load(path)
    assert back.parameters == r.model.parameters
    rec = smid.simulate_plant(PAPER, seed=91)
    v = back.validate((rec.u, rec.y))
    assert v.data["format"] == "smid.validation" and v.data["format_version"] == 1
    d = back.diagnose([("held", rec.u, rec.y)], only=["actuator_lag"], max_effects=1)
    assert d.data["format"] == "smid.diagnosis" and d.data["format_version"] == 1
    assert {"choice", "before", "after", "summary", "text"} <= set(d.data)


def test_a_result_of_an_unknown_or_missing_format_version_is_refused_by_name(tmp_path):
    raw = smid.identify(PAPER).result
    rec = smid.simulate_plant(PAPER, seed=92)
    for name, version, found in (("v999.json", 999, "found 999"), ("unversioned.json", None, "missing")):
        bad = dict(raw)
        if version is None:
            del bad["format_version"]
        else:
            bad["format_version"] = version
        path = tmp_path / name
        path.write_text(json.dumps(bad), encoding="utf-8")
        expected = f"{path}: field `format_version`: {found}; this smid reads `smid.result` files of format_version 1"
        with pytest.raises(smid.FormatError) as e:
            smid.ModelSet.load(path)
        assert expected in str(e.value)
        # Every function that takes a model set refuses it the same way.
        with pytest.raises(smid.FormatError, match="field `format_version`"):
            smid.validate(path, (rec.u, rec.y))
        with pytest.raises(smid.FormatError, match="field `format_version`"):
            smid.simulate(bad, rec.u)
    assert issubclass(smid.FormatError, smid.SmidError)


def test_a_file_of_another_kind_is_refused_by_its_format_field(tmp_path):
    r = smid.identify(PAPER)
    rec = smid.simulate_plant(PAPER, seed=93)
    validation = r.model.validate((rec.u, rec.y)).data
    path = tmp_path / "validation.json"
    path.write_text(json.dumps(validation), encoding="utf-8")
    with pytest.raises(smid.FormatError) as e:
        smid.ModelSet.load(path)
    assert f'{path}: field `format`: found "smid.validation"' in str(e.value)
    assert "`smid.result`" in str(e.value)

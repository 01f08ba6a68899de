"""A data file that does not fit its spec fails with the file, row (line) and column named."""


import pytest
from conftest import ROOT, SPECS, armcal_cli

from armcal.dataio.reader import read_joint_file, read_measurements
from armcal.support.errors import SpecError
from armcal.spec import load_spec

HEADER = "sample,target,q1,q2,q3,q4,q5,q6,x,y,z\n"
GOOD = "1,reflector,10,-45,90,0,20,0,250.5,10.25,80.125\n2,reflector,20,-40,80,5,10,15,251.5,11.25,81.125\n"


@pytest.fixture(scope="module")
def spec():
    return load_spec(SPECS / "puma560_six.yaml").spec


def _problems(tmp_path, spec, text):
    path = tmp_path / "data.csv"
    path.write_text(text)
    with pytest.raises(SpecError) as caught:
        read_measurements(path, spec)
    return [(i.line, i.column, i.field, i.message) for i in caught.value.issues]


def test_a_good_file_reads_in_internal_units(tmp_path, spec):
    path = tmp_path / "data.csv"
    path.write_text(HEADER + GOOD)
    data = read_measurements(path, spec)
    assert data.keys == (("reflector",), ("reflector",))
    assert data.q[0, 1] == pytest.approx(-0.7853981633974483)  # -45 deg
    assert data.readings["x"][1] == pytest.approx(2515.0)  # 251.5 cm
    assert data.rows.tolist() == [2, 3]


def test_missing_column(tmp_path, spec):
    text = HEADER.replace(",z", "") + GOOD.replace(",80.125", "").replace(",81.125", "")
    assert _problems(tmp_path, spec, text) == [(1, None, "", "missing column: z")]


def test_nan_and_text_and_limits_are_located(tmp_path, spec):
    bad = "3,reflector,10,-45,90,0,20,0,nan,10.25,80.125\n4,reflector,10,abc,90,0,20,0,1,2,3\n5,reflector,10,-45,90,0,20,300,1,2,3\n"
    assert _problems(tmp_path, spec, HEADER + GOOD + bad) == [
        (4, 9, "x", "not a finite number (nan or an infinity)"),
        (5, 4, "q2", "not a number (armcal reads ASCII digits with an optional sign, '.' and exponent, e.g. -1.5e-3)"),
        (6, 8, "q6", "300 deg lies outside joint 6's limits"),
    ]


def test_unknown_names_duplicate_samples_and_short_rows(tmp_path, spec):
    bad = "2,ghost,10,-45,90,0,20,0,1,2,3\n7,reflector,10,-45\n"
    assert _problems(tmp_path, spec, HEADER + GOOD + bad) == [
        (4, 2, "target", "not a known target (the spec's: reflector)"),
        (5, None, "", "4 fields, but the header has 11"),
        (4, 1, "sample", "the sample repeats line 3's"),
    ]


def test_unknown_column_is_named_with_a_suggestion(tmp_path, spec):
    problems = _problems(tmp_path, spec, HEADER.replace("target", "targte") + GOOD)
    assert (1, 2, "targte", "unknown column 'targte'. Did you mean 'target'?") in problems


def test_semicolons_and_decimal_commas_are_recognised(tmp_path, spec):
    text = HEADER.replace(",", ";") + GOOD.replace(",", ";")
    [(line, _, _, message)] = _problems(tmp_path, spec, text)
    assert line == 1 and "separated by ';'" in message


def test_empty_file_and_header_only(tmp_path, spec):
    assert _problems(tmp_path, spec, "")[0][3].startswith("the file is empty")
    assert _problems(tmp_path, spec, HEADER)[0][3] == "the file has a header but no data rows"


def test_pose_list(tmp_path, spec):
    path = tmp_path / "poses.csv"
    path.write_text("q1,q2,q3,q4,q5,q6\n0,-90,90,0,0,0\n10,-80,100,0,10,0\n")
    Q = read_joint_file(path, spec)
    assert Q.shape == (2, 6) and Q[1, 4] == pytest.approx(0.17453292519943295)


def test_cli_simulate_writes_and_reports(tmp_path):
    result = armcal_cli("simulate", SPECS / "puma560_six.yaml", "--out", tmp_path)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "calibration.csv").exists() and (tmp_path / "validation.csv").exists()
    assert (tmp_path / "truth.json").exists()
    assert not list(tmp_path.glob(".*.tmp"))


def test_decimal_commas_are_recognised_in_a_comma_file(tmp_path, spec):
    [(line, _, _, message)] = _problems(tmp_path, spec, HEADER + "1,reflector,10,-45,90,0,20,0,250,5,10,25,80,125\n")
    assert line == 2 and "decimal commas?" in message


def test_sonic_targets_may_be_given_as_link_numbers(tmp_path):
    """The data contract's sonic `target` is the link that carries the sparker (1..N); names work too."""
    folder = ROOT / "examples" / "puma560_sonic"
    spec = load_spec(folder / "spec.yaml").spec
    by_name = read_measurements(folder / "calibration.csv", spec)
    lines = (folder / "calibration.csv").read_text().splitlines()
    column = lines[0].split(",").index("target")
    renamed = [lines[0]] + [",".join(v.replace("sparker", "") if i == column else v for i, v in enumerate(line.split(","))) for line in lines[1:]]
    (tmp_path / "links.csv").write_text("\n".join(renamed) + "\n")
    by_link = read_measurements(tmp_path / "links.csv", spec)
    assert by_link.keys == by_name.keys and by_link.keys[0] == ("sparker6",) and renamed[1].split(",")[column] == "6"

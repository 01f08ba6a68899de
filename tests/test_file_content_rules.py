"""What armcal says about, reads from and writes into files, by one rule each (hostile report 30, items 2, 9, 10).

- Messages never pass a file's content through: a name, serial or value read from a file is shown only as short
  printable text (errors.shown_text / shown_key / shown_value), a data cell never, a git object's bytes never.
- Numbers in files are read by one strict rule (units.parse_number): ASCII digits only; Python's float() would read
  '1_0' as 10 and take Arabic-Indic or full-width digits and Unicode spaces.
- Every CSV armcal writes comes from fileio.csv_text: a text cell that a spreadsheet would run as a formula gets a
  leading quote (OWASP's list: = + - @ tab CR LF), and armcal's reader takes it back off.

Cases here differ from the report's own examples (other commands, file kinds and positions).
"""

import csv
import hashlib
import io
import re
import zlib
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, armcal_cli, copy_example

from armcal.dataio.measurements import Measurements
from armcal.dataio.reader import read_measurements, read_pose_file
from armcal.dataio.writer import measurements_csv
from armcal.support.errors import SpecError, UserError
from armcal.support.fileio import csv_text, spreadsheet_text
from armcal.support.gitrepo import file_at_revision
from armcal.importers.urdf import read_urdf
from armcal.spec import load_spec
from armcal.support.units import parse_number

SECRET = "hunter2-Pa55"
CONTROL = "\x1b[2J\x1b]8;;http://x\x07"  # clear screen, a hyperlink escape, BEL


def _no_content(text: str, *contents: str) -> None:
    for content in contents:
        assert content not in text, text
    assert "\x1b" not in text and "\x07" not in text and "Traceback" not in text, text


# --- A: content echoed in messages -------------------------------------------------------------------------------

def test_messages_show_no_file_content_beyond_short_printable_names(tmp_path):
    copy_example("theodolite", tmp_path)
    spec = (tmp_path / "spec.yaml").read_text()
    serial = re.search(r"serial: (.*)", spec).group(1)

    # compare of two specs: a serial with escape sequences, then (same serial) a robot name of 41 characters
    escaped = tmp_path / "escaped.yaml"
    escaped.write_text(spec.replace(f"serial: {serial}", f'serial: "{SECRET}\\e[2J\\e]8;;http://x\\a"'))
    done = armcal_cli("compare", tmp_path / "spec.yaml", escaped)
    assert done.returncode == 1 and "with control characters (not shown)" in done.stderr, done.stderr
    _no_content(done.stdout + done.stderr, SECRET)
    renamed = tmp_path / "renamed.yaml"
    renamed.write_text(re.sub(r"name: .*", "name: " + "N" * 41, spec, count=1))
    done = armcal_cli("compare", tmp_path / "spec.yaml", renamed)
    assert done.returncode == 1 and "a name of 41 characters (not shown)" in done.stderr, done.stderr
    _no_content(done.stderr, "N" * 41)

    # validate: an unknown key that is no key (a space and a '$' in it, 45 characters) inside a section, a unit of
    # 60 characters, and a key in an effect
    key = "x$" + "k" * 43
    bad = tmp_path / "bad.yaml"
    bad.write_text(re.sub(r"units: \{length: \w+", "units: {length: " + SECRET + "u" * 48, spec.replace("\nrobot:\n", f"\nrobot:\n  {key}: 1\n", 1)))
    done = armcal_cli("validate", bad)
    assert done.returncode == 1, done.stderr
    assert "a key of 45 characters (not shown)" in done.stderr and "a value of 60 characters (not shown)" in done.stderr
    _no_content(done.stderr, key, SECRET)
    bad.write_text(spec.replace("units: {length: mm", f"units: {{length: {SECRET}, length: mm", 1))  # the parser quotes
    done = armcal_cli("validate", bad)
    assert done.returncode == 1 and "duplicate key" in done.stderr, done.stderr
    _no_content(done.stderr, SECRET)


def test_a_data_or_pose_file_cell_is_never_quoted(tmp_path):
    loaded = load_spec(ROOT / "examples" / "goswami_ballbar" / "spec.yaml")
    poses = tmp_path / "poses.csv"
    row = ["10", "-20", "30", "12,5", "0", "x" + SECRET]  # a decimal comma in q4 (quoted), text in q6
    poses.write_text("q1,q2,q3,q4,q5,q6,pivot,sphere\n" + ",".join(f'"{c}"' if "," in c else c for c in row)
                     + f",{SECRET},sphere1\n")
    with pytest.raises(SpecError) as raised:
        read_pose_file(poses, loaded.spec)
    issues = [str(i) for i in raised.value.issues]
    assert f"{poses}:2:4: q4: not a number (a decimal comma? armcal reads '.')" in issues
    assert any(i.startswith(f"{poses}:2:6: q6: not a number") for i in issues)
    assert any(i.startswith(f"{poses}:2:7: pivot: not a known pivot") for i in issues), issues
    _no_content(str(raised.value), SECRET, "12,5")


def test_a_broken_git_object_is_not_echoed(tmp_path):
    git_dir = tmp_path / "repo" / ".git"
    (git_dir / "refs" / "heads").mkdir(parents=True)
    (git_dir / "HEAD").write_text("ref: refs/heads/main\n")
    data = f"commit 3\0{SECRET}-token".encode()  # a header that declares 3 bytes for 19: no loose object
    oid = hashlib.sha1(data).hexdigest()
    (git_dir / "objects" / oid[:2]).mkdir(parents=True)
    (git_dir / "objects" / oid[:2] / oid[2:]).write_bytes(zlib.compress(data))
    (git_dir / "refs" / "heads" / "main").write_text(oid + "\n")
    with pytest.raises(UserError) as raised:
        file_at_revision(tmp_path / "repo" / "spec.yaml", "HEAD")
    assert "not a loose object" in str(raised.value) and "not shown" in str(raised.value)
    _no_content(str(raised.value), SECRET, "commit 3")


# --- B: one strict number parser -----------------------------------------------------------------------------------

@pytest.mark.parametrize("text", ["2_5", "\u0662", "\uff12.5", "2.5\u00a0", "\u20072", "0x10", "1e", "--1", "", " 1"])
def test_only_ascii_numbers_are_numbers(text):
    with pytest.raises(ValueError):
        parse_number(text)


@pytest.mark.parametrize("text, value", [("-1.5e-3", -1.5e-3), ("+.5", 0.5), ("7.", 7.0), ("1E3", 1000.0)])
def test_ascii_numbers_read_as_python_reads_them(text, value):
    assert parse_number(text) == value


def test_every_file_reader_refuses_what_float_would_take(tmp_path):
    # a ball-bar data file: an underscore in a length, a full-width digit in a joint value
    copy_example("goswami_ballbar", tmp_path)
    loaded = load_spec(tmp_path / "spec.yaml")
    lines = (tmp_path / "calibration.csv").read_text().splitlines()[:3]
    header = lines[0].split(",")
    cells = lines[1].split(",")
    cells[header.index("length")] = cells[header.index("length")].replace(".", "_", 1)
    second = lines[2].split(",")
    second[header.index("q5")] = "\uff13"
    (tmp_path / "calibration.csv").write_text("\n".join([lines[0], ",".join(cells), ",".join(second)]) + "\n")
    with pytest.raises(SpecError) as raised:
        read_measurements(tmp_path / "calibration.csv", loaded.spec)
    assert [(i.line, i.field) for i in raised.value.issues] == [(2, "length"), (3, "q5")]

    # a URDF: an Arabic-Indic digit in a limit, a no-break space between an axis's numbers
    urdf = tmp_path / "r.urdf"
    urdf.write_text('<robot name="r"><link name="a"/><link name="b"/>'
                    '<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0\u00a01"/>'
                    '<limit lower="-1" upper="\u0661" effort="1" velocity="1"/></joint></robot>')
    with pytest.raises(UserError, match="not 3 numbers"):
        read_urdf(urdf, "a", "b")
    urdf.write_text(urdf.read_text().replace("0 0\u00a01", "0 0 1"))
    with pytest.raises(UserError, match="not 1 number"):
        read_urdf(urdf, "a", "b")

    # a spec quantity written as text
    spec = (tmp_path / "spec.yaml").read_text()
    (tmp_path / "spec.yaml").write_text(spec.replace("sigma_p: 0.01", 'sigma_p: "0.0_1 cm"', 1))
    done = armcal_cli("validate", tmp_path / "spec.yaml")
    assert done.returncode == 1 and "simulate.sigma_p" in done.stderr and "Traceback" not in done.stderr, done.stderr


# --- C: formula-like CSV cells -------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["+chuck|x", "-2+3", "@A1", "\n=1+1", "\r=1", "\t@x", "'=x", "''@x", "plain", "'quoted"])
def test_csv_text_escapes_formula_cells_and_the_reader_takes_them_back(name):
    written = csv_text([["name", "value"], [name, "-1.5"]])
    _, (cell, number) = csv.reader(io.StringIO(written))
    assert number == "-1.5"  # a number is no formula
    assert not cell.startswith(("=", "+", "-", "@", "\t", "\r", "\n"))
    assert spreadsheet_text(cell) == name


def test_simulated_data_with_formula_like_names_is_escaped_and_read_back(tmp_path):
    copy_example("goswami_ballbar", tmp_path)
    spec = (tmp_path / "spec.yaml").read_text().replace("chuck2", '"@SUM(2)"').replace("chuck3", '"-chuck3"')
    (tmp_path / "spec.yaml").write_text(spec)
    loaded = load_spec(tmp_path / "spec.yaml")
    keys = (("@SUM(2)", "sphere1", None), ("-chuck3", "sphere2", None))
    measured = Measurements(keys=keys, q=np.zeros((2, 6)), readings={"length": np.array([457.0, 458.0])}, extras={},
                            rows=np.arange(2, 4), source=Path("x.csv"), sample=("=1", "2"))
    text = measurements_csv(measured, loaded.spec)
    rows = text.splitlines()[1:]
    assert rows[0].startswith("'=1,'@SUM(2),sphere1,") and rows[1].startswith("2,'-chuck3,sphere2,"), text
    (tmp_path / "back.csv").write_text(text)
    back = read_measurements(tmp_path / "back.csv", loaded.spec)
    assert back.keys == keys and back.sample == ("=1", "2")


def test_no_csv_is_written_but_through_csv_text():
    """Every writer of CSV text in armcal calls fileio.csv_text: no csv.writer, no comma-joined rows elsewhere."""
    offenders = []
    for path in (ROOT / "armcal").rglob("*.py"):
        if path.name == "fileio.py":
            continue
        text = path.read_text()
        joined = [line for line in text.splitlines() if re.search(r"""['"],['"]\.join\(""", line)
                  and any(word in line for word in ("write", "append", "\\n"))]  # a CSV row being written
        if "csv.writer" in text or joined:
            offenders.append(path.relative_to(ROOT))
    assert offenders == []

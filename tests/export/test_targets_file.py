"""compensate's targets file (issue 30 class 8) is read by the measured-data reader (dataio.reader.read_table): a BOM
and CRLF are read, an unknown, doubled or missing column, a partial seed, a seed outside the joint limits, a row of
the wrong length, an unclosed quote, an empty or non-numeric cell, a position beyond a kilometre (its arithmetic overflowed: numpy's
warnings, not one message), a number finite in the spec's unit but not in mm (1e308 cm) is one located message, exit 1, no traceback;
nothing of the file but an accepted column name is quoted. The oracle target: the PUMA's tool at a known q."""

import csv

import numpy as np
import pytest
from conftest import SPECS, armcal_cli

from armcal.support.errors import SpecError
from armcal.export.compensation import compensate
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.transforms import pose_from_matrix
from armcal.spec import load_spec

Q = [10, -40, 150, 5, 30, 20]  # deg, inside the PUMA's limits


@pytest.fixture(scope="module")
def puma():
    loaded = load_spec(SPECS / "puma560_dh.yaml")  # cm and deg
    x, y, z, rz, ry, rx = pose_from_matrix(compile_robot(loaded.spec.robot.chain()).tool_poses(np.radians([Q]))[0])
    return loaded, [f"{v:.12g}" for v in (x / 10, y / 10, z / 10, *np.degrees([rx, ry, rz]))]


SEED = ",".join(str(q + 3) for q in Q)
BAD = [  # (header, row, expected issue after "targets:")
    ("name,x,y,z,rx,ry,rz,x", "p,{pose},1", "1:8: x: column 'x' appears twice"),
    ("name,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6,q7", "p,{pose}," + SEED + ",0", "1:14: q7: unknown column 'q7'. Known columns: x, y, z, rx, ry, rz, q1, q2, q3, q4, q5, q6, name."),
    ("nmae,x,y,z,rx,ry,rz", "p,{pose}", "1:1: nmae: unknown column 'nmae'. Did you mean 'name'?"),
    ("name,x,y,z,rx,ry,rz", "p,{pose},7", "2: 8 fields, but the header has 7 (decimal commas? armcal reads '.' as the decimal mark)"),
    ("name,x,y,z,rx,ry,rz", "p,{pose_short}", "2: 6 fields, but the header has 7"),
    ("name,x,y,z,rx,ry,rz,q1,q2,q3", "p,{pose},1,2,3", "1: missing columns: q4, q5, q6"),
    ("name,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6", "p,{pose},13,-37,153,,33,23", "2:11: q4: empty value"),
    ("name,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6", "p,{pose},13,100,153,8,33,23", "2:9: q2: 100 deg lies outside joint 2's limits"),
    ("name,x,y,z,rx,ry,rz", '"p,{pose}', "2: not a CSV row the reader can take (unexpected end of data: an unclosed quote?)"),
    ("name,x,y,z,rx,ry,rz", "p,,{pose_short}", "2:2: x: empty value"),
    ("name,x,y,z,rx,ry,rz", "p,{pose_short},inf", "2:7: rz: not a finite number (nan or an infinity)"),
    ("name,x,y,z,rx,ry,rz", "p,1e7,{pose_short}", "2: x: farther than any robot reaches (more than 100000 cm, a kilometre, from the world origin)"),
    ("name,x,y,z,rx,ry,rz", "p,1e308,{pose_short}", "2:2: x: too large: infinite in mm, armcal's internal unit"),  # finite in cm
    ("name,x,y,z,rx,ry,rz,root:x:0:0:secret-" + "z" * 40, "p,{pose},1", "1:8: unknown column 8 (a header of 58 characters that is no column name, not shown). "
     "Known columns: x, y, z, rx, ry, rz, name, q1, q2, q3, q4, q5, q6."),
]


@pytest.mark.parametrize("header, row, issue", BAD, ids=["doubled", "q-beyond-dof", "misspelt", "extra-field", "short-row", "seed-columns-partial",
                                                         "seed-row-partial", "seed-outside-limits", "unclosed-quote", "empty", "infinite", "beyond-a-kilometre", "infinite-in-mm",
                                                         "not-echoed"])
def test_a_mistake_in_the_targets_is_one_located_message(puma, header, row, issue):
    loaded, pose = puma
    text = header + "\n" + row.format(pose=",".join(pose), pose_short=",".join(pose[:5])) + "\n"
    with pytest.raises(SpecError) as raised:
        compensate(loaded, None, text, "targets")
    assert [str(i) for i in raised.value.issues] == [f"targets:{issue}"]
    assert "secret" not in str(raised.value)


def test_a_repeated_target_name_is_refused_at_its_line(puma):
    """Names label the commands: a name given twice, or a name that is an unnamed row's number, is a located mistake."""
    loaded, pose = puma
    rows = [f"{n},{','.join(pose)}" for n in ("a", "b", "a", "", "4", "b")]
    with pytest.raises(SpecError) as raised:
        compensate(loaded, None, "name,x,y,z,rx,ry,rz\n" + "\n".join(rows) + "\n", "targets")
    assert [str(i) for i in raised.value.issues] == [f"targets:{line}: name: the name repeats line {first}'s: each target names one command"
                                                     for line, first in ((4, 2), (6, 5), (7, 3))]


def test_a_bom_and_crlf_keep_the_names_and_a_seed_in_the_limits_reaches(tmp_path, puma):
    """A spreadsheet's UTF-8 export (BOM, CRLF): the names stay names; seeded 3 deg off or not seeded, the reachable
    target is reached at Q. Through the command: exit 0, and exit 1 with one located line for a seed outside."""
    loaded, pose = puma
    targets = tmp_path / "targets.csv"
    rows = ["name,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6", f"seeded,{','.join(pose)},{SEED}", f"unseeded,{','.join(pose)},,,,,,"]
    targets.write_bytes(b"\xef\xbb\xbf" + "\r\n".join(rows[:2]).encode() + b"\r\n")
    out = tmp_path / "commands.csv"
    done = armcal_cli("compensate", SPECS / "puma560_dh.yaml", "--targets", targets, "--out", out)
    assert done.returncode == 0, done.stderr
    written = list(csv.DictReader(out.read_text().splitlines()))
    assert [r["name"] for r in written] == ["seeded"] and written[0]["status"] == "ok"
    np.testing.assert_allclose([float(written[0][f"q{i}"]) for i in range(1, 7)], Q, atol=1e-8)

    text, unreached, _, _ = compensate(loaded, None, "\ufeffname,x,y,z,rx,ry,rz\r\n" + f"free,{','.join(pose)}\r\n", "targets")
    assert not unreached and next(csv.DictReader(text.splitlines()))["name"] == "free"

    targets.write_text("\r\n".join([rows[0], f"outside,{','.join(pose)},{SEED.replace('153', '230')}"]) + "\r\n")
    refused = armcal_cli("compensate", SPECS / "puma560_dh.yaml", "--targets", targets, "--out", out, "--force")
    assert refused.returncode == 1 and "Traceback" not in refused.stderr
    assert f"{targets}:2:10: q3: 230 deg lies outside joint 3's limits" in refused.stderr


def test_targets_not_utf8_are_refused_at_their_line(tmp_path, puma):
    """A Latin-1 export (a name with an accent on line 3) is refused with its line, no traceback, nothing written."""
    _, pose = puma
    targets = tmp_path / "targets.csv"
    targets.write_bytes(f"name,x,y,z,rx,ry,rz\nfirst,{','.join(pose)}\n".encode() + "d\xe9p\xf4t,".encode("latin-1") + ",".join(pose).encode() + b"\n")
    out = tmp_path / "commands.csv"
    refused = armcal_cli("compensate", SPECS / "puma560_dh.yaml", "--targets", targets, "--out", out)
    assert refused.returncode == 1 and "Traceback" not in refused.stderr and not out.exists()
    assert f"{targets}:3:" in refused.stderr and "not UTF-8" in refused.stderr and "d\ufffdp" not in refused.stderr


def test_the_count_of_targets_reached_counts_records_not_lines(tmp_path, puma):
    """A quoted name holding line breaks is one target: 'wrote ...: 1 target reached' (it had counted 4)."""
    _, pose = puma
    targets = tmp_path / "targets.csv"
    targets.write_text('name,x,y,z,rx,ry,rz\n"a\nb\nc\nd",' + ",".join(pose) + "\n")
    done = armcal_cli("compensate", SPECS / "puma560_dh.yaml", "--targets", targets, "--out", tmp_path / "commands.csv")
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == f"wrote {tmp_path / 'commands.csv'}: 1 target reached"

"""A scripted newcomer session (issue 20): specs written from the docs' snippets for robots armcal does not ship,
simulated, run; every surprise the issue names must print its explanation on the terminal."""

from __future__ import annotations

import re
from pathlib import Path


from conftest import armcal_cli

ROOT = Path(__file__).resolve().parents[1]

# the quickstart's tracker spec (docs/quickstart.md), made a SCARA whose parallel axes' betas are held at 0
SCARA = """\
armcal: 1
robot:
  name: My SCARA
  serial: SC-1
  units: {length: mm, angle: deg}
  convention: dh
  joints:
    - {limits: [-130, 130], theta: 0, d: 200, a: 325, alpha: 0, beta: {value: 0, vary: false}}
    - {limits: [-145, 145], theta: 0, d: 0, a: 225, alpha: 180, beta: {value: 0, vary: false}}
    - {type: prismatic, limits: [0, 200], theta: 0, d: 0, a: 0, alpha: 0, beta: {value: 0, vary: false}}
    - {limits: [-360, 360], theta: 0, d: 50, a: 0, alpha: 0}
  targets:
    reflector: {link: 4, x: 30, y: 0, z: -40}
device:
  type: tracker
  targets: [reflector]
  robot_base: {x: 1500, y: 300, z: -200, rz: 20, ry: 0, rx: 0}
  noise: 0.02
procedure: {type: poses, count: 40, seed: 1}
validation: {type: poses, count: 20, seed: 2}
data: {calibration: calibration.csv, validation: validation.csv}
simulate: {seed: 7, sigma_p: 0.2, sigma_o: 0.02, sigma_e: 0.05}
report: {tasks: []}
"""

# the ball-bar guide's spec (docs/devices/ballbar.md) for the quickstart's arm: spheres and chucks held, as it advises
BALLBAR = """\
armcal: 1
robot:
  name: My arm
  serial: SN-0002
  units: {length: mm, angle: deg}
  convention: dh
  base: {x: 0, y: 0, z: 0, rz: 0, ry: 0, rx: 0}
  joints:
    - {limits: [-360, 360], theta: 0, d: 127.3, a: 0, alpha: 90}
    - {limits: [-180, 0], theta: 0, d: 0, a: -612.0, alpha: 0}
    - {limits: [-160, 160], theta: 0, d: 0, a: -572.3, alpha: 0}
    - {limits: [-360, 360], theta: 0, d: 163.9, a: 0, alpha: 90}
    - {limits: [-360, 360], theta: 0, d: 115.7, a: 0, alpha: -90}
    - {limits: [-360, 360], theta: 0, d: 92.2, a: 0, alpha: 0}
  targets:
    s1: {link: 6, x: {value: 60, vary: false}, y: {value: 0, vary: false}, z: {value: 80, vary: false}}
    s2: {link: 6, x: {value: -30, vary: false}, y: {value: 51.96, vary: false}, z: {value: 80, vary: false}}
    s3: {link: 6, x: {value: -30, vary: false}, y: {value: -51.96, vary: false}, z: {value: 80, vary: false}}
device:
  type: ballbar
  pivots:
    c1: {x: {value: 700, vary: false}, y: {value: 0, vary: false}, z: {value: 0, vary: false}}
    c2: {x: {value: 500, vary: false}, y: {value: 150, vary: false}, z: {value: 0, vary: false}}
    c3: {x: {value: 500, vary: false}, y: {value: -150, vary: false}, z: {value: 0, vary: false}}
  spheres: [s1, s2, s3]
  length: {value: 460, vary: false}
  travel: TRAVEL
  noise: 0.01
procedure:
  type: shells
  pairings:
    - {pivot: c1, sphere: s1}
    - {pivot: c1, sphere: s2}
    - {pivot: c2, sphere: s2}
    - {pivot: c2, sphere: s3}
    - {pivot: c3, sphere: s3}
    - {pivot: c3, sphere: s1}
  latitudes: [20, 50, 80]
  longitudes: 8
data: {calibration: calibration.csv}
simulate: {seed: 3, sigma_p: 0.3, sigma_o: 0.03}
report: {tasks: []}
"""


def _write(folder: Path, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "spec.yaml").write_text(text)
    return folder / "spec.yaml"


def _ok(result) -> str:
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_scara_with_held_betas_names_hayati(tmp_path):
    """Item 1: chi2/dof above the noise after a 'converged' fit -> Hayati's beta on the parallel axes, with its key and line."""
    spec = _write(tmp_path / "scara", SCARA)
    _ok(armcal_cli("simulate", spec))
    out = _ok(armcal_cli("run", spec, "--no-pdf"))
    assert "likely causes of chi2/dof" in out
    first = re.search(r"    1\. (.*)", out).group(1)
    assert first.startswith("Hayati's beta of the parallel axes 1 and 2 (j1.beta")
    assert "[robot.joints[0].beta (j1), spec.yaml:8]" in first
    assert "the declared noise (device.noise)" in out
    # item 2: validate's free = run's identified + not identifiable, row by row
    validate = _ok(armcal_cli("validate", spec))
    total, free, held = map(int, re.search(r"parameters (\d+) \((\d+) free, (\d+) held by the spec\)", validate).groups())
    assert total == free + held
    before = {m[0]: (int(m[1]), int(m[2])) for m in re.findall(r"^ {13}(\w+) +(\d+) +(\d+) +\d+$", validate, re.M)}
    after = {m[0]: tuple(map(int, m[1:])) for m in re.findall(r"^ {4}(\w+) +(\d+) +(\d+) +(\d+) +(\d+)$", out, re.M)}
    assert set(before) == set(after) and "total" in after
    assert f"identified {after['total'][0]} of {total} parameters" in out
    for row, (identified, unidentifiable, spec_held, row_total) in after.items():
        assert identified + unidentifiable + spec_held == row_total
        assert before[row] == (identified + unidentifiable, spec_held), (row, validate, out)


def test_held_spheres_named_and_freeing_them_predicted(tmp_path):
    """Item 1: the ball-bar guide's held sphere positions: each sphere named with its key; freeing all predicted near 1."""
    spec = _write(tmp_path / "bb", BALLBAR.replace("TRAVEL", "20"))
    _ok(armcal_cli("simulate", spec))
    out = _ok(armcal_cli("run", spec, "--no-pdf"))
    causes = re.findall(r"    \d\. (.*)", out)
    assert all(f"target s{i}'s position held by the spec" in "\n".join(causes[:3]) for i in (1, 2, 3)), out
    assert "[robot.targets.s2.{x, y, z}, spec.yaml:17]" in out
    together = float(re.search(r"all 3 freed together: chi2/dof ([0-9.]+)", out).group(1))
    assert together < 1.5


def test_ballbar_drops_and_lost_readings_counted_with_reasons(tmp_path):
    """Item 1: planning drops per reason with latitude/longitude; readings lost to the bar's travel counted."""
    text = BALLBAR.replace("TRAVEL", "2").replace("x: {value: 700, vary: false}", "x: {value: 1500, vary: false}")
    # the base joint held within +-30 deg: the points the pivots c2 and c3 put beside the robot need j1 beyond it
    # on every inverse kinematics branch (the joint every solution leaves is named, whichever solutions are found)
    text = text.replace("{limits: [-360, 360], theta: 0, d: 127.3", "{limits: [-30, 30], theta: 0, d: 127.3")
    spec = _write(tmp_path / "bb", text)
    out = _ok(armcal_cli("simulate", spec))
    assert re.search(r"calibration: \d+ samples of 144 planned; \d+ planned poses dropped; \d+ readings lost on the simulated robot", out), out
    assert re.search(r"c1-s1: \d+ (beyond the arm's reach|pivot out of reach) \(lat 20: lon 0", out), out
    assert re.search(r"c2-s2: \d+ joint limit \(j1\)", out) and set(re.findall(r"joint limit \(([^)]*)\)", out)) == {"j1"}, out
    assert "readings outside the bar's travel (device.travel 2 mm: within 1 mm of mid-travel)" in out
    assert "look at: " in out and "robot.joints[].limits" in out and "device.travel" in out


def test_simulate_out_elsewhere_says_where_run_reads_and_fake_times_warned(tmp_path):
    """Item 3: --out elsewhere names the files run reads and the data section to use; pasted readings keep a fake t."""
    spec = _write(tmp_path / "arm", SCARA)
    out = _ok(armcal_cli("simulate", spec, "--out", tmp_path / "sim"))
    assert "note: `armcal run` does not read these files" in out
    assert "Point the spec at them with data: {calibration: ../sim/calibration.csv, validation: ../sim/validation.csv}" in out
    out = _ok(armcal_cli("simulate", spec))
    assert f"`armcal run {spec}` reads them" in out and "truth.json beside them marks these files" in out
    csv = spec.parent / "calibration.csv"
    lines = csv.read_text().splitlines()
    fields = lines[1].split(",")
    fields[6] = f"{float(fields[6]) + 0.001:.6f}"  # a 'real' reading pasted into the layout
    csv.write_text("\n".join([lines[0], ",".join(fields), *lines[2:]]) + "\n")
    out = _ok(armcal_cli("run", spec, "--no-pdf"))
    assert "warning: calibration.csv: its t column is 0, 10, 20, ... s, every 10 s, as `armcal simulate` writes it" in out

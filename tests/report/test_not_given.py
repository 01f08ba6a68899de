"""`armcal run` on the spec `armcal new` writes, simulated and left as written: results.json's `spec.placeholders` and
`warnings` name every stand-in, and the certificate states each one not given in the spec, beside the instrument's
identity the spec does not give either. The oracle is the spec's own sections; a spec without stand-ins has no such
rows (tests/report/test_certificate.py's golden certificate, whose results.json has no `placeholders`)."""

import html
import json

from conftest import armcal_cli

STANDS_FOR = {"robot.serial": "the robot's serial number", "robot.targets": "the points the instrument measures on the robot",
              "device": "the measuring instrument's placement, targets and noise", "procedure": "the calibration poses as measured",
              "validation": "the held-out poses as measured"}


def test_the_certificate_states_each_stand_in_not_given(tmp_path):
    spec = tmp_path / "cell.yaml"
    assert armcal_cli("new", "--robot", "ur3e", "--device", "tracker", "--out", spec).returncode == 0
    assert "\nvalidation:\n" in spec.read_text()
    assert armcal_cli("simulate", spec, "--out", tmp_path).returncode == 0
    done = armcal_cli("run", spec, "--out", tmp_path / "out", "--no-pdf")
    assert done.returncode == 0, done.stderr
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["spec"]["placeholders"] == [{"field": field, "stands_for": what} for field, what in STANDS_FOR.items()]
    assert [w.split(":")[0] for w in results["warnings"] if "the stand-in armcal wrote" in w] == list(STANDS_FOR)
    assert all(f"  warning: {field}: the stand-in armcal wrote" in done.stdout for field in STANDS_FOR)
    page = html.unescape((tmp_path / "out" / "certificate.html").read_text())
    assert "serial SERIAL-NUMBER (not given in the spec: armcal's stand-in)" in page
    for field, what in STANDS_FOR.items():
        assert f"<tr><td>{what[0].upper() + what[1:]}</td><td>not given in the spec: armcal's stand-in ({field}) is unchanged</td></tr>" in page

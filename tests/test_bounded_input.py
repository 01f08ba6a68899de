"""Unbounded or odd input ends fast with one located message, never a traceback, and never echoes a file's content."""

import os

import pytest
from conftest import ROOT, armcal_process, copy_example

EXAMPLE = ROOT / "examples" / "hidden_harmonic"
SECRET = "armcal-test-secret-3f9a"


@pytest.fixture()
def workspace(tmp_path):
    return copy_example("hidden_harmonic", tmp_path)


def armcal(*args, timeout=120):
    """The CLI with a secret in its environment (no message may show it)."""
    return armcal_process(*args, timeout=timeout, env={**os.environ, "ARMCAL_TEST_SECRET": SECRET})


def refused(result, *phrases):
    assert result.returncode == 1, (result.returncode, result.stdout, result.stderr)
    assert "Traceback" not in result.stderr and SECRET not in result.stderr + result.stdout
    for phrase in phrases:
        assert phrase in result.stderr, result.stderr


@pytest.fixture()
def fifo(tmp_path):
    path = tmp_path / "fifo"
    os.mkfifo(path)
    return path


def test_a_spec_that_is_a_stream_a_device_or_a_pipe(fifo):
    for path in ("/dev/zero", "/dev/urandom", "/proc/self/environ"):
        refused(armcal("validate", path), "cannot read the spec file", "holds no input files")
    refused(armcal("validate", fifo), "not a regular file")


def test_a_spec_too_large_too_deep_or_with_a_huge_number(tmp_path):
    big = tmp_path / "big.yaml"
    big.write_text("armcal: 1\nvalues: [" + ", ".join(["1"] * 1_000_000) + "]\n")
    refused(armcal("validate", big), "more than the 256 KiB a spec file may have")
    deep = tmp_path / "deep.yaml"
    deep.write_text("armcal: 1\nrobot: " + "[" * 500 + "]" * 500 + "\n")
    refused(armcal("validate", deep), "nested too deeply")
    huge = tmp_path / "huge.yaml"
    huge.write_text("armcal: 1\nrobot: {name: " + "9" * 5000 + "}\n")
    refused(armcal("validate", huge), "a value cannot be read")


@pytest.mark.parametrize("value", ["1e-320", "1e308"])
def test_numbers_outside_what_can_be_computed(workspace, value):
    text = (workspace / "spec.yaml").read_text()
    text = text.replace("noise: 0.0025", f"noise: {value}") if value == "1e-320" else text.replace("reflector: {link: 6, x: 5.0", f"reflector: {{link: 6, x: {value}")
    (workspace / "spec.yaml").write_text(text)
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "lies outside what armcal computes with")


def test_data_files_that_are_not_data(workspace, fifo):
    spec = workspace / "spec.yaml"
    original = spec.read_text()
    for path, phrase in (("/dev/zero", "holds no input files"), ("/proc/self/environ", "holds no input files"), (str(fifo), "not a regular file"),
                         (str(workspace), "it is a folder")):
        spec.write_text(original.replace("calibration: calibration.csv", f"calibration: {path}"))
        refused(armcal("run", spec, "--no-pdf"), "cannot read the data file", phrase)


@pytest.mark.parametrize("encoding", ["latin-1", "utf-16"])
def test_data_in_another_encoding(workspace, encoding):
    text = (workspace / "calibration.csv").read_text().replace("sample,", "sample\u00e9,", 1)
    (workspace / "calibration.csv").write_bytes(text.encode(encoding))
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "calibration.csv:1", "not UTF-8 text")


def test_a_csv_field_too_long_and_too_many_rows(workspace):
    lines = (workspace / "calibration.csv").read_text().splitlines()
    (workspace / "calibration.csv").write_text("\n".join(lines[:5] + ['"' + "x" * 200_000 + '"'] + lines[5:]) + "\n")
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "calibration.csv:", "not a CSV row")
    (workspace / "calibration.csv").write_text("\n".join([lines[0]] + [lines[1]] * 200_001) + "\n")
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "more than 200000 samples")


@pytest.mark.parametrize("content", ["", "[]", "{\"data_sha256\": 3}", "folder"])
def test_a_truth_record_that_is_not_one(workspace, content):
    truth = workspace / "truth.json"
    if content == "folder":
        truth.mkdir()
        phrase = "it is a folder"
    else:
        truth.write_text(content)
        phrase = "not a truth record"
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "truth.json", phrase)


def test_a_truth_record_that_is_not_one_is_refused_before_the_fit(workspace, monkeypatch):
    """Every input is read, and refused, before the work: a broken record ends the run before its fit, not after."""
    import armcal.commands.run as pipeline
    from armcal.support.errors import UserError

    (workspace / "truth.json").write_text("[]")
    monkeypatch.setattr(pipeline, "identify_and_diagnose", lambda *args: pytest.fail("the fit ran before the inputs were all read"))
    with pytest.raises(UserError, match="truth.json: not a truth record"):
        pipeline.run(workspace / "spec.yaml", workspace / "out", pdf=False)


def test_import_ipa_of_an_empty_file_or_into_a_spec_without_a_tracker(tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    refused(armcal("import-ipa", ROOT / "specs" / "ur10.yaml", empty, "--out", tmp_path / "out.csv"), "the file is empty")
    refused(armcal("import-ipa", ROOT / "specs" / "puma560_dh.yaml", empty, "--out", tmp_path / "out.csv", "--target", "sparker6"),
            "the spec's device must be a tracker")


@pytest.mark.parametrize("address", ["tcp://", "nonsense", "tcp://host:99999", "a b:1"])
def test_a_malformed_scheduler_address_is_refused_at_once(tmp_path, address):
    result = armcal("batch", EXAMPLE / "spec.yaml", "--out", tmp_path, "--no-pdf", "--scheduler", address)
    refused(result, "is not a scheduler address")


@pytest.mark.parametrize("address", ["tcp://", "nonsense", "tcp://host:99999", "a b:1"])
def test_a_malformed_scheduler_address_is_refused_before_any_connection(monkeypatch, address):
    """'At once' without a clock: the address is refused before Dask is asked to connect (its timeout: 30 s)."""
    from armcal.commands import workers
    from armcal.support.errors import UserError

    monkeypatch.setattr(workers, "_on_dask", lambda *args: pytest.fail("a connection was tried"))
    with pytest.raises(UserError, match="is not a scheduler address"):
        workers.run_tasks(abs, [1], scheduler=address)


def test_studies_and_procedures_of_unbounded_size(workspace):
    result = armcal("montecarlo", workspace / "spec.yaml", "--runs", "1000000000")
    assert result.returncode == 2 and "Traceback" not in result.stderr
    spec = ROOT / "examples" / "goswami_ballbar" / "spec.yaml"
    (workspace / "shells.yaml").write_text(spec.read_text().replace("longitudes: 23", "longitudes: 3000000"))
    refused(armcal("validate", workspace / "shells.yaml"), "longitudes")


@pytest.mark.parametrize("args, phrase", [
    (("montecarlo", "--poses", "99999999999999999999"), "each from 1 to 10000"),
    (("montecarlo", "--poses", "5000000"), "each from 1 to 10000"),
    (("montecarlo", "--poses", ",".join(str(n) for n in range(10, 40))), "up to 20 numbers of poses"),
    (("plan", "--poses", "10", "--runs", "20000", "--out", "p.csv"), "to 10000 simulated robots"),
])
def test_count_options_have_upper_bounds(workspace, args, phrase):
    """Every count a user types is checked against an upper bound before anything is allocated (issue 30 class 6)."""
    command, *rest = args
    rest = [str(workspace / a) if a.endswith(".csv") else a for a in rest]
    refused(armcal(command, workspace / "spec.yaml", *rest), phrase)


@pytest.mark.parametrize("tamper", ["drop a link error", "a NaN encoder error", "an effect of no known type", "no parameters"])
def test_a_tampered_truth_record_is_refused_not_a_traceback(workspace, tamper):
    """A truth.json whose hashes still match the data but whose robot was edited (issue 30 class 10): one message."""
    import json

    assert armcal("simulate", workspace / "spec.yaml", "--out", workspace, "--force").returncode == 0
    path = workspace / "truth.json"
    record = json.loads(path.read_text())
    if tamper == "drop a link error":
        record["link_errors"] = record["link_errors"][:-1]
    elif tamper == "a NaN encoder error":
        record["encoder_errors"][0] = float("nan")
    elif tamper == "an effect of no known type":
        record["hidden_effects"] = [{"type": "no_such_effect", "joint": 2}]
    else:
        del record["parameters"]
    path.write_text(json.dumps(record))
    refused(armcal("run", workspace / "spec.yaml", "--no-pdf"), "truth.json", "not a truth record")

"""The certificate reads only files inside its folders, fails on a template's mistake with file:line, refuses a
tampered results.json with one message, and the same spec gives the same plots and certificate."""

import json
import os
import re
import shutil
from pathlib import Path

import matplotlib
import pytest
from conftest import HANG, ROOT, TESTS, armcal_process
from test_first_run import wait_for_builds

from armcal.support.errors import UserError
from armcal.report.context import certificate_context
from armcal.report.plots import draw_plots
from armcal.report.pdf import TemplateFetcher
from armcal.report.render import PACKAGED, TEMPLATE, certificate_files, render_html
from armcal.results.schema import Evidence, Results

GOLDEN = TESTS / "data" / "golden"
OUTSIDE = Path("/etc/hostname")  # any readable file outside the folders


def golden() -> dict:
    return json.loads((GOLDEN / "results.json").read_text())


@pytest.fixture()
def example(tmp_path) -> Path:
    """A copy of the Goswami ball-bar example; returns its spec."""
    shutil.copytree(ROOT / "examples" / "goswami_ballbar", tmp_path / "ex")
    return tmp_path / "ex" / "spec.yaml"


def use_templates(spec: Path, files: dict[str, str]) -> Path:
    """The spec's report.template folder 'templates' with ``files`` (the spec ends in its report section)."""
    folder = spec.parent / "templates"
    folder.mkdir()
    for name, text in files.items():
        (folder / name).write_text(text)
    with open(spec, "a") as stream:
        stream.write("  template: templates\n")
    return folder


def assert_user_error(result, *expected: str) -> None:
    assert result.returncode == 1, (result.returncode, result.stderr)
    assert result.stderr.startswith("error: ") and "Traceback" not in result.stderr, result.stderr
    for text in expected:
        assert text in result.stderr, (text, result.stderr)


# Local files into the certificate


def test_run_refuses_a_template_that_includes_a_link_to_a_file_outside(example, tmp_path):
    folder = use_templates(example, {TEMPLATE: "<p>{{ number }}</p>\n{% include 'host.html' %}\n"})
    (folder / "host.html").symlink_to(OUTSIDE)
    result = armcal_process("run", example, "--out", tmp_path / "out", "--no-pdf")
    assert_user_error(result, f"{TEMPLATE}:2:", "host.html leads outside")
    assert OUTSIDE.read_text().strip() not in result.stdout + result.stderr
    assert not (tmp_path / "out" / "certificate.html").exists()


@pytest.mark.parametrize("kind", ["link out", "link in a subfolder", "fifo", "device", "too large", "not utf-8"])
def test_a_template_file_must_be_a_small_regular_text_file_inside_its_folder(tmp_path, kind):
    (tmp_path / TEMPLATE).write_text("{% include 'part.html' %}")
    part = tmp_path / "part.html"
    if kind == "link out":
        part.symlink_to("/etc/passwd")
    elif kind == "link in a subfolder":
        (tmp_path / "sub").symlink_to("/etc")
        (tmp_path / TEMPLATE).write_text("{% include 'sub/passwd' %}")
    elif kind == "fifo":
        os.mkfifo(part)
    elif kind == "device":
        part.symlink_to("/dev/zero")
    elif kind == "too large":
        part.write_text("x" * (1 << 20) + "x")
    else:
        part.write_bytes(b"caf\xe9")
    with pytest.raises(UserError, match=rf"{TEMPLATE}:1: .*(leads outside|not a regular file|larger than 1 MiB|not UTF-8)") as refused:
        render_html(certificate_context(Results.model_validate(golden()), {}), [tmp_path, PACKAGED])
    assert "root:" not in str(refused.value)


def test_a_link_inside_the_folder_to_a_file_of_the_folder_is_followed(tmp_path):
    (tmp_path / "real.html").write_text("<p>{{ number }}</p>")
    (tmp_path / TEMPLATE).symlink_to(tmp_path / "real.html")
    assert render_html(certificate_context(Results.model_validate(golden()), {}), [tmp_path, PACKAGED]) == f"<p>{golden()['report']['certificate_number']}</p>"


@pytest.fixture()
def results_folder(tmp_path) -> Path:
    folder = tmp_path / "set"
    folder.mkdir()
    shutil.copy(GOLDEN / "results.json", folder / "results.json")
    return folder


def list_plots(folder: Path, names: list[str]) -> Path:
    results = json.loads((folder / "results.json").read_text())
    results["diagnosis"]["plots"] = names
    (folder / "results.json").write_text(json.dumps(results))
    return folder / "results.json"


@pytest.mark.parametrize("kind", ["parent", "absolute", "device", "fifo", "link out", "too large"])
def test_report_embeds_no_plot_from_outside_its_folder(results_folder, kind):
    name = {"parent": "../../../../../../etc/passwd", "absolute": "/etc/passwd", "device": "/dev/zero"}.get(kind, "plot.svg")
    if kind == "fifo":
        os.mkfifo(results_folder / name)
    elif kind == "link out":
        (results_folder / name).symlink_to("/etc/passwd")
    elif kind == "too large":
        (results_folder / name).write_bytes(b"<svg/>" + b" " * (10 << 20))
    result = armcal_process("report", list_plots(results_folder, [name]), "--no-pdf", timeout=120)
    assert_user_error(result, f"lists the plot '{name}'")
    assert "root:" not in result.stderr
    assert not (results_folder / "certificate.html").exists()


def test_report_leaves_out_a_listed_plot_that_is_missing_and_embeds_the_others(results_folder):
    (results_folder / "residual_histogram.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg"/>')
    result = armcal_process("report", list_plots(results_folder, ["residual_histogram.svg", "residual_vs_t.svg"]), "--no-pdf")
    assert result.returncode == 0, result.stderr
    assert (results_folder / "certificate.html").read_text().count("data:image/svg+xml;base64,") == 1


def test_a_user_stylesheet_is_applied_in_the_pdf(example, tmp_path):
    use_templates(example, {"certificate.css": '@page { size: A4; margin: 20mm; @top-center { content: "STYLED BY OUR LAB"; } }\n'})
    result = armcal_process("run", example, "--out", tmp_path / "out")
    assert result.returncode == 0, result.stderr
    from pypdf import PdfReader

    text = " ".join(page.extract_text() for page in PdfReader(tmp_path / "out" / "certificate.pdf").pages)
    assert "STYLED BY OUR LAB" in text


def test_the_packaged_stylesheet_serves_a_user_folder_without_one(tmp_path):
    response = TemplateFetcher([tmp_path, PACKAGED]).fetch((tmp_path.resolve() / "certificate.css").as_uri())
    assert response.read() == (PACKAGED / "certificate.css").read_bytes()


@pytest.mark.parametrize(
    "url",
    ["file:///etc/passwd", "file:///{folder}/../../../etc/passwd", "file:///{folder}/link.css", "file:///{folder}/fifo.css", "file://host/{folder}/a.css", "https://example.invalid/a.css"],
)
def test_the_fetcher_refuses_outside_files_links_fifos_and_the_network(tmp_path, url):
    (tmp_path / "link.css").symlink_to("/etc/passwd")
    os.mkfifo(tmp_path / "fifo.css")
    with pytest.raises(ValueError):
        TemplateFetcher([tmp_path, PACKAGED]).fetch(url.format(folder=str(tmp_path.resolve()).lstrip("/")))


def test_a_template_asking_for_a_local_file_fails_the_pdf(tmp_path):
    (tmp_path / TEMPLATE).write_text('<p>{{ number }}</p><img src="file:///etc/passwd">')
    with pytest.raises(UserError, match="may not fetch file:///etc/passwd"):
        certificate_files(Results.model_validate(golden()), {}, True, tmp_path)


# Reproducibility


def masked(text: str) -> str:
    """The creation time and what derives from it (issue date, certificate number) masked."""
    return re.sub(r"\d{4}-\d\d-\d\d(T\d\d:\d\d:\d\dZ)?", "<created>", text)


def test_two_runs_of_one_spec_give_the_same_artifacts_but_the_creation_time(tmp_path):
    """The first run on a cold cache uses CasADi's virtual machine (ARMCAL_COMPILE=background builds the library
    meanwhile), the second the compiled library: the same numbers, bit for bit. On the theodolite example, whose
    libraries compile in 5 s of gcc (the ball-bar's in 20 s)."""
    shutil.copytree(ROOT / "examples" / "theodolite", tmp_path / "ex")
    example = tmp_path / "ex" / "spec.yaml"
    environment = {**os.environ, "ARMCAL_CACHE": str(tmp_path / "cache"), "ARMCAL_COMPILE": "background"}
    assert armcal_process("run", example, "--out", tmp_path / "one", "--no-pdf", env=environment).returncode == 0
    wait_for_builds(tmp_path / "cache", timeout=4 * HANG)  # the builds, one after another (a hang guard only)
    assert armcal_process("run", "./ex/../ex/spec.yaml", "--out", "two", "--no-pdf", cwd=tmp_path, env=environment).returncode == 0
    one, two = tmp_path / "one", tmp_path / "two"
    svgs = sorted(p.name for p in one.glob("*.svg"))
    assert svgs and svgs == sorted(p.name for p in two.glob("*.svg"))
    for name in svgs:
        assert (one / name).read_bytes() == (two / name).read_bytes(), name
    for name in ("certificate.html", "results.json", "calibrated.yaml"):
        assert masked((one / name).read_text()) == masked((two / name).read_text()), name
    assert json.loads((one / "results.json").read_text())["spec"]["path"] == str(example.resolve())


EVIDENCE = Evidence.model_validate({
    "unit": "mm",
    "joints": [{"joint": 1, "x": [0.0, 90.0], "before": [1.0, 2.0], "after": [0.5, 0.4], "count": [4, 4]}],
    "joint_axes": ["joint angle (deg)"],
    "gravity_torque": [],
    "keys": [{"key": "sphere1", "n": 8, "rms_before": 1.0, "rms_after": 0.5}],
    "magnitude": "RMS over each sample's readings",
    "histogram": {"edges": [-1.0, 0.0, 1.0], "counts": [3, 5], "expected": [4.0, 4.0], "noise_sigma": 0.5, "mean": 0.1, "std": 0.4},
})


def test_drawing_plots_twice_gives_the_same_svg_and_leaves_rcparams_alone():
    before = dict(matplotlib.rcParams)
    first = draw_plots(EVIDENCE, "mm")
    assert first == draw_plots(EVIDENCE, "mm") and "<dc:date>" not in first["residual_histogram.svg"]
    assert dict(matplotlib.rcParams) == before


# Located messages instead of tracebacks


def test_run_reports_a_template_syntax_error_with_file_and_line(example, tmp_path):
    folder = use_templates(example, {TEMPLATE: "<p>{{ number }}</p>\n{% if %}\n"})
    result = armcal_process("run", example, "--out", tmp_path / "out", "--no-pdf")
    assert_user_error(result, f"{folder / TEMPLATE}:2: ")


@pytest.mark.parametrize(
    "source, line, message",
    [
        ("a\n{{ nothing }}", 2, "'nothing' is undefined"),
        ("a\nb\n{% include 'missing.html' %}", 3, "no template 'missing.html'"),
        ("{% for i in range(10**9) %}x{% endfor %}", 1, "Range too big"),
        ("{% for i in range(100000) %}{% for j in range(100000) %}{% endfor %}{% endfor %}", 1, "range() items"),
        ("{% for i in range(100000) %}{% for j in range(100) %}{{ 'x' * 100000 }}{% endfor %}{% endfor %}", 1, "MiB of text"),
        ("{% macro m() %}{% for i in range(100000) %}{{ 'x' * 100000 }}{% endfor %}{% endmacro %}{{ m() }}", 1, "MiB of text"),
        ("{{ 'x' * 10**9 }}", 1, "would repeat"),
        ("{{ 10**10**10 }}", 1, "too large"),
        ("{% macro f() %}{{ f() }}{% endmacro %}\n{{ f() }}", 1, "recursion"),
        ("\n\n{{ 1 / 0 }}", 3, "division by zero"),
        ("{{ number.__class__ }}", 1, "unsafe"),
    ],
)
def test_every_template_error_names_the_file_and_line(tmp_path, source, line, message):
    (tmp_path / TEMPLATE).write_text(source)
    with pytest.raises(UserError) as failed:
        render_html(certificate_context(Results.model_validate(golden()), {}), [tmp_path, PACKAGED])
    assert str(failed.value).startswith(f"{tmp_path / TEMPLATE}:{line}: ") and message in str(failed.value), str(failed.value)


def test_an_error_in_an_included_template_names_that_file(tmp_path):
    (tmp_path / TEMPLATE).write_text("{% include 'part.html' %}")
    (tmp_path / "part.html").write_text("a\nb\n{% endif %}")
    with pytest.raises(UserError, match=rf"^{tmp_path / 'part.html'}:3: "):
        render_html(certificate_context(Results.model_validate(golden()), {}), [tmp_path, PACKAGED])


def tamper(path: Path, kind: str) -> None:
    results = golden()
    if kind == "a list":
        path.write_text(json.dumps([results]))
    elif kind == "missing key":
        del results["report"]
        path.write_text(json.dumps(results))
    elif kind == "wrong type":
        results["robot"]["dof"] = "six"
        path.write_text(json.dumps(results))
    elif kind == "free-form block":
        results["evaluation"]["grid_task"] = {"indices": [5]}
        path.write_text(json.dumps(results))
    elif kind == "not utf-8":
        path.write_bytes(json.dumps(results).encode().replace(b"Example", b"Ex\xe9mple"))
    elif kind == "not json":
        path.write_text("{")
    elif kind == "deep":
        path.write_text("[" * 100_000 + "]" * 100_000)
    elif kind == "huge":
        path.write_bytes(b" " * (16 << 20) + json.dumps(results).encode())
    else:
        os.mkfifo(path)


@pytest.mark.parametrize("kind", ["a list", "missing key", "wrong type", "free-form block", "not utf-8", "not json", "deep", "huge", "fifo"])
def test_report_on_a_tampered_results_file_gives_one_message(tmp_path, kind):
    path = tmp_path / "results.json"
    tamper(path, kind)
    result = armcal_process("report", path, "--no-pdf", timeout=120)
    assert_user_error(result, f"error: {path}")
    assert len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "body, said",
    [
        ("{{ 'x'.center(10**9) }}", "a width above 1000000 given to a string method"),
        ("{{ '%0999999999d' % 1 }}", "a width above 1000000 in a % format"),
        ("{% set s = namespace(v='ab') %}{% for i in range(60) %}{% set s.v = s.v ~ s.v %}{% endfor %}{{ s.v }}", "more than 256 MiB of text"),
    ],
)
def test_widths_and_doubling_concatenations_are_bounded(tmp_path, body, said):
    (tmp_path / "certificate.html.j2").write_text(body)
    with pytest.raises(UserError, match=said):
        render_html({}, [tmp_path])

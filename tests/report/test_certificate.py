"""The certificate: golden HTML for a fixed results file, strict rendering, and no reach outside its job."""

import json
import os
import shutil

import jinja2
import pytest
from conftest import TESTS, armcal_cli

from armcal.support.errors import UserError
from armcal.report.context import certificate_context
from armcal.report.pdf import TemplateFetcher
from armcal.report.render import PACKAGED, TEMPLATE, certificate_files, render_html, write_files
from armcal.results.schema import Results

GOLDEN = TESTS / "data" / "golden"


def _results() -> dict:
    return json.loads((GOLDEN / "results.json").read_text())


def test_golden_html(tmp_path):
    """Set ARMCAL_REFRESH_GOLDEN=1 to accept an intended change of the certificate."""
    html = render_html(certificate_context(Results.model_validate(_results()), {}), [PACKAGED])
    if os.environ.get("ARMCAL_REFRESH_GOLDEN"):
        (GOLDEN / "certificate.html").write_text(html)
    assert html == (GOLDEN / "certificate.html").read_text()


def test_a_missing_value_fails_the_render(tmp_path):
    context = certificate_context(Results.model_validate(_results()), {})
    del context["unit"]
    with pytest.raises(UserError, match=rf"^{PACKAGED / TEMPLATE}:\d+: 'unit' is undefined$") as failed:
        render_html(context, [PACKAGED])
    assert isinstance(failed.value.__cause__, jinja2.UndefinedError)


def test_injected_markup_prints_as_text_and_reads_no_file(tmp_path, monkeypatch):
    results = _results()
    attack = '<img src="file:///etc/passwd">'
    results["report"]["customer"] = attack
    results["robot"]["name"] = '<link rel="stylesheet" href="http://example.invalid/x.css">'
    fetched = []
    original = TemplateFetcher.fetch

    def spy(self, url, headers=None):
        fetched.append(url)
        return original(self, url, headers)

    monkeypatch.setattr(TemplateFetcher, "fetch", spy)
    write_files(tmp_path, certificate_files(Results.model_validate(results), {}))
    html = (tmp_path / "certificate.html").read_text()
    assert attack not in html and "&lt;img src=&#34;file:///etc/passwd&#34;&gt;" in html
    assert all(url.startswith("file://" + str(PACKAGED)) or url.startswith("data:") for url in fetched), fetched
    from pypdf import PdfReader

    text = " ".join(p.extract_text() for p in PdfReader(tmp_path / "certificate.pdf").pages)
    assert "file:///etc/passwd" in text  # printed, as text


@pytest.mark.parametrize("url", ["file:///etc/passwd", "http://example.invalid/a.png", "https://example.invalid/", "ftp://x/y"])
def test_the_fetcher_refuses_anything_outside_the_templates(url):
    with pytest.raises(ValueError):
        TemplateFetcher([PACKAGED]).fetch(url)


def test_the_fetcher_serves_the_stylesheet():
    response = TemplateFetcher([PACKAGED]).fetch((PACKAGED / "certificate.css").as_uri())
    assert response is not None


def test_report_rerenders_from_results_alone(tmp_path):
    shutil.copy(GOLDEN / "results.json", tmp_path / "results.json")
    result = armcal_cli("report", tmp_path / "results.json")
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "certificate.pdf").stat().st_size > 10_000


def test_user_templates_are_searched_first(tmp_path):
    (tmp_path / "certificate.html.j2").write_text("<p>{{ number }} by our lab</p>")
    html = render_html(certificate_context(Results.model_validate(_results()), {}), [tmp_path, PACKAGED])
    assert html == f"<p>{_results()['report']['certificate_number']} by our lab</p>"


def test_user_templates_are_sandboxed(tmp_path):
    """A template cannot climb to Python internals (e.g. to run commands)."""
    from jinja2.exceptions import SecurityError

    (tmp_path / "certificate.html.j2").write_text("{{ number.__class__.__mro__[1].__subclasses__() }}")
    with pytest.raises(UserError, match=r"certificate.html.j2:1: access to attribute '__class__'") as failed:
        render_html(certificate_context(Results.model_validate(_results()), {}), [tmp_path, PACKAGED])
    assert isinstance(failed.value.__cause__, SecurityError)

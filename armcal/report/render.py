"""Render the certificate: Jinja2 (autoescaped, strict) to HTML, WeasyPrint to PDF with a closed URL fetcher."""

from __future__ import annotations

import json
from pathlib import Path
from urllib.parse import unquote, urlparse

import jinja2
from jinja2.sandbox import SandboxedEnvironment
from weasyprint import HTML
from weasyprint.urls import URLFetcher

from armcal.errors import UserError
from armcal.fileio import write_bytes_atomic
from armcal.report.context import certificate_context

PACKAGED = Path(__file__).resolve().parent.parent / "templates"
TEMPLATE = "certificate.html.j2"


def template_folders(user_folder: Path | None) -> list[Path]:
    """A user's template folder first, then the packaged one."""
    return ([user_folder] if user_folder else []) + [PACKAGED]


class TemplateFetcher(URLFetcher):
    """Serves data: URIs and files inside the template folders; refuses everything else (no file://, no network)."""

    def __init__(self, folders: list[Path]):
        super().__init__(allowed_protocols={"data", "file"}, fail_on_errors=False)
        self.folders = [f.resolve() for f in folders]

    def fetch(self, url, headers=None):
        if url.startswith("file:"):
            path = Path(unquote(urlparse(url).path)).resolve()
            if not any(path.is_relative_to(folder) for folder in self.folders):
                raise ValueError(f"the certificate may not read {url}")
        elif not url.startswith("data:"):
            raise ValueError(f"the certificate may not fetch {url}")
        return super().fetch(url, headers)


def render_html(context: dict, folders: list[Path]) -> str:
    environment = SandboxedEnvironment(  # a user's template cannot reach Python internals
        loader=jinja2.FileSystemLoader([str(f) for f in folders]),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
    )
    return environment.get_template(TEMPLATE).render(**context)


def render_pdf(html: str, folders: list[Path]) -> bytes:
    base = folders[-1]
    return HTML(string=html, base_url=str(base) + "/", url_fetcher=TemplateFetcher(folders)).write_pdf()


def certificate_files(results: dict, plots: dict[str, str], pdf: bool = True, user_templates: Path | None = None) -> dict[str, bytes]:
    """certificate.html (and .pdf), rendered in memory."""
    folders = template_folders(user_templates)
    html = render_html(certificate_context(results, plots), folders)
    files = {"certificate.html": html.encode("utf-8")}
    if pdf:
        files["certificate.pdf"] = render_pdf(html, folders)
    return files


def write_files(folder: Path, files: dict[str, bytes | str]) -> list[Path]:
    """Each file written whole (after everything was rendered: a failure leaves the old set intact)."""
    written = []
    for name, content in files.items():
        path = Path(folder) / name
        write_bytes_atomic(path, content.encode("utf-8") if isinstance(content, str) else content)
        written.append(path)
    return written


def rerender(results_path: Path, pdf: bool = True) -> list[Path]:
    """``armcal report``: the certificate again, from results.json alone (and the plots beside it)."""
    folder = Path(results_path).parent
    try:
        results = json.loads(Path(results_path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise UserError(f"{results_path}: cannot read results ({exc})") from None
    plots = {name: (folder / name).read_text() for name in results["diagnosis"].get("plots", []) if (folder / name).exists()}
    return write_files(folder, certificate_files(results, plots, pdf))

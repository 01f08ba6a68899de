"""Print the certificate's HTML to PDF with WeasyPrint, through a closed URL fetcher (the template folders and data:
URIs only). Its own module because importing WeasyPrint costs seconds: runs with --no-pdf never import it.
"""

from __future__ import annotations

import mimetypes
import os
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path
from urllib.parse import unquote, urlparse

from weasyprint import HTML
from weasyprint.urls import URLFetcher, URLFetcherResponse

from armcal.support.errors import UserError
from armcal.report.render import FOLDER_FILE_LIMIT, read_inside


class TemplateFetcher(URLFetcher):
    """Serves data: URIs and files of the template folders (read with read_inside; a name is looked up in the folder
    its URL names, then in the later ones); refuses any other file:// URL and the network, and remembers each refusal."""

    def __init__(self, folders: list[Path]):
        super().__init__(allowed_protocols={"data"}, fail_on_errors=False)
        self.folders = [Path(f).resolve() for f in folders]
        self.refused: list[str] = []

    def fetch(self, url, headers=None):
        try:
            return self.serve(url, headers)
        except (UserError, ValueError) as exc:
            self.refused.append(str(exc))
            raise ValueError(str(exc)) from None

    def serve(self, url: str, headers=None):
        """A data: URI, or a file:// URL inside one of the folders."""
        parsed = urlparse(url)
        if parsed.scheme == "data":
            return super().fetch(url, headers)
        if parsed.scheme == "file" and parsed.netloc in ("", "localhost"):
            path = Path(os.path.normpath(unquote(parsed.path)))
            for index, folder in enumerate(self.folders):
                if path.is_relative_to(folder):
                    return self.first_of(str(path.relative_to(folder)), self.folders[index:], url)
        shown = ", ".join(map(str, self.folders))
        raise ValueError(f"the certificate may not fetch {url}: it reads only files of its template folders ({shown}) and data: URIs")

    def first_of(self, name: str, folders: list[Path], url: str) -> URLFetcherResponse:
        """File ``name`` of the first of ``folders`` that has it."""
        for folder in folders:
            data = read_inside(folder, name, FOLDER_FILE_LIMIT)
            if data is not None:
                kind = mimetypes.guess_type(name)[0] or "application/octet-stream"
                return URLFetcherResponse((folder / name).as_uri(), data, {"Content-Type": kind})
        raise ValueError(f"the certificate asks for {url}, which is in none of the template folders")


@contextmanager
def source_date(created: str):
    """SOURCE_DATE_EPOCH at the results' creation time while it lasts (unless already set), so that fontTools
    stamps the PDF's subset fonts with that time rather than now: the same results give the same PDF."""
    try:
        epoch = str(int(datetime.fromisoformat(created).timestamp()))
    except ValueError:
        epoch = None
    if epoch is None or "SOURCE_DATE_EPOCH" in os.environ:
        yield
        return
    os.environ["SOURCE_DATE_EPOCH"] = epoch
    try:
        yield
    finally:
        del os.environ["SOURCE_DATE_EPOCH"]


def render_pdf(html: str, folders: list[Path], created: str) -> bytes:
    """The PDF; relative URLs (certificate.css) are looked up in the first folder, a user's, then in the packaged one."""
    fetcher = TemplateFetcher(folders)
    with source_date(created):
        pdf = HTML(string=html, base_url=fetcher.folders[0].as_uri() + "/", url_fetcher=fetcher).write_pdf()
    if fetcher.refused:
        raise UserError(fetcher.refused[0])
    return pdf

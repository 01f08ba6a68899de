"""Render the certificate: Jinja2 (sandboxed, autoescaped, strict, bounded) to HTML; the PDF is report/pdf.py's.

Every file the certificate reads - templates, stylesheets and images of the template
folders, the plots beside a results.json - is a regular file inside its folder after
resolving links, of bounded size (the limits below, listed in docs/errors.md).
"""

from __future__ import annotations

import math
import re
import traceback
from pathlib import Path

import jinja2
from jinja2.compiler import CodeGenerator
from jinja2.loaders import split_template_path
from jinja2.sandbox import SandboxedEnvironment, SecurityError, safe_range

from armcal.support.errors import UserError
from armcal.support.fileio import MiB, decoded, read_regular, write_bytes_atomic
from armcal.support.output_set import check_set, replace_in_set
from armcal.report.context import certificate_context
from armcal.results.history import history_entries
from armcal.results.reader import read_earlier, read_results, results_file
from armcal.results.schema import Results

PACKAGED = Path(__file__).resolve().parent.parent / "templates"
TEMPLATE = "certificate.html.j2"
CERTIFICATES = ("certificate.pdf", "certificate.html")

FOLDER_FILE_LIMIT = 1 * MiB  # a template, stylesheet or image of a template folder
PLOT_LIMIT = 10 * MiB  # an SVG plot beside results.json
TEXT_LIMIT = 256 * MiB  # text one render may make: each value it prints and each join (output, blocks, macros), counted together
RANGE_LIMIT = 1_000_000  # items of all range() calls of one render (each at most the sandbox's 100000)
REPEAT_LIMIT = 1_000_000  # items of a string or list repeated with *
NUMBER_BITS = 128  # integers computed with * and ** stay below 2**128
FORMAT_WIDTH = re.compile(r"%[-+ #0]*(\d+)")  # the width of each % conversion


def template_folders(user_folder: Path | None) -> list[Path]:
    """A user's template folder first, then the packaged one."""
    return ([user_folder] if user_folder else []) + [PACKAGED]


def read_inside(folder: Path, name: str, limit: int) -> bytes | None:
    """The bytes of file ``name`` of ``folder`` (read_regular), refused if it leads outside the folder (a link, '..', an absolute path)."""
    shown = Path(folder) / name
    try:
        root = Path(folder).resolve()
        path = (root / name).resolve()
    except (OSError, RuntimeError, ValueError) as exc:  # RuntimeError: a loop of links
        raise UserError(f"{shown}: cannot read the file ({exc})") from None
    if not path.is_relative_to(root):
        raise UserError(f"{shown} leads outside {folder} (a link, '..' or an absolute path); only files inside the folder are read")
    return read_regular(path, limit, shown)


class FolderLoader(jinja2.BaseLoader):
    """Templates from the first folder that has them, each read with read_inside; remembers the files it served."""

    def __init__(self, folders: list[Path]):
        self.folders = folders
        self.served: list[str] = []  # the first is the certificate's own template

    def get_source(self, environment, template: str):
        name = "/".join(split_template_path(template))  # refuses '..'
        for folder in self.folders:
            data = read_inside(folder, name, FOLDER_FILE_LIMIT)
            if data is not None:
                filename = str(Path(folder) / name)
                self.served.append(filename)
                return decoded(data, Path(filename)), filename, None
        raise jinja2.TemplateNotFound(template)


class CountingCodeGenerator(CodeGenerator):
    """Jinja's code generator with every ``~`` concatenation's result counted by the environment's text limit."""

    def visit_Concat(self, node, frame) -> None:
        self.write("environment.counted(")
        super().visit_Concat(node, frame)
        self.write(")")


class CertificateEnvironment(SandboxedEnvironment):
    """The sandbox (a template cannot reach Python internals) with bounds on what one render may build:
    range() items, repetition with *, integer size, widths given to str methods and % formats, and text (each
    printed value, each ~ concatenation and each join, counted together)."""

    intercepted_binops = frozenset({"*", "**", "%"})
    code_generator_class = CountingCodeGenerator

    def __init__(self, folders: list[Path]):
        super().__init__(loader=FolderLoader(folders), autoescape=True, undefined=jinja2.StrictUndefined, finalize=self.printed)
        self.globals["range"] = self.bounded_range
        del self.globals["lipsum"]  # lipsum(n) has no bound on n
        self.ranged = 0
        self.characters = 0

    def count_text(self, length: int) -> None:
        self.characters += length
        if self.characters > TEXT_LIMIT:
            raise SecurityError(f"the template renders more than {TEXT_LIMIT // MiB} MiB of text")

    def bounded_range(self, *args: int) -> range:
        """range() as the sandbox allows it, with at most RANGE_LIMIT items over the whole render."""
        items = safe_range(*args)
        self.ranged += len(items)
        if self.ranged > RANGE_LIMIT:
            raise SecurityError(f"the template's loops run over more than {RANGE_LIMIT} range() items")
        return items

    def counted(self, text):
        """A ``~`` concatenation's result, counted (so a string doubled in a loop stops at the text limit)."""
        self.count_text(len(text))
        return text

    def call(self, __context, __obj, *args, **kwargs):
        """Calls, with no integer argument above REPEAT_LIMIT for a str method (center, ljust, zfill, format ...)."""
        if isinstance(getattr(__obj, "__self__", None), str) and any(_integers(a) and abs(a) > REPEAT_LIMIT for a in (*args, *kwargs.values())):
            raise SecurityError(f"a width above {REPEAT_LIMIT} given to a string method")
        return super().call(__context, __obj, *args, **kwargs)

    def call_binop(self, context, operator: str, left, right):
        """``*``, ``**`` and ``%`` with bounded results: no gigabyte strings or million-digit numbers from one expression."""
        if operator == "%" and isinstance(left, str) and any(int(width) > REPEAT_LIMIT for width in FORMAT_WIDTH.findall(left)):
            raise SecurityError(f"a width above {REPEAT_LIMIT} in a % format")
        if operator == "**" and _integers(left, right) and abs(left) > 1 and right * math.log2(abs(left)) >= NUMBER_BITS:
            raise SecurityError(f"{left} ** {right} is too large (integers stay below 2**{NUMBER_BITS})")
        if operator == "*":
            if _integers(left, right) and abs(left).bit_length() + abs(right).bit_length() > NUMBER_BITS:
                raise SecurityError(f"the product is too large (integers stay below 2**{NUMBER_BITS})")
            sequence, count = (left, right) if isinstance(right, int) else (right, left)
            if isinstance(sequence, (str, list, tuple)) and isinstance(count, int):
                size = len(sequence) * max(count, 0)
                if size > REPEAT_LIMIT:
                    raise SecurityError(f"'*' would repeat {len(sequence)} x {count} items (at most {REPEAT_LIMIT})")
                self.count_text(size)
        return super().call_binop(context, operator, left, right)

    def printed(self, value):
        """Each value a template prints (Jinja's finalize), counted as it is made."""
        self.count_text(len(value) if isinstance(value, str) else len(str(value)))
        return value

    def concat(self, pieces) -> str:
        """Join text (the output, a block, a macro's body), counted piece by piece."""
        kept = []
        for piece in pieces:
            try:
                self.count_text(len(piece))
            except SecurityError as exc:
                if hasattr(pieces, "throw"):  # the output, still being rendered: raise it at the template's line
                    pieces.throw(exc)
                raise
            kept.append(piece)
        return "".join(kept)


def _integers(*values) -> bool:
    """Whether every value is an int (bools included)."""
    return all(isinstance(v, int) for v in values)


def template_error(exc: BaseException, served: list[str]) -> str:
    """``file:line: message`` of an error raised while loading or rendering a template (the line where Jinja knows it)."""
    if isinstance(exc, jinja2.TemplateSyntaxError) and exc.filename:
        return f"{exc.filename}:{exc.lineno}: {exc.message}"
    if isinstance(exc, jinja2.TemplateNotFound):
        message = f"there is no template '{exc.name}' in the template folders"
    else:
        message = str(exc) or type(exc).__name__
    lines = [f"{frame.filename}:{frame.lineno}" for frame in traceback.extract_tb(exc.__traceback__) if frame.filename in served]
    where = lines[-1] if lines else served[0] if served else ""
    return f"{where}: {message}" if where else message


NAMING = (jinja2.nodes.Include, jinja2.nodes.Import, jinja2.nodes.FromImport, jinja2.nodes.Extends)


def check_templates(folders: list[Path]) -> None:
    """Load and parse the certificate's template and every template it names by a constant (include, import,
    extends), as rendering will, before a run's work starts: a template the run could not use is refused first,
    as a UserError naming the file and line (render_html still guards what only rendering finds)."""
    environment = CertificateEnvironment(folders)
    pending, seen = [(TEMPLATE, "")], set()
    while pending:
        name, where = pending.pop()
        if name in seen:
            continue
        seen.add(name)
        try:
            source, filename, _ = environment.loader.get_source(environment, name)
            tree = environment.parse(source, name, filename)
        except jinja2.TemplateSyntaxError as exc:
            raise UserError(template_error(exc, [])) from exc
        except (UserError, jinja2.TemplateNotFound) as exc:
            message = template_error(exc, []) if isinstance(exc, jinja2.TemplateNotFound) else str(exc)
            raise UserError(f"{where}: {message}" if where else message) from exc
        for node in tree.find_all(NAMING):
            if isinstance(node.template, jinja2.nodes.Const) and isinstance(node.template.value, str):
                pending.append((node.template.value, f"{filename}:{node.lineno}"))


def render_html(context: dict, folders: list[Path]) -> str:
    """The certificate's HTML; any error in a template becomes a UserError naming its file and line."""
    environment = CertificateEnvironment(folders)
    try:
        return environment.get_template(TEMPLATE).render(**context)
    except Exception as exc:  # whatever a template does wrong (syntax, undefined value, a limit, a Python error) is the template's
        raise UserError(template_error(exc, environment.loader.served)) from exc


def render_certificate(context: dict, folders: list[Path], pdf: bool, created: str) -> dict[str, bytes]:
    """certificate.html (and .pdf) from the template context."""
    html = render_html(context, folders)
    files = {"certificate.html": html.encode("utf-8")}
    if pdf:
        from armcal.report.pdf import render_pdf  # WeasyPrint takes seconds to import: only a run that prints a PDF pays it

        files["certificate.pdf"] = render_pdf(html, folders, created)
    return files


def certificate_files(results: Results, plots: dict[str, str], pdf: bool = True, user_templates: Path | None = None) -> dict[str, bytes]:
    """certificate.html (and .pdf) of ``results``, rendered in memory."""
    return render_certificate(certificate_context(results, plots), template_folders(user_templates), pdf, results.created)


def write_files(folder: Path, files: dict[str, bytes | str]) -> list[Path]:
    """Each file written whole (after everything was rendered: a failure leaves the old set intact)."""
    written = []
    for name, content in files.items():
        path = Path(folder) / name
        write_bytes_atomic(path, content.encode("utf-8") if isinstance(content, str) else content)
        written.append(path)
    return written


def read_plots(results_path: Path, names: list[str]) -> dict[str, str]:
    """The SVG plots a results.json lists, from its folder (read_inside, PLOT_LIMIT each); a missing one is left out."""
    plots = {}
    for name in names:
        try:
            data = read_inside(results_path.parent, name, PLOT_LIMIT)
            if data is not None:
                plots[name] = decoded(data, results_path.parent / name)
        except UserError as exc:
            raise UserError(f"{results_path} lists the plot {name!r}: {exc}") from None
    return plots


def rerender(results_path: Path, pdf: bool = True, force: bool = False, history: list[Path] = ()) -> list[Path]:
    """``armcal report``: the certificate again, from results.json alone (and the plots beside it), into its output set;
    with ``history``, that section from those earlier results instead of the one results.json holds."""
    results_path = results_file(Path(results_path))
    folder = results_path.parent
    results = read_results(results_path)
    if history:
        earlier = read_earlier(history, results.robot.serial, str(results_path))
        results = results.model_copy(update={"history": history_entries(results, earlier)})
    plots = read_plots(results_path, results.diagnosis.plots)
    check_set(folder, [results_path.name, *plots])
    existing = [name for name in CERTIFICATES if (folder / name).exists()]
    if existing and not force:
        raise UserError(f"{folder / existing[0]} exists; use --force to replace the certificate")
    try:
        context = certificate_context(results, plots)
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as exc:  # what validation lets through, the certificate cannot show
        raise UserError(f"{results_path}: not a results.json as armcal writes it ({type(exc).__name__}: {exc})") from None
    return replace_in_set(folder, render_certificate(context, template_folders(None), pdf, results.created))

"""What tasks.sh sets up on a fresh Debian: WeasyPrint finds every system library it asks for, HarfBuzz-Subset
included, so rendering a certificate prints no warning (issue 28)."""

import subprocess
import sys


def test_weasyprint_renders_without_a_warning(tmp_path):
    code = ("import logging, weasyprint; logging.getLogger('weasyprint').addHandler(logging.StreamHandler()); "
            "weasyprint.HTML(string='<p>armcal</p>').write_pdf(sys.argv[1])")  # its log (font subsetting) to stderr too
    done = subprocess.run([sys.executable, "-W", "always", "-c", "import sys; " + code, str(tmp_path / "a.pdf")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert not [line for line in done.stderr.splitlines() if "weasyprint" in line.lower() or "harfbuzz" in line.lower()], done.stderr
    assert (tmp_path / "a.pdf").read_bytes().startswith(b"%PDF")

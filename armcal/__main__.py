"""``python -m armcal`` runs the command line."""

from armcal.cli import app

app(prog_name="armcal")

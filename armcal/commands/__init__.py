"""The commands behind the CLI (armcal/cli.py), one module each: run (a spec through the pipeline), plan, montecarlo,
batch (fleets), new (a starting spec), and terminal (what they print). docs/architecture.md gives the layers."""

"""The commands behind the CLI (armcal/cli.py), one module each: run (a spec through the pipeline), plan, montecarlo,
batch (fleets), new (a starting spec), terminal (what they print) and workers (a fleet's or a study's tasks on
worker processes or a Dask cluster). docs/architecture.md gives the layers."""

"""What every layer leans on and none is about calibration: user-facing errors (errors.py), units (units.py), safe file
reading and writing (fileio.py), the output folder's one complete set (output_set.py), git revisions (gitrepo.py) and
progress lines (progress.py). docs/architecture.md gives the layers."""

"""Reports: residual plots (the certificate comes later)."""

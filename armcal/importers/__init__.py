"""Robot descriptions from other tools made into armcal specs (docs/export.md, "URDF in")."""

"""One module per effect type on the robot's side or on any length reading (effects/registry.py lists them)."""

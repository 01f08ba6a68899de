"""The residual diagnosis: candidate effects, score tests, the refit loop."""

"""Evaluation: residual statistics, validation, improvement factors, evaluation tasks."""

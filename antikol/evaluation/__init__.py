"""Evaluation tools: scenarios, ground truth, scoring, comparison figures and log replay."""

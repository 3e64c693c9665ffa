# SPDX-License-Identifier: MIT
"""Evaluation and benchmarks: verifier/detector tables, recall, temporal and fleet runs,
speed benchmarks. Imports the layers below, training included."""

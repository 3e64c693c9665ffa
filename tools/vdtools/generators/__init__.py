# SPDX-License-Identifier: MIT
"""Generators of committed files: golden vectors, the embedded report, the median network
of lib/src/pixel/median.c. Top layer."""

# SPDX-License-Identifier: MIT
"""Data sets and clips: frame loaders, splits, training samples cut by the C library, the
synthetic and bundled clips. Imports vdtools.bindings only."""

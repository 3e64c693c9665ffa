# SPDX-License-Identifier: MIT
"""The C library through ctypes: the only layer that knows C struct layouts and prototypes
(tests/python/test_bindings_layout.py checks every mirror against the C build). Imports nothing else
from vdtools."""

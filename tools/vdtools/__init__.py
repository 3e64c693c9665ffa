# SPDX-License-Identifier: MIT
"""Python tools of vd: data sets, training, quantisation, export, evaluation.

Layered (docs/architecture.md): bindings < data, metrics < formats < training < evaluation <
generators; a module imports only its own subpackage or lower layers (tests/python/test_layers.py).
Everything that touches the detector calls the C library itself through its shared build, via
vdtools.bindings (see :mod:`vdtools.bindings.clib`)."""

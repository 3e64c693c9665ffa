# SPDX-License-Identifier: MIT
"""Python tools of vd: data sets, training, quantisation, export, evaluation.

Everything that touches the detector calls the C library itself through its
shared build (see :mod:`vdtools.clib`)."""
